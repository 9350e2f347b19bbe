// JSON string escaping shared by every JSON vkmech writes (render summaries,
// output-set manifests, study tables and figure specs).
#pragma once

#include <string>

namespace vkmech {

// The body of a JSON string literal for `s`: quotes and backslashes escaped,
// control characters as \n, \t or \u00XX.
std::string json_escape(const std::string& s);

}  // namespace vkmech
