// A tiny whitespace tokenizer over a text buffer that knows its line number (for messages).
#pragma once
#include "engine/core/error.hpp"

#include <charconv>
#include <cmath>
#include <string>
#include <string_view>

namespace hocurve::io_detail {

class TextScanner {
 public:
  TextScanner(std::string_view text, const std::string& name) : s_(text), name_(name) {}

  /// Skips blanks and newlines (counting lines) and `comment` lines if given.
  void skip_space(char comment = 0) {
    while (p_ < s_.size()) {
      const char c = s_[p_];
      if (c == '\n') ++line_, ++p_;
      else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') ++p_;
      else if (comment && c == comment) { while (p_ < s_.size() && s_[p_] != '\n') ++p_; }
      else break;
    }
  }
  /// Skips blanks but stops at the end of the line.
  void skip_blanks() {
    while (p_ < s_.size() && (s_[p_] == ' ' || s_[p_] == '\t' || s_[p_] == '\r')) ++p_;
  }
  bool at_end(char comment = 0) { skip_space(comment); return p_ >= s_.size(); }
  bool at_line_end() { skip_blanks(); return p_ >= s_.size() || s_[p_] == '\n' || s_[p_] == '#'; }
  /// Moves past the next newline.
  void next_line() {
    while (p_ < s_.size() && s_[p_] != '\n') ++p_;
    if (p_ < s_.size()) ++p_, ++line_;
  }
  /// Next token (may be empty at end of input).
  std::string_view token(char comment = 0) {
    skip_space(comment);
    const std::size_t b = p_;
    while (p_ < s_.size() && !std::isspace(static_cast<unsigned char>(s_[p_]))) ++p_;
    return s_.substr(b, p_ - b);
  }
  /// Next token on the current line only (empty when the line is over).
  std::string_view token_on_line() {
    skip_blanks();
    if (p_ < s_.size() && s_[p_] == '\n') return {};
    return token();
  }
  double number(const char* what, char comment = 0) {
    const std::string_view t = token(comment);
    if (t.empty()) fail(std::string("unexpected end of file, expected ") + what);
    return parse_double(t, what);
  }
  long long integer(const char* what, char comment = 0) {
    const std::string_view t = token(comment);
    if (t.empty()) fail(std::string("unexpected end of file, expected ") + what);
    return parse_int(t, what);
  }
  double parse_double(std::string_view t, const char* what) const {
    double v = 0;
    const char* b = t.data();
    if (!t.empty() && t[0] == '+') ++b;
    auto [q, ec] = std::from_chars(b, t.data() + t.size(), v);
    if (ec == std::errc::result_out_of_range) return std::strtod(std::string(t).c_str(), nullptr);
    if (ec != std::errc() || q != t.data() + t.size())
      fail(std::string("expected ") + what + ", found '" + std::string(t.substr(0, 40)) + "'");
    return v;
  }
  long long parse_int(std::string_view t, const char* what) const {
    long long v = 0;
    const char* b = t.data();
    if (!t.empty() && t[0] == '+') ++b;
    auto [q, ec] = std::from_chars(b, t.data() + t.size(), v);
    if (ec != std::errc() || q != t.data() + t.size())
      fail(std::string("expected ") + what + ", found '" + std::string(t.substr(0, 40)) + "'");
    return v;
  }
  [[noreturn]] void fail(const std::string& why) const { throw InputError(where(), why); }
  std::string where() const { return name_ + ": line " + std::to_string(line_); }
  long long line() const { return line_; }
  std::size_t pos() const { return p_; }
  std::size_t remaining() const { return s_.size() - p_; }
  void seek(std::size_t p) { p_ = p; }

 private:
  std::string_view s_;
  const std::string& name_;
  std::size_t p_ = 0;
  long long line_ = 1;
};

}  // namespace hocurve::io_detail
