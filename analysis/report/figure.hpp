// Figure specifications: the experiments describe each chart as JSON
// (analysis/plot_figures.py draws them with matplotlib), so the numbers
// plotted are exactly the ones computed here and the charts are redrawable.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace vkmech::report {

struct Series {
    std::string label;
    std::vector<double> x, y;    // NaN in y = missing
    std::vector<double> lo, hi;  // optional band (line) or error bars (bar)
    std::string color, marker, linestyle;
    double size = 0.0, alpha = 0.0;  // 0 = default
    std::vector<bool> lower_bound;   // bar: censored bars
};

struct HLine {
    double y = 0.0;
    std::string label, linestyle = "--", color = "#888888";
};

struct Panel {
    std::string kind = "line";  // line | scatter | bar
    std::string title, xlabel, ylabel;
    bool logx = false, logy = false, diagonal = false;
    std::optional<std::pair<double, double>> xlim, ylim;
    std::vector<std::string> categories;
    std::vector<Series> series;
    std::vector<HLine> hlines;
};

struct Figure {
    std::string name;  // file stem
    std::string title, caption;
    int columns = 0;
    std::vector<Panel> panels;
    std::optional<std::pair<double, double>> panel_size;  // inches per panel (the script's default: 4 x 3.2)
    std::string json() const;
};

// Writes DIR/NAME.json atomically; returns the path.
std::string write_figure(const std::string& dir, const Figure& f);

}  // namespace vkmech::report
