#include "report/table.hpp"

#include "io/atomic_file.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

namespace vkmech::report {

std::string format(const char* fmt, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, fmt, v);
    return buf;
}

Cell Cell::num(double v, const char* fmt, const std::string& nan_text) {
    if (!std::isfinite(v)) return {nan_text, ""};
    return {format(fmt, v), format("%.9g", v)};
}

Cell Cell::pct(double share, int decimals, const std::string& nan_text) {
    if (!std::isfinite(share)) return {nan_text, ""};
    char fmt[16];
    std::snprintf(fmt, sizeof fmt, "%%.%df%%%%", decimals);
    return {format(fmt, 100.0 * share), format("%.9g", share)};
}

Cell Cell::integer(long long v) { return {std::to_string(v), std::to_string(v)}; }

std::string csv_escape(const std::string& s) {
    if (s.find_first_of(",\"\n") == std::string::npos) return s;
    std::string o = "\"";
    for (char c : s) o += c == '"' ? std::string("\"\"") : std::string(1, c);
    return o + "\"";
}

std::string Table::markdown() const {
    std::ostringstream o;
    if (!title.empty()) o << "**" << title << "**\n\n";
    o << "|";
    for (const auto& c : columns) o << " " << c << " |";
    o << "\n|";
    for (size_t i = 0; i < columns.size(); ++i) o << (i == 0 ? ":---|" : "---:|");
    o << "\n";
    for (const auto& r : rows) {
        o << "|";
        for (const auto& c : r) o << " " << c.text << " |";
        o << "\n";
    }
    if (!note.empty()) o << "\n" << note << "\n";
    return o.str();
}

std::string Table::csv() const {
    std::ostringstream o;
    for (size_t i = 0; i < columns.size(); ++i) o << (i ? "," : "") << csv_escape(columns[i]);
    o << "\n";
    for (const auto& r : rows) {
        for (size_t i = 0; i < r.size(); ++i) o << (i ? "," : "") << csv_escape(r[i].csv);
        o << "\n";
    }
    return o.str();
}

std::string write_table(const std::string& dir, const Table& t) {
    namespace fs = std::filesystem;
    std::string md = (fs::path(dir) / (t.name + ".md")).string();
    write_file_atomic(md, t.markdown());
    write_file_atomic((fs::path(dir) / (t.name + ".csv")).string(), t.csv());
    return md;
}

}  // namespace vkmech::report
