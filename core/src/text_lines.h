#pragma once
// Line and token scanning shared by core's text readers (OFF, ascii STL, XYZ/PWN): '#' comments
// stripped, whitespace trimmed, 1-based line numbers kept for error messages, and strict number
// parsing (std::from_chars; the whole token must be a number).
#include <algorithm>
#include <charconv>
#include <cstddef>
#include <string_view>
#include <system_error>

namespace scanbench::io_detail {

inline bool space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
}

// Lines of a text file with '#' comments removed and surrounding whitespace trimmed; keeps the
// 1-based line number for messages.
class Lines {
 public:
  explicit Lines(std::string_view text) : text_(text) {}
  // Next non-empty line; false at the end.
  bool next(std::string_view& line) {
    while (pos_ < text_.size()) {
      const std::size_t end = std::min(text_.find('\n', pos_), text_.size());
      std::string_view l = text_.substr(pos_, end - pos_);
      pos_ = end + 1;
      ++number_;
      if (const std::size_t hash = l.find('#'); hash != std::string_view::npos)
        l = l.substr(0, hash);
      while (!l.empty() && space(l.front()))
        l.remove_prefix(1);
      while (!l.empty() && space(l.back()))
        l.remove_suffix(1);
      if (!l.empty()) {
        line = l;
        return true;
      }
    }
    return false;
  }
  std::size_t number() const { return number_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t number_ = 0;
};

// Whitespace-separated tokens of one line.
class Tokens {
 public:
  explicit Tokens(std::string_view s) : s_(s) {}
  bool next(std::string_view& tok) {
    while (i_ < s_.size() && space(s_[i_]))
      ++i_;
    if (i_ == s_.size()) return false;
    const std::size_t start = i_;
    while (i_ < s_.size() && !space(s_[i_]))
      ++i_;
    tok = s_.substr(start, i_ - start);
    return true;
  }

 private:
  std::string_view s_;
  std::size_t i_ = 0;
};

template <class T>
inline bool parse_number(std::string_view tok, T& out) {
  const char* first = tok.data();
  const char* last = tok.data() + tok.size();
  if (first != last && *first == '+') ++first;
  const auto [p, ec] = std::from_chars(first, last, out);
  return ec == std::errc() && p == last;
}

}  // namespace scanbench::io_detail
