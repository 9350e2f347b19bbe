#include "report/figure.hpp"

#include "io/atomic_file.hpp"
#include "report/table.hpp"

#include <cmath>
#include <filesystem>
#include <sstream>

namespace vkmech::report {

namespace {
std::string arr(const std::vector<double>& v) {
    std::string o = "[";
    for (size_t i = 0; i < v.size(); ++i) {
        if (i) o += ',';
        o += json_number(v[i]);
    }
    return o + "]";
}
}  // namespace

std::string Figure::json() const {
    std::ostringstream o;
    o << "{\n  \"title\": " << json_string(title) << ",\n";
    if (!caption.empty()) o << "  \"caption\": " << json_string(caption) << ",\n";
    if (columns > 0) o << "  \"columns\": " << columns << ",\n";
    if (panel_size)
        o << "  \"panel_size\": [" << json_number(panel_size->first) << ", " << json_number(panel_size->second)
          << "],\n";
    o << "  \"panels\": [\n";
    for (size_t pi = 0; pi < panels.size(); ++pi) {
        const Panel& p = panels[pi];
        o << "    {\"kind\": " << json_string(p.kind) << ", \"title\": " << json_string(p.title)
          << ", \"xlabel\": " << json_string(p.xlabel) << ", \"ylabel\": " << json_string(p.ylabel);
        if (p.logx) o << ", \"logx\": true";
        if (p.logy) o << ", \"logy\": true";
        if (p.diagonal) o << ", \"diagonal\": true";
        if (p.xlim) o << ", \"xlim\": [" << json_number(p.xlim->first) << ", " << json_number(p.xlim->second) << "]";
        if (p.ylim) o << ", \"ylim\": [" << json_number(p.ylim->first) << ", " << json_number(p.ylim->second) << "]";
        if (!p.categories.empty()) {
            o << ", \"categories\": [";
            for (size_t i = 0; i < p.categories.size(); ++i) o << (i ? ", " : "") << json_string(p.categories[i]);
            o << "]";
        }
        if (!p.hlines.empty()) {
            o << ", \"hlines\": [";
            for (size_t i = 0; i < p.hlines.size(); ++i)
                o << (i ? ", " : "") << "{\"y\": " << json_number(p.hlines[i].y)
                  << ", \"label\": " << json_string(p.hlines[i].label)
                  << ", \"linestyle\": " << json_string(p.hlines[i].linestyle)
                  << ", \"color\": " << json_string(p.hlines[i].color) << "}";
            o << "]";
        }
        o << ",\n     \"series\": [";
        for (size_t si = 0; si < p.series.size(); ++si) {
            const Series& s = p.series[si];
            o << (si ? ",\n       " : "\n       ") << "{\"label\": " << json_string(s.label);
            if (!s.x.empty()) o << ", \"x\": " << arr(s.x);
            o << ", \"y\": " << arr(s.y);
            if (!s.lo.empty()) o << ", \"lo\": " << arr(s.lo) << ", \"hi\": " << arr(s.hi);
            if (!s.color.empty()) o << ", \"color\": " << json_string(s.color);
            if (!s.marker.empty()) o << ", \"marker\": " << json_string(s.marker);
            if (!s.linestyle.empty()) o << ", \"linestyle\": " << json_string(s.linestyle);
            if (s.size > 0) o << ", \"size\": " << json_number(s.size);
            if (s.alpha > 0) o << ", \"alpha\": " << json_number(s.alpha);
            if (!s.lower_bound.empty()) {
                o << ", \"lower_bound\": [";
                for (size_t i = 0; i < s.lower_bound.size(); ++i)
                    o << (i ? "," : "") << (s.lower_bound[i] ? "true" : "false");
                o << "]";
            }
            o << "}";
        }
        o << "]}" << (pi + 1 < panels.size() ? "," : "") << "\n";
    }
    o << "  ]\n}\n";
    return o.str();
}

std::string write_figure(const std::string& dir, const Figure& f) {
    std::string p = (std::filesystem::path(dir) / (f.name + ".json")).string();
    write_file_atomic(p, f.json());
    return p;
}

}  // namespace vkmech::report
