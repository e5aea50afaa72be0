// Internal helpers of the text readers and writers (gravity/shape_io.cpp, io/scenario.cpp):
// locale-independent number parsing and formatting and whitespace tokenising. Not installed.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace tubempc::core::text {

// Splits `line` at spaces, tabs, carriage returns and vertical tabs / form feeds into `out` (cleared
// first); the views point into `line`.
void split(std::string_view line, std::vector<std::string_view>& out);

// Parses the whole token as a double (C locale; an optional leading '+'; "inf" and "nan" are read
// as such and left to the caller to reject). Returns false if the token is not exactly one number
// or lies outside the range of double.
bool parse_double(std::string_view token, double& value);

// Parses the whole token as a signed 64-bit integer (optional leading '+' or '-').
bool parse_int64(std::string_view token, std::int64_t& value);

// Shortest-round-trip-safe text of a double: printf's "%.17g" in the C locale ("inf", "-inf", "nan").
std::string format_double(double value);

}  // namespace tubempc::core::text
