#pragma once
// The one conversion for a number read from a file (monomeshd.toml, calibration TOML): to the
// field's type within the field's range, so that nothing wraps (max_entries = 4294967297 cast
// to int is 1), nothing non-finite (inf, nan) and nothing absurd (timeout_s = 1e300) gets past
// the reader. Each reader names the file and the key around the problem it returns.
//
// Thread-safety: reentrant.

#include <charconv>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <type_traits>
#include <variant>

namespace mm {

/// A number as a parser hands it out: an integer literal or a floating-point literal.
using ParsedNumber = std::variant<int64_t, double>;

/// The values a field accepts, bounds included.
template <typename T>
struct NumberRange {
  T min;
  T max;
};

namespace checked_number_detail {

inline std::string Text(double v) {
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof(buf), v);
  return ec == std::errc() ? std::string(buf, end) : std::string("?");
}

template <typename T>
std::string Expected(NumberRange<T> range) {
  if constexpr (std::is_integral_v<T>) {
    return "an integer in [" + std::to_string(range.min) + ", " + std::to_string(range.max) + "]";
  } else {
    return "a finite number in [" + Text(range.min) + ", " + Text(range.max) + "]";
  }
}

}  // namespace checked_number_detail

/// `parsed` as T, or nullopt with *problem saying what the field takes and what it got, e.g.
/// "expected an integer in [0, 1000000], got 4294967297". An integer field takes an integer
/// literal or a floating literal with an integral value (1e3); a floating field takes either,
/// finite. T is an integral (not bool) or floating-point type that holds the range.
template <typename T>
std::optional<T> CheckedNumber(const ParsedNumber& parsed, NumberRange<T> range,
                               std::string* problem) {
  static_assert(std::is_arithmetic_v<T> && !std::is_same_v<T, bool>);
  using checked_number_detail::Expected;
  using checked_number_detail::Text;
  const std::string got = std::holds_alternative<int64_t>(parsed)
                              ? std::to_string(std::get<int64_t>(parsed))
                              : Text(std::get<double>(parsed));
  auto fail = [&]() -> std::optional<T> {
    *problem = "expected " + Expected(range) + ", got " + got;
    return std::nullopt;
  };
  if constexpr (std::is_integral_v<T>) {
    int64_t v = 0;
    if (const auto* i = std::get_if<int64_t>(&parsed)) {
      v = *i;
    } else {
      const double d = std::get<double>(parsed);
      // The bounds are compared as doubles first: a cast of 1e300 to int64_t is undefined.
      if (!std::isfinite(d) || d != std::floor(d) || d < static_cast<double>(range.min) ||
          d > static_cast<double>(range.max)) {
        return fail();
      }
      v = static_cast<int64_t>(d);
    }
    if (v < static_cast<int64_t>(range.min) || v > static_cast<int64_t>(range.max)) return fail();
    return static_cast<T>(v);
  } else {
    const double d = std::holds_alternative<int64_t>(parsed)
                         ? static_cast<double>(std::get<int64_t>(parsed))
                         : std::get<double>(parsed);
    if (!std::isfinite(d) || d < static_cast<double>(range.min) ||
        d > static_cast<double>(range.max)) {
      return fail();
    }
    return static_cast<T>(d);
  }
}

/// The same from a parser's node: anything with as_integer() and as_floating_point() returning
/// a pointer to something with get() (toml::node); a string, boolean, array ... is "wrong type".
template <typename T, typename Node>
std::optional<T> CheckedNumberOf(const Node& node, NumberRange<T> range, std::string* problem) {
  if (const auto* i = node.as_integer()) return CheckedNumber<T>(int64_t{i->get()}, range, problem);
  if (const auto* f = node.as_floating_point()) {
    return CheckedNumber<T>(double{f->get()}, range, problem);
  }
  *problem = "wrong type: expected " + checked_number_detail::Expected(range);
  return std::nullopt;
}

}  // namespace mm
