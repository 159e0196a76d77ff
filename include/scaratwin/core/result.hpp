// Result<T>: the value of an operation that can fail in an expected way (an unreachable
// target, a decode error, a timeout, a lost link). Bugs abort; bad user input at a boundary is
// reported with a message naming the value; everything else that can fail returns a Result.
// std::expected is not available with g++ 12 in C++20, so this is a small stand-in.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>

#include "scaratwin/core/error_codes.hpp"

namespace scaratwin {

// An error: a machine-readable code (a module's enum of scaratwin/core/error_codes.hpp, stored
// as int; each module has its own range there) and a message for people that names the
// offending value and, where possible, what would be valid.
struct Error {
  Error() = default;
  Error(int code_value, std::string text) : code(code_value), message(std::move(text)) {}
  // From a module's enum: Error{SimError::kOccupied, "..."}.
  template <typename E>
  requires std::is_enum_v<E> Error(E code_value, std::string text)
      : Error(static_cast<int>(code_value), std::move(text)) {}

  int code = 0;
  std::string message;
  // Where a peer refused with an ER reply that carried one: its detail field (docs/protocol.md
  // section 6), so that no caller reads the message text to tell refusals apart.
  std::optional<int> detail;
};

// Always-on check for programming errors (not for user input).
#define SCARATWIN_CHECK(cond, msg)                                                           \
  do {                                                                                       \
    if (!(cond)) {                                                                           \
      std::fprintf(stderr, "%s:%d: check failed: %s: %s\n", __FILE__, __LINE__, #cond, msg); \
      std::abort();                                                                          \
    }                                                                                        \
  } while (0)

template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}      // NOLINT: implicit by design
  Result(Error error) : v_(std::move(error)) {}  // NOLINT: implicit by design

  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }

  const T& value() const& {
    SCARATWIN_CHECK(ok(), "Result::value() on an error");
    return std::get<0>(v_);
  }
  T& value() & {
    SCARATWIN_CHECK(ok(), "Result::value() on an error");
    return std::get<0>(v_);
  }
  T&& value() && {
    SCARATWIN_CHECK(ok(), "Result::value() on an error");
    return std::get<0>(std::move(v_));
  }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }

  const Error& error() const {
    SCARATWIN_CHECK(!ok(), "Result::error() on a value");
    return std::get<1>(v_);
  }

 private:
  std::variant<T, Error> v_;
};

// Result of an operation that has no value on success.
struct Ok {};
using Status = Result<Ok>;

}  // namespace scaratwin
