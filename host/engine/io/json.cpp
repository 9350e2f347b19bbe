#include "io/json.hpp"

#include <cmath>
#include <cstdio>

namespace vkmech {

std::string json_escape(const std::string& s) {
    std::string o;
    for (char c : s) {
        switch (c) {
            case '"':
                o += "\\\"";
                break;
            case '\\':
                o += "\\\\";
                break;
            case '\n':
                o += "\\n";
                break;
            case '\t':
                o += "\\t";
                break;
            default:
                if (static_cast<unsigned char>(c) < 0x20) {
                    char b[8];
                    std::snprintf(b, sizeof b, "\\u%04x", static_cast<unsigned char>(c));
                    o += b;
                } else {
                    o += c;
                }
        }
    }
    return o;
}

std::string json_string(const std::string& s) {
    std::string r = "\"";  // appended piecewise: GCC 12 warns falsely (-Wrestrict) on "\"" + std::string
    r += json_escape(s);
    r += '"';
    return r;
}

std::string json_number(double x) {
    if (!std::isfinite(x)) return "null";
    char b[64];
    std::snprintf(b, sizeof b, "%.9g", x);
    return b;
}

}  // namespace vkmech
