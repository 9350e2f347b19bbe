// One parsed XML file of a Mitsuba scene, with what error messages need:
// its path and a byte-offset -> line table (pugixml reports offsets).
#pragma once

#include <pugixml.hpp>

#include <string>
#include <vector>

namespace vkmech {

class XmlDocument {
public:
    static constexpr int kMaxNesting = 64;

    // Reads and parses `path` (a regular file of at most 64 MiB). A file
    // that cannot be read is reported at (`from_file`, `from_line`) when
    // given (an <include>), else at `path`; malformed XML, or elements
    // nested deeper than kMaxNesting, at `path` with the line.
    XmlDocument(std::string path, const std::string& from_file = {}, int from_line = 0);
    XmlDocument(const XmlDocument&) = delete;
    XmlDocument& operator=(const XmlDocument&) = delete;

    const std::string& path() const { return path_; }
    pugi::xml_node root() const { return doc_.document_element(); }

    // 1-based line of a node (0 if pugixml cannot tell).
    int line_of(const pugi::xml_node& n) const;
    int line_at(ptrdiff_t byte_offset) const;

private:
    void check_nesting() const;

    std::string path_;
    std::string text_;
    std::vector<size_t> line_starts_;
    pugi::xml_document doc_;
};

}  // namespace vkmech
