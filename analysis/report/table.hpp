// Result tables written twice: Markdown for reading (cells formatted as the
// paper prints them, LaTeX label in the title) and CSV for further analysis
// (full-precision numbers, NaN as an empty field).
#pragma once

#include "io/json.hpp"  // json_escape, for the table and figure writers

#include <string>
#include <variant>
#include <vector>

namespace vkmech::report {

// A cell: text, or a number with its Markdown formatting.
struct Cell {
    std::string text;  // Markdown text
    std::string csv;   // CSV field
    static Cell str(const std::string& s) { return {s, s}; }
    // printf-style `fmt` for Markdown (e.g. "%.3f"); NaN shows as `nan_text`.
    static Cell num(double v, const char* fmt = "%.3f", const std::string& nan_text = "---");
    static Cell pct(double share, int decimals = 2, const std::string& nan_text = "---");  // 0.9558 -> "95.58%"
    static Cell integer(long long v);
};

struct Table {
    std::string name;   // file stem, e.g. "cross_spp"
    std::string title;  // e.g. "Cross-SPP stability of the dominant label (tab:cross-spp)"
    std::vector<std::string> columns;
    std::vector<std::vector<Cell>> rows;
    std::string note;  // printed under the Markdown table

    void add(std::vector<Cell> row) { rows.push_back(std::move(row)); }
    std::string markdown() const;  // title, table, note
    std::string csv() const;
};

// Writes DIR/NAME.md and DIR/NAME.csv atomically; returns the .md path.
std::string write_table(const std::string& dir, const Table& t);

std::string csv_escape(const std::string& s);
std::string format(const char* fmt, double v);

}  // namespace vkmech::report
