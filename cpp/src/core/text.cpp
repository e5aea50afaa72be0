#include "text.hpp"

#include <charconv>
#include <locale>
#include <sstream>
#include <system_error>

namespace tubempc::core::text {

namespace {

// from_chars takes no '+': drop one leading '+' (not followed by another sign). False if nothing is left.
bool strip_plus(std::string_view& token) {
  if (!token.empty() && token.front() == '+') {
    token.remove_prefix(1);
    if (!token.empty() && (token.front() == '+' || token.front() == '-')) return false;
  }
  return !token.empty();
}

}  // namespace

void split(std::string_view line, std::vector<std::string_view>& out) {
  out.clear();
  constexpr std::string_view kSpace = " \t\r\v\f";
  std::size_t i = line.find_first_not_of(kSpace);
  while (i != std::string_view::npos) {
    const std::size_t end = line.find_first_of(kSpace, i);
    out.push_back(line.substr(i, end == std::string_view::npos ? std::string_view::npos : end - i));
    i = end == std::string_view::npos ? end : line.find_first_not_of(kSpace, end);
  }
}

bool parse_double(std::string_view token, double& value) {
  if (!strip_plus(token)) return false;
#if defined(__cpp_lib_to_chars) && __cpp_lib_to_chars >= 201611L
  // Out of range (|x| > DBL_MAX, or a nonzero below the subnormals) is a failure, not a silent inf or 0.
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && end == token.data() + token.size();
#else
  std::istringstream in{std::string(token)};
  in.imbue(std::locale::classic());
  in >> value;
  return !in.fail() && in.peek() == std::char_traits<char>::eof();
#endif
}

bool parse_int64(std::string_view token, std::int64_t& value) {
  if (!strip_plus(token)) return false;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && end == token.data() + token.size();
}

std::string format_double(double value) {
#if defined(__cpp_lib_to_chars) && __cpp_lib_to_chars >= 201611L
  char buf[64];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, value, std::chars_format::general, 17);
  if (ec == std::errc()) return std::string(buf, end);
#endif
  std::ostringstream out;
  out.imbue(std::locale::classic());
  out.precision(17);
  out << value;
  return out.str();
}

}  // namespace tubempc::core::text
