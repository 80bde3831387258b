#include "ply.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <istream>
#include <limits>
#include <ostream>
#include <sstream>

#include "scanbench/core/errors.h"
#include "scanbench/core/files.h"

namespace scanbench::ply {

namespace {

constexpr std::size_t kMaxHeaderLine = 1 << 16;
constexpr std::size_t kMaxHeaderLines = 1 << 16;
constexpr std::uint64_t kMaxCount = std::numeric_limits<std::int32_t>::max();

struct TypeInfo {
  Type type;
  const char* name;
  const char* alias;
  std::size_t size;
  double min;
  double max;
};

constexpr std::array<TypeInfo, 8> kTypes{{
    {Type::Int8, "char", "int8", 1, -128.0, 127.0},
    {Type::UInt8, "uchar", "uint8", 1, 0.0, 255.0},
    {Type::Int16, "short", "int16", 2, -32768.0, 32767.0},
    {Type::UInt16, "ushort", "uint16", 2, 0.0, 65535.0},
    {Type::Int32, "int", "int32", 4, -2147483648.0, 2147483647.0},
    {Type::UInt32, "uint", "uint32", 4, 0.0, 4294967295.0},
    {Type::Float32, "float", "float32", 4, -static_cast<double>(std::numeric_limits<float>::max()),
     static_cast<double>(std::numeric_limits<float>::max())},
    {Type::Float64, "double", "float64", 8, -std::numeric_limits<double>::max(),
     std::numeric_limits<double>::max()},
}};

const TypeInfo& info(Type t) {
  return kTypes[static_cast<std::size_t>(t)];
}

bool parse_type(std::string_view s, Type& t) {
  for (const auto& ti : kTypes) {
    if (s == ti.name || s == ti.alias) {
      t = ti.type;
      return true;
    }
  }
  return false;
}

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i]))
      ++i;
    const std::size_t start = i;
    while (i < line.size() && !is_space(line[i]))
      ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

// Buffered reader over an istream: header lines, ascii tokens and raw bytes.
class Input {
 public:
  explicit Input(std::istream& in) : in_(in), buf_(1 << 16) {}

  // One line without its '\n' (and a trailing '\r'); false when the data ends before a '\n'.
  // Lines longer than `max` set `too_long`.
  bool line(std::string& out, std::size_t max, bool& too_long) {
    out.clear();
    too_long = false;
    for (;;) {
      if (pos_ == end_ && !fill()) return false;
      const char c = buf_[pos_++];
      if (c == '\n') break;
      if (out.size() >= max) {
        too_long = true;
        return true;
      }
      out.push_back(c);
    }
    if (!out.empty() && out.back() == '\r') out.pop_back();
    return true;
  }

  // Next whitespace-separated token; false at end of data.
  bool token(std::string& out) {
    out.clear();
    for (;;) {
      if (pos_ == end_ && !fill()) return false;
      if (!is_space(buf_[pos_])) break;
      ++pos_;
    }
    for (;;) {
      if (pos_ == end_ && !fill()) return true;
      const char c = buf_[pos_];
      if (is_space(c)) return true;
      if (out.size() >= 256) return true;  // absurd token; the parser rejects it
      out.push_back(c);
      ++pos_;
    }
  }

  // Copies up to n bytes; returns how many were available (n unless the data ends).
  std::size_t bytes(char* dst, std::size_t n) {
    std::size_t done = 0;
    while (done < n) {
      if (pos_ == end_ && !fill()) break;
      const std::size_t k = std::min(n - done, end_ - pos_);
      std::memcpy(dst + done, buf_.data() + pos_, k);
      pos_ += k;
      done += k;
    }
    return done;
  }

  // True when everything left is whitespace.
  bool only_whitespace_left() {
    for (;;) {
      if (pos_ == end_ && !fill()) return true;
      if (!is_space(buf_[pos_])) return false;
      ++pos_;
    }
  }

 private:
  bool fill() {
    if (!in_) return false;
    in_.read(buf_.data(), static_cast<std::streamsize>(buf_.size()));
    pos_ = 0;
    end_ = static_cast<std::size_t>(in_.gcount());
    return end_ > 0;
  }

  std::istream& in_;
  std::vector<char> buf_;
  std::size_t pos_ = 0;
  std::size_t end_ = 0;
};

[[noreturn]] void header_error(const std::string& name, std::size_t line, const std::string& what) {
  throw IoError(fmt::format("{}: header line {}: {}", name, line, what));
}

File parse_header(Input& in, const std::string& name) {
  File f;
  std::string line;
  bool too_long = false;
  if (!in.line(line, kMaxHeaderLine, too_long) || too_long || line != "ply") {
    throw IoError(fmt::format("{}: not a PLY file (first line is not 'ply')", name));
  }
  bool have_format = false;
  for (std::size_t n = 2;; ++n) {
    if (n > kMaxHeaderLines) header_error(name, n, "header too long (no end_header)");
    if (!in.line(line, kMaxHeaderLine, too_long)) {
      throw IoError(fmt::format("{}: unexpected end of file in the header (no end_header)", name));
    }
    if (too_long) header_error(name, n, "line too long");
    const auto tok = split(line);
    if (tok.empty()) header_error(name, n, "empty line");
    const std::string_view key = tok[0];
    if (key == "end_header") {
      if (tok.size() != 1) header_error(name, n, "unexpected text after end_header");
      break;
    }
    if (key == "comment" || key == "obj_info") {
      const std::size_t at = line.find(key) + key.size();
      std::string text = at < line.size() ? line.substr(at + 1) : std::string();
      (key == "comment" ? f.comments : f.obj_info).push_back(std::move(text));
      continue;
    }
    if (key == "format") {
      if (have_format) header_error(name, n, "second format line");
      if (tok.size() != 3) header_error(name, n, "expected 'format <type> 1.0'");
      if (tok[1] == "ascii") {
        f.format = Format::Ascii;
      } else if (tok[1] == "binary_little_endian") {
        f.format = Format::BinaryLittleEndian;
      } else if (tok[1] == "binary_big_endian") {
        f.format = Format::BinaryBigEndian;
      } else {
        header_error(name, n, fmt::format("unknown format '{}'", tok[1]));
      }
      if (tok[2] != "1.0" && tok[2] != "1") {
        header_error(name, n, fmt::format("unsupported version '{}'", tok[2]));
      }
      have_format = true;
      continue;
    }
    if (!have_format) header_error(name, n, "'format' must come before '" + std::string(key) + "'");
    if (key == "element") {
      if (tok.size() != 3) header_error(name, n, "expected 'element <name> <count>'");
      Element e;
      e.name = std::string(tok[1]);
      if (f.find(e.name)) header_error(name, n, fmt::format("duplicate element '{}'", e.name));
      std::uint64_t count = 0;
      const auto [p, ec] = std::from_chars(tok[2].data(), tok[2].data() + tok[2].size(), count);
      if (ec != std::errc() || p != tok[2].data() + tok[2].size() || count > kMaxCount) {
        header_error(name, n,
                     fmt::format("element {}: invalid count '{}' (expected 0 to {})", e.name,
                                 tok[2], kMaxCount));
      }
      e.count = static_cast<std::size_t>(count);
      f.elements.push_back(std::move(e));
      continue;
    }
    if (key == "property") {
      if (f.elements.empty()) header_error(name, n, "property before any element");
      Element& e = f.elements.back();
      Property prop;
      if (tok.size() == 5 && tok[1] == "list") {
        prop.is_list = true;
        if (!parse_type(tok[2], prop.count_type) || !is_integer(prop.count_type)) {
          header_error(name, n, fmt::format("invalid list count type '{}'", tok[2]));
        }
        if (!parse_type(tok[3], prop.type)) {
          header_error(name, n, fmt::format("unknown type '{}'", tok[3]));
        }
        prop.name = std::string(tok[4]);
      } else if (tok.size() == 3 && tok[1] != "list") {
        if (!parse_type(tok[1], prop.type)) {
          header_error(name, n, fmt::format("unknown type '{}'", tok[1]));
        }
        prop.name = std::string(tok[2]);
      } else {
        header_error(name, n,
                     "expected 'property <type> <name>' or 'property list <type> <type> <name>'");
      }
      if (e.find(prop.name)) {
        header_error(name, n,
                     fmt::format("element {}: duplicate property '{}'", e.name, prop.name));
      }
      e.properties.push_back(std::move(prop));
      continue;
    }
    header_error(name, n, fmt::format("unknown keyword '{}'", key));
  }
  if (!have_format) throw IoError(fmt::format("{}: header has no format line", name));
  return f;
}

double decode(const char* p, Type t, bool swap) {
  std::array<char, 8> b{};
  const std::size_t n = info(t).size;
  std::memcpy(b.data(), p, n);
  if (swap) std::reverse(b.begin(), b.begin() + static_cast<std::ptrdiff_t>(n));
  switch (t) {
    case Type::Int8: {
      std::int8_t v;
      std::memcpy(&v, b.data(), 1);
      return v;
    }
    case Type::UInt8: {
      std::uint8_t v;
      std::memcpy(&v, b.data(), 1);
      return v;
    }
    case Type::Int16: {
      std::int16_t v;
      std::memcpy(&v, b.data(), 2);
      return v;
    }
    case Type::UInt16: {
      std::uint16_t v;
      std::memcpy(&v, b.data(), 2);
      return v;
    }
    case Type::Int32: {
      std::int32_t v;
      std::memcpy(&v, b.data(), 4);
      return v;
    }
    case Type::UInt32: {
      std::uint32_t v;
      std::memcpy(&v, b.data(), 4);
      return v;
    }
    case Type::Float32: {
      float v;
      std::memcpy(&v, b.data(), 4);
      return v;
    }
    case Type::Float64: {
      double v;
      std::memcpy(&v, b.data(), 8);
      return v;
    }
  }
  return 0.0;
}

// Parses an ascii value of type t; returns an error text or nullptr.
const char* parse_ascii(const std::string& s, Type t, double& out) {
  const char* first = s.data();
  const char* last = s.data() + s.size();
  if (first != last && *first == '+') ++first;  // from_chars rejects a leading '+'
  if (is_integer(t)) {
    std::int64_t v = 0;
    const auto [p, ec] = std::from_chars(first, last, v);
    if (ec == std::errc::result_out_of_range) return "integer out of range";
    if (ec != std::errc() || p != last) return "not an integer";
    out = static_cast<double>(v);
    if (out < info(t).min || out > info(t).max) return "integer out of range of its type";
    return nullptr;
  }
  double v = 0.0;
  const auto [p, ec] = std::from_chars(first, last, v);
  if (ec == std::errc::result_out_of_range) return "number out of range";
  if (ec != std::errc() || p != last) return "not a number";
  if (std::isfinite(v) && (v < info(t).min || v > info(t).max)) {
    return "number out of range of its type";
  }
  out = v;
  return nullptr;
}

void read_body(Input& in, File& f, const std::string& name) {
  const bool ascii = f.format == Format::Ascii;
  const bool swap =
      (f.format == Format::BinaryBigEndian) != (std::endian::native == std::endian::big);
  std::string tok;
  std::array<char, 8> bytes{};
  for (Element& e : f.elements) {
    if (e.properties.empty()) continue;  // nothing stored per row
    // The declared count is not trusted for allocation (a short file may claim billions of
    // rows): vectors grow with the data actually read.
    for (Property& p : e.properties) {
      p.values.reserve(std::min<std::size_t>(e.count, 4096));
      if (p.is_list) {
        p.offsets.reserve(std::min<std::size_t>(e.count + 1, 4096));
        p.offsets.push_back(0);
      }
    }
    // Binary rows of scalars have a fixed size: read each row in one go (the common case of
    // large point clouds), decoding at fixed offsets.
    const bool fixed = !ascii && std::none_of(e.properties.begin(), e.properties.end(),
                                              [](const Property& p) { return p.is_list; });
    if (fixed) {
      std::vector<std::size_t> offset;
      std::size_t row_size = 0;
      for (const Property& p : e.properties) {
        offset.push_back(row_size);
        row_size += info(p.type).size;
      }
      std::vector<char> row_bytes(row_size);
      for (std::size_t row = 0; row < e.count; ++row) {
        const std::size_t got = in.bytes(row_bytes.data(), row_size);
        if (got != row_size) {
          std::size_t k = 0;
          while (offset[k] + info(e.properties[k].type).size <= got)
            ++k;
          throw IoError(fmt::format("{}: element {}, row {}, property {}: unexpected end of file",
                                    name, e.name, row, e.properties[k].name));
        }
        for (std::size_t k = 0; k < e.properties.size(); ++k) {
          Property& p = e.properties[k];
          p.values.push_back(decode(row_bytes.data() + offset[k], p.type, swap));
        }
      }
      continue;
    }
    for (std::size_t row = 0; row < e.count; ++row) {
      for (Property& p : e.properties) {
        auto fail = [&](const std::string& what) {
          throw IoError(fmt::format("{}: element {}, row {}, property {}: {}", name, e.name, row,
                                    p.name, what));
        };
        auto value = [&](Type t) -> double {
          if (ascii) {
            if (!in.token(tok)) fail("unexpected end of file");
            double v = 0.0;
            if (const char* err = parse_ascii(tok, t, v)) {
              fail(fmt::format("{} '{}' (type {})", err, tok.substr(0, 40), info(t).name));
            }
            return v;
          }
          if (in.bytes(bytes.data(), info(t).size) != info(t).size) {
            fail("unexpected end of file");
          }
          return decode(bytes.data(), t, swap);
        };
        if (!p.is_list) {
          p.values.push_back(value(p.type));
          continue;
        }
        const double count = value(p.count_type);
        if (count < 0) fail(fmt::format("negative list length {}", count));
        for (std::size_t k = 0, n = static_cast<std::size_t>(count); k < n; ++k)
          p.values.push_back(value(p.type));
        p.offsets.push_back(p.values.size());
      }
    }
  }
  if (!in.only_whitespace_left()) {
    throw IoError(fmt::format("{}: unexpected data after the last element", name));
  }
}

bool valid_name(std::string_view s) {
  if (s.empty()) return false;
  for (char c : s) {
    if (is_space(c) || c == '\0') return false;
  }
  return true;
}

void encode(std::string& out, double v, Type t, bool swap) {
  std::array<char, 8> b{};
  switch (t) {
    case Type::Int8: {
      const auto x = static_cast<std::int8_t>(v);
      std::memcpy(b.data(), &x, 1);
      break;
    }
    case Type::UInt8: {
      const auto x = static_cast<std::uint8_t>(v);
      std::memcpy(b.data(), &x, 1);
      break;
    }
    case Type::Int16: {
      const auto x = static_cast<std::int16_t>(v);
      std::memcpy(b.data(), &x, 2);
      break;
    }
    case Type::UInt16: {
      const auto x = static_cast<std::uint16_t>(v);
      std::memcpy(b.data(), &x, 2);
      break;
    }
    case Type::Int32: {
      const auto x = static_cast<std::int32_t>(v);
      std::memcpy(b.data(), &x, 4);
      break;
    }
    case Type::UInt32: {
      const auto x = static_cast<std::uint32_t>(v);
      std::memcpy(b.data(), &x, 4);
      break;
    }
    case Type::Float32: {
      const auto x = static_cast<float>(v);
      std::memcpy(b.data(), &x, 4);
      break;
    }
    case Type::Float64:
      std::memcpy(b.data(), &v, 8);
      break;
  }
  const std::size_t n = info(t).size;
  if (swap) std::reverse(b.begin(), b.begin() + static_cast<std::ptrdiff_t>(n));
  out.append(b.data(), n);
}

void append_ascii(std::string& out, double v, Type t) {
  if (is_integer(t)) {
    fmt::format_to(std::back_inserter(out), "{}", static_cast<std::int64_t>(v));
  } else if (t == Type::Float32) {
    fmt::format_to(std::back_inserter(out), "{}", static_cast<float>(v));
  } else {
    fmt::format_to(std::back_inserter(out), "{}", v);
  }
}

}  // namespace

const char* type_name(Type t) {
  return info(t).name;
}
std::size_t type_size(Type t) {
  return info(t).size;
}
bool is_integer(Type t) {
  return t != Type::Float32 && t != Type::Float64;
}

const Property* Element::find(std::string_view property) const {
  for (const auto& p : properties) {
    if (p.name == property) return &p;
  }
  return nullptr;
}

const Element* File::find(std::string_view element) const {
  for (const auto& e : elements) {
    if (e.name == element) return &e;
  }
  return nullptr;
}

File read(std::istream& in, const std::string& name) {
  Input input(in);
  File f = parse_header(input, name);
  read_body(input, f, name);
  return f;
}

File read(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(fmt::format("{}: cannot open for reading", path.string()));
  return read(in, path.string());
}

void write(const File& file, std::ostream& out, const std::string& name) {
  std::string head = "ply\nformat ";
  head += file.format == Format::Ascii                ? "ascii"
          : file.format == Format::BinaryLittleEndian ? "binary_little_endian"
                                                      : "binary_big_endian";
  head += " 1.0\n";
  auto check_line = [&](const std::string& s) {
    if (s.find_first_of("\r\n") != std::string::npos) {
      throw IoError(fmt::format("{}: header text may not contain a line break: '{}'", name, s));
    }
  };
  for (const auto& c : file.comments) {
    check_line(c);
    head += "comment " + c + "\n";
  }
  for (const auto& c : file.obj_info) {
    check_line(c);
    head += "obj_info " + c + "\n";
  }
  for (const auto& e : file.elements) {
    if (!valid_name(e.name))
      throw IoError(fmt::format("{}: invalid element name '{}'", name, e.name));
    head += fmt::format("element {} {}\n", e.name, e.count);
    for (const auto& p : e.properties) {
      if (!valid_name(p.name)) {
        throw IoError(
            fmt::format("{}: element {}: invalid property name '{}'", name, e.name, p.name));
      }
      const bool sizes_ok = p.is_list ? p.offsets.size() == e.count + 1 && p.offsets.front() == 0 &&
                                            p.offsets.back() == p.values.size()
                                      : p.values.size() == e.count;
      if (!sizes_ok) {
        throw IoError(fmt::format("{}: element {}, property {}: value count does not match {} rows",
                                  name, e.name, p.name, e.count));
      }
      if (p.is_list && !is_integer(p.count_type)) {
        throw IoError(fmt::format("{}: element {}, property {}: list count type must be an integer",
                                  name, e.name, p.name));
      }
      for (double v : p.values) {
        if (is_integer(p.type) &&
            (!(v >= info(p.type).min && v <= info(p.type).max) || v != std::trunc(v))) {
          throw IoError(fmt::format("{}: element {}, property {}: value {} does not fit type {}",
                                    name, e.name, p.name, v, info(p.type).name));
        }
      }
      if (p.is_list) {
        head += fmt::format("property list {} {} {}\n", info(p.count_type).name, info(p.type).name,
                            p.name);
        for (std::size_t r = 0; r < e.count; ++r) {
          if (p.offsets[r + 1] < p.offsets[r] ||
              static_cast<double>(p.offsets[r + 1] - p.offsets[r]) > info(p.count_type).max) {
            throw IoError(fmt::format("{}: element {}, row {}, property {}: invalid list length",
                                      name, e.name, r, p.name));
          }
        }
      } else {
        head += fmt::format("property {} {}\n", info(p.type).name, p.name);
      }
    }
  }
  head += "end_header\n";
  out.write(head.data(), static_cast<std::streamsize>(head.size()));

  const bool ascii = file.format == Format::Ascii;
  const bool swap =
      (file.format == Format::BinaryBigEndian) != (std::endian::native == std::endian::big);
  std::string buf;
  auto flush = [&](bool force) {
    if (force || buf.size() > (std::size_t{1} << 20)) {
      out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
      buf.clear();
    }
  };
  for (const auto& e : file.elements) {
    if (e.properties.empty()) continue;
    for (std::size_t r = 0; r < e.count; ++r) {
      bool first = true;
      for (const auto& p : e.properties) {
        auto put = [&](double v, Type t) {
          if (ascii) {
            if (!first) buf.push_back(' ');
            append_ascii(buf, v, t);
          } else {
            encode(buf, v, t, swap);
          }
          first = false;
        };
        if (!p.is_list) {
          put(p.values[r], p.type);
          continue;
        }
        put(static_cast<double>(p.offsets[r + 1] - p.offsets[r]), p.count_type);
        for (std::size_t k = p.offsets[r]; k < p.offsets[r + 1]; ++k)
          put(p.values[k], p.type);
      }
      if (ascii) buf.push_back('\n');
      flush(false);
    }
  }
  flush(true);
  out.flush();
  if (!out) throw IoError(fmt::format("{}: write failed", name));
}

void write(const File& file, const std::filesystem::path& path) {
  // Encoded in memory, then written whole by the one atomic writer: every write(2) is checked
  // there, so a full disk is reported with its reason and never leaves a part under `path`.
  std::ostringstream out(std::ios::binary);
  write(file, out, path.string());
  write_file_atomic(path, std::move(out).str());
}

}  // namespace scanbench::ply
