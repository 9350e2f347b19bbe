// Strict, locale-independent number parsing shared by the XML and mesh
// readers. "Strict" means the whole token must be consumed: "1.2.3" and
// "3abc" are errors rather than silently read as 1.2 and 3.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace vkmech::text {

std::string_view trim(std::string_view s);

// The whole of `s` (after trimming) as a number; nullopt if it is not one.
// "nan" and "inf" parse (callers decide whether non-finite is allowed).
std::optional<double> to_double(std::string_view s);
std::optional<long long> to_int(std::string_view s);

// The whole of `s` as a finite number that a 32-bit float (the renderer's
// precision) can hold, returned as parsed; otherwise nullopt, and `why`
// says what is wrong: "cannot parse 'x' as a number", "non-finite number
// 'nan'" or "value 1e39 overflows a 32-bit float".
std::optional<double> to_finite_float(std::string_view s, std::string& why);

// Splits "1, 2, 3", "1 2 3" or "1,2,3" into tokens (commas and whitespace
// both separate, as in Mitsuba's value lists).
std::vector<std::string_view> split_list(std::string_view s);

// Splits on whitespace only (mesh files).
std::vector<std::string_view> split_ws(std::string_view s);

// ASCII lower case, for case-insensitive keywords.
std::string lower(std::string_view s);

}  // namespace vkmech::text
