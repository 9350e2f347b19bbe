// JSON string escaping shared by every JSON vkmech writes (render summaries,
// output-set manifests, study tables and figure specs).
#pragma once

#include <string>

namespace vkmech {

// The body of a JSON string literal for `s`: quotes and backslashes escaped,
// control characters as \n, \t or \u00XX.
std::string json_escape(const std::string& s);
// A JSON string literal: s escaped, in double quotes.
std::string json_string(const std::string& s);
// A JSON number with 9 significant digits (%.9g), or null when x is not finite.
std::string json_number(double x);

}  // namespace vkmech
