#include "scene/xml_document.hpp"

#include "scene/file_read.hpp"
#include "scene/scene.hpp"

#include <algorithm>
#include <utility>

namespace vkmech {

XmlDocument::XmlDocument(std::string path, const std::string& from_file, int from_line) : path_(std::move(path)) {
    if (from_file.empty()) {
        text_ = read_regular_file(path_, "scene file", kMaxIncludedXmlBytes);
    } else {
        try {
            text_ = read_regular_file(path_, "included file '" + path_ + "'", kMaxIncludedXmlBytes);
        } catch (const SceneError& e) {
            throw SceneError(from_file, from_line, e.reason());
        }
    }
    line_starts_.push_back(0);
    for (size_t i = 0; i < text_.size(); ++i)
        if (text_[i] == '\n') line_starts_.push_back(i + 1);
    // load_buffer copies; offsets (offset_debug, result.offset) are relative
    // to the bytes as read, which is what the line table indexes (UTF-8).
    pugi::xml_parse_result r = doc_.load_buffer(text_.data(), text_.size(), pugi::parse_default, pugi::encoding_utf8);
    if (!r) throw SceneError(path_, line_at(r.offset), std::string("malformed XML: ") + r.description());
    if (!doc_.document_element()) throw SceneError(path_, 0, "malformed XML: no root element");
    check_nesting();
}

void XmlDocument::check_nesting() const {
    // pugixml parses iteratively, but the loader walks plugins recursively
    // (a twosided bsdf inside a twosided bsdf ...): bound the depth here,
    // walking without recursion.
    pugi::xml_node n = doc_.document_element();
    int depth = 1;
    while (n) {
        if (depth > kMaxNesting)
            throw SceneError(path_, line_of(n),
                             "nesting deeper than " + std::to_string(kMaxNesting) + " elements at line " +
                                 std::to_string(line_of(n)) +
                                 " (a scene needs far fewer; a corrupt or generated file?)");
        if (pugi::xml_node c = n.first_child()) {
            n = c;
            ++depth;
            continue;
        }
        while (n && !n.next_sibling()) {
            n = n.parent();
            --depth;
        }
        if (n) n = n.next_sibling();
    }
}

int XmlDocument::line_at(ptrdiff_t byte_offset) const {
    if (byte_offset < 0) return 0;
    auto it = std::upper_bound(line_starts_.begin(), line_starts_.end(), static_cast<size_t>(byte_offset));
    return static_cast<int>(it - line_starts_.begin());
}

int XmlDocument::line_of(const pugi::xml_node& n) const { return line_at(n.offset_debug()); }

}  // namespace vkmech
