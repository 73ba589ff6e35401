// Validation of options structs. Every Check() is one list of field checks
// through an OptionChecker, and the first violation becomes the error: it
// names the option as the user spells it, its allowed range and the bad
// value, e.g. "GlobalMapper.rp_max_epipolar_error_px must be > 0, is -1", so
// that the command line and the GUI can report it in one line.
//
// The name is `prefix` + the field name. A stage's Check(prefix = "") names
// its fields; GlobalMapperOptions::Check passes the prefix of the stage's
// `GlobalMapper.*` keys ("GlobalMapper.rp_"), which is why every field that
// is an option has the name of its key without the prefix.
#pragma once

#include <charconv>
#include <string>
#include <utility>

#include "glomap/util/status.h"

namespace glomap {

namespace options_check_internal {

// Keeps a bound from taking part in template argument deduction, so that
// AtLeast("ratio", ratio, 0) compares a double with 0.0.
template <typename T>
struct Identity {
  using type = T;
};

inline std::string ValueText(int value) { return std::to_string(value); }

// The shortest text that reads back as the same double ("0.1", "1e-05",
// "-1e+09", "nan"), so the message shows exactly the value that was given.
inline std::string ValueText(double value) {
  char buffer[32];
  const std::to_chars_result result =
      std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

}  // namespace options_check_internal

template <typename T>
using OptionBound = typename options_check_internal::Identity<T>::type;

// Which ends of the range of InRange belong to it.
enum class Interval {
  kClosed,     // [min, max]
  kOpen,       // (min, max)
  kLeftOpen,   // (min, max]
  kRightOpen,  // [min, max)
};

class OptionChecker {
 public:
  explicit OptionChecker(std::string prefix) : prefix_(std::move(prefix)) {}

  // Each check records a violation unless `value` lies in the range; NaN
  // lies in none. Only the first violation is kept. T is int or double.
  template <typename T>
  void GreaterThan(const char* field, T value, OptionBound<T> min) {
    if (!(value > min)) Fail(field, "> " + Text(min), value);
  }
  template <typename T>
  void AtLeast(const char* field, T value, OptionBound<T> min) {
    if (!(value >= min)) Fail(field, ">= " + Text(min), value);
  }
  template <typename T>
  void AtMost(const char* field, T value, OptionBound<T> max) {
    if (!(value <= max)) Fail(field, "<= " + Text(max), value);
  }
  template <typename T>
  void InRange(const char* field, T value, OptionBound<T> min,
               OptionBound<T> max, Interval interval = Interval::kClosed) {
    const bool min_open =
        interval == Interval::kOpen || interval == Interval::kLeftOpen;
    const bool max_open =
        interval == Interval::kOpen || interval == Interval::kRightOpen;
    const bool above_min = min_open ? value > min : value >= min;
    const bool below_max = max_open ? value < max : value <= max;
    if (!(above_min && below_max)) {
      Fail(field,
           std::string("in ") + (min_open ? "(" : "[") + Text(min) + ", " +
               Text(max) + (max_open ? ")" : "]"),
           value);
    }
  }
  // -1 (a special meaning, such as "all cores"), or at least `min`.
  void MinusOneOrAtLeast(const char* field, int value, int min) {
    if (value != -1 && value < min) {
      Fail(field, "-1 or >= " + Text(min), value);
    }
  }

  // The same relations to another field of the same struct, which the
  // message names with the same prefix.
  template <typename T>
  void GreaterThanField(const char* field, T value, const char* other_field,
                        OptionBound<T> other_value) {
    if (!(value > other_value)) {
      Fail(field, "> " + Named(other_field, other_value), value);
    }
  }
  template <typename T>
  void AtLeastField(const char* field, T value, const char* other_field,
                    OptionBound<T> other_value) {
    if (!(value >= other_value)) {
      Fail(field, ">= " + Named(other_field, other_value), value);
    }
  }
  template <typename T>
  void AtMostField(const char* field, T value, const char* other_field,
                   OptionBound<T> other_value) {
    if (!(value <= other_value)) {
      Fail(field, "<= " + Named(other_field, other_value), value);
    }
  }

  // The result of a nested struct's Check (called with its own prefix).
  void Add(const Status& status) {
    if (ok_ && !status.ok()) {
      ok_ = false;
      message_ = status.message();
    }
  }

  const std::string& prefix() const { return prefix_; }

  Status status() const { return ok_ ? Status::Ok() : Status::Error(message_); }

 private:
  template <typename T>
  static std::string Text(T value) {
    return options_check_internal::ValueText(value);
  }

  template <typename T>
  std::string Named(const char* other_field, T other_value) const {
    return prefix_ + other_field + " (" + Text(other_value) + ")";
  }

  template <typename T>
  void Fail(const char* field, const std::string& range, T value) {
    if (!ok_) return;
    ok_ = false;
    message_ = prefix_ + field + " must be " + range + ", is " + Text(value);
  }

  std::string prefix_;
  bool ok_ = true;
  std::string message_;
};

}  // namespace glomap
