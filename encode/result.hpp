// Result type for parsers and per-frame code: a value or an Error with a code,
// a message and (where it applies) the offending field. Start-up and config may throw.
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <variant>

namespace hdrd {

struct Error {
  std::string code;     // stable machine-readable code, e.g. "exr.truncated", "cube.syntax"
  std::string message;  // one human line naming what is wrong
  std::string field;    // request field or option it concerns, may be empty
};

// Thrown where a Result cannot be returned (CLI plumbing, start-up).
class HdrdError : public std::runtime_error {
 public:
  explicit HdrdError(Error e) : std::runtime_error(e.message), error_(std::move(e)) {}
  const Error& error() const noexcept { return error_; }

 private:
  Error error_;
};

template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}  // NOLINT(implicit)
  Result(Error e) : v_(std::move(e)) {}       // NOLINT(implicit)

  bool ok() const noexcept { return v_.index() == 0; }
  explicit operator bool() const noexcept { return ok(); }

  T& value() & { check(); return std::get<0>(v_); }
  const T& value() const& { check(); return std::get<0>(v_); }
  T&& value() && { check(); return std::get<0>(std::move(v_)); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }

  const Error& error() const { return std::get<1>(v_); }

 private:
  void check() const {
    if (!ok()) throw HdrdError(std::get<1>(v_));
  }
  std::variant<T, Error> v_;
};

template <>
class [[nodiscard]] Result<void> {
 public:
  Result() = default;
  Result(Error e) : err_(std::move(e)), ok_(false) {}  // NOLINT(implicit)
  bool ok() const noexcept { return ok_; }
  explicit operator bool() const noexcept { return ok_; }
  const Error& error() const { return err_; }
  void value() const {
    if (!ok_) throw HdrdError(err_);
  }

 private:
  Error err_{};
  bool ok_ = true;
};

inline Error make_error(std::string code, std::string message, std::string field = {}) {
  return Error{std::move(code), std::move(message), std::move(field)};
}

// An error message is one human line, even when it quotes what a user sent (a JSON key may
// hold "\n", a path or query parameter %0A): `s` with every C0 control and DEL replaced by
// a space.
inline std::string one_line(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  return out;
}

}  // namespace hdrd
