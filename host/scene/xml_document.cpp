#include "scene/xml_document.hpp"

#include "scene/scene.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>

namespace vkmech {

XmlDocument::XmlDocument(std::string path, const std::string& from_file, int from_line) : path_(std::move(path)) {
    std::ifstream in(path_, std::ios::binary);
    if (!in) {
        if (!from_file.empty()) throw SceneError(from_file, from_line, "cannot open included file '" + path_ + "'");
        throw SceneError(path_, 0, "cannot open scene file");
    }
    std::ostringstream ss;
    ss << in.rdbuf();
    text_ = std::move(ss).str();
    line_starts_.push_back(0);
    for (size_t i = 0; i < text_.size(); ++i)
        if (text_[i] == '\n') line_starts_.push_back(i + 1);
    // load_buffer copies; offsets (offset_debug, result.offset) are relative
    // to the bytes as read, which is what the line table indexes (UTF-8).
    pugi::xml_parse_result r = doc_.load_buffer(text_.data(), text_.size(), pugi::parse_default, pugi::encoding_utf8);
    if (!r) throw SceneError(path_, line_at(r.offset), std::string("malformed XML: ") + r.description());
    if (!doc_.document_element()) throw SceneError(path_, 0, "malformed XML: no root element");
}

int XmlDocument::line_at(ptrdiff_t byte_offset) const {
    if (byte_offset < 0) return 0;
    auto it = std::upper_bound(line_starts_.begin(), line_starts_.end(), static_cast<size_t>(byte_offset));
    return static_cast<int>(it - line_starts_.begin());
}

int XmlDocument::line_of(const pugi::xml_node& n) const { return line_at(n.offset_debug()); }

}  // namespace vkmech
