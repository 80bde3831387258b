#include "scanbench/core/json_text.h"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <vector>

#include "scanbench/core/errors.h"

namespace scanbench {

namespace {

/// The SAX pass: nlohmann's parser calls these while it lexes; returning false stops it. Builds
/// no value, so its memory is one frame per open object or array (bounded by max_depth).
class CheckingSax {
 public:
  explicit CheckingSax(const JsonTextOptions& options) : options_(options) {}

  bool null() { return value(); }
  bool boolean(bool) { return value(); }
  bool number_integer(Json::number_integer_t) { return value(); }
  bool number_unsigned(Json::number_unsigned_t) { return value(); }
  bool number_float(Json::number_float_t, const std::string&) { return value(); }
  bool string(std::string&) { return value(); }
  bool binary(Json::binary_t&) { return value(); }

  bool start_object(std::size_t) { return open(true); }
  bool start_array(std::size_t) { return open(false); }
  bool end_object() { return close(); }
  bool end_array() { return close(); }

  bool key(std::string& k) {
    Frame& f = stack_.back();
    f.key = k;
    if (options_.reject_duplicate_keys && !f.keys.insert(k).second) {
      duplicate_ = pointer();
      return false;
    }
    return true;
  }

  bool parse_error(std::size_t, const std::string&, const Json::exception& e) {
    error_ = e.what();
    return false;
  }

  bool too_deep() const { return too_deep_; }
  const std::string& duplicate() const { return duplicate_; }
  const std::string& error() const { return error_; }

 private:
  struct Frame {
    bool object = false;
    std::set<std::string> keys;  // only with reject_duplicate_keys
    std::string key;             // the current key of an object
    std::size_t index = 0;       // the current index of an array
  };

  bool open(bool object) {
    if (stack_.size() >= options_.max_depth) {
      too_deep_ = true;
      return false;
    }
    stack_.push_back(Frame{object, {}, {}, 0});
    return true;
  }
  bool close() {
    stack_.pop_back();
    return value();
  }
  // A complete value inside the top frame: an array moves on to its next index.
  bool value() {
    if (!stack_.empty() && !stack_.back().object) ++stack_.back().index;
    return true;
  }
  // The JSON pointer (RFC 6901: "~" as "~0", "/" as "~1") of the current position.
  std::string pointer() const {
    std::string ptr;
    for (const Frame& f : stack_) {
      ptr += '/';
      if (!f.object) {
        ptr += std::to_string(f.index);
        continue;
      }
      for (char c : f.key)
        ptr += c == '~' ? std::string("~0") : c == '/' ? std::string("~1") : std::string(1, c);
    }
    return ptr;
  }

  const JsonTextOptions& options_;
  std::vector<Frame> stack_;
  bool too_deep_ = false;
  std::string duplicate_;
  std::string error_;
};

}  // namespace

Json parse_json_text(std::string_view text, const std::string& where,
                     const JsonTextOptions& options) {
  CheckingSax sax(options);
  const bool ok = Json::sax_parse(text, &sax, Json::input_format_t::json,
                                  /*strict=*/true, options.ignore_comments);
  if (sax.too_deep()) {
    throw IoError(fmt::format("{}: JSON nested deeper than {} levels", where, options.max_depth));
  }
  if (!sax.duplicate().empty()) {
    throw ParamError(
        fmt::format("{}: {}: duplicate key (JSON keeps only one of them)", where, sax.duplicate()));
  }
  if (!ok) {
    throw IoError(fmt::format("{}: not valid JSON: {}", where,
                              sax.error().empty() ? "parse stopped" : sax.error()));
  }
  // The text is known to be valid and shallow: the DOM pass cannot fail but for memory.
  try {
    return Json::parse(text, nullptr, /*allow_exceptions=*/true, options.ignore_comments);
  } catch (const Json::exception& e) {
    throw IoError(fmt::format("{}: not valid JSON: {}", where, e.what()));
  }
}

Json parse_assigned_value(std::string_view text, const std::string& where) {
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first != std::string_view::npos && (text[first] == '[' || text[first] == '{')) {
    return parse_json_text(text, where);
  }
  // A scalar cannot nest, so nlohmann's parser is safe here; not JSON: the text itself.
  Json value = Json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (value.is_discarded()) return Json(std::string(text));
  return value;
}

Json parse_json_file(const std::filesystem::path& file, std::string_view what,
                     const JsonTextOptions& options) {
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    throw IoError(fmt::format("{}: cannot open {}: {}", file.string(), what, std::strerror(errno)));
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) {
    throw IoError(fmt::format("{}: cannot read {}: {}", file.string(), what, std::strerror(errno)));
  }
  return parse_json_text(text.str(), file.string(), options);
}

}  // namespace scanbench
