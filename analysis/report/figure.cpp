#include "report/figure.hpp"

#include "io/atomic_file.hpp"
#include "report/table.hpp"

#include <cmath>
#include <filesystem>
#include <sstream>

namespace vkmech::report {

namespace {
std::string num(double v) { return std::isfinite(v) ? format("%.9g", v) : "null"; }
std::string q(const std::string& s) { return "\"" + json_escape(s) + "\""; }
std::string arr(const std::vector<double>& v) {
    std::string o = "[";
    for (size_t i = 0; i < v.size(); ++i) o += (i ? "," : "") + num(v[i]);
    return o + "]";
}
}  // namespace

std::string Figure::json() const {
    std::ostringstream o;
    o << "{\n  \"title\": " << q(title) << ",\n";
    if (!caption.empty()) o << "  \"caption\": " << q(caption) << ",\n";
    if (columns > 0) o << "  \"columns\": " << columns << ",\n";
    if (panel_size) o << "  \"panel_size\": [" << num(panel_size->first) << ", " << num(panel_size->second) << "],\n";
    o << "  \"panels\": [\n";
    for (size_t pi = 0; pi < panels.size(); ++pi) {
        const Panel& p = panels[pi];
        o << "    {\"kind\": " << q(p.kind) << ", \"title\": " << q(p.title) << ", \"xlabel\": " << q(p.xlabel)
          << ", \"ylabel\": " << q(p.ylabel);
        if (p.logx) o << ", \"logx\": true";
        if (p.logy) o << ", \"logy\": true";
        if (p.diagonal) o << ", \"diagonal\": true";
        if (p.xlim) o << ", \"xlim\": [" << num(p.xlim->first) << ", " << num(p.xlim->second) << "]";
        if (p.ylim) o << ", \"ylim\": [" << num(p.ylim->first) << ", " << num(p.ylim->second) << "]";
        if (!p.categories.empty()) {
            o << ", \"categories\": [";
            for (size_t i = 0; i < p.categories.size(); ++i) o << (i ? ", " : "") << q(p.categories[i]);
            o << "]";
        }
        if (!p.hlines.empty()) {
            o << ", \"hlines\": [";
            for (size_t i = 0; i < p.hlines.size(); ++i)
                o << (i ? ", " : "") << "{\"y\": " << num(p.hlines[i].y) << ", \"label\": " << q(p.hlines[i].label)
                  << ", \"linestyle\": " << q(p.hlines[i].linestyle) << ", \"color\": " << q(p.hlines[i].color) << "}";
            o << "]";
        }
        o << ",\n     \"series\": [";
        for (size_t si = 0; si < p.series.size(); ++si) {
            const Series& s = p.series[si];
            o << (si ? ",\n       " : "\n       ") << "{\"label\": " << q(s.label);
            if (!s.x.empty()) o << ", \"x\": " << arr(s.x);
            o << ", \"y\": " << arr(s.y);
            if (!s.lo.empty()) o << ", \"lo\": " << arr(s.lo) << ", \"hi\": " << arr(s.hi);
            if (!s.color.empty()) o << ", \"color\": " << q(s.color);
            if (!s.marker.empty()) o << ", \"marker\": " << q(s.marker);
            if (!s.linestyle.empty()) o << ", \"linestyle\": " << q(s.linestyle);
            if (s.size > 0) o << ", \"size\": " << num(s.size);
            if (s.alpha > 0) o << ", \"alpha\": " << num(s.alpha);
            if (!s.lower_bound.empty()) {
                o << ", \"lower_bound\": [";
                for (size_t i = 0; i < s.lower_bound.size(); ++i) o << (i ? "," : "") << (s.lower_bound[i] ? "true" : "false");
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
