#pragma once
// A general PLY codec, private to core. Debian 12 packages no PLY library (no tinyply, happly or
// miniply; assimp reads PLY but is not a chosen dependency and cannot write extra properties), so
// scanbench carries its own. It is fuzzed (tests/fuzz/fuzz_readers.cpp) and tested with a corpus
// of malformed files (tests/data/malformed).
//
// Reading: the header (format ascii / binary_little_endian / binary_big_endian 1.0, comment,
// obj_info, elements with scalar and list properties of every PLY type: char uchar short ushort
// int uint float double and the aliases int8 uint8 int16 uint16 int32 uint32 float32 float64) is
// parsed strictly; the body is streamed through a buffer with exact bounds checks. Every value is
// held as a double (exact for every PLY type). Errors are IoError("<name>: <where>: <what>"), e.g.
// "x.ply: element vertex, row 12: unexpected end of file".
//
// Writing: the header in a fixed order with the given comments (no timestamps), values converted
// to each property's declared type; ascii floats use the shortest representation that reads back
// bit for bit. Equal data gives equal bytes.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <string_view>
#include <vector>

namespace scanbench::ply {

enum class Type : std::uint8_t { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };
enum class Format : std::uint8_t { Ascii, BinaryLittleEndian, BinaryBigEndian };

/// Canonical PLY name ("char", "uchar", ..., "double").
const char* type_name(Type t);
/// Size in bytes of one binary value.
std::size_t type_size(Type t);
bool is_integer(Type t);

struct Property {
  std::string name;
  Type type = Type::Float32;  ///< the value type (of the items, for a list)
  bool is_list = false;
  Type count_type = Type::UInt8;  ///< list only: type of the item count (an integer type)
  /// Scalar: one value per row. List: the items of every row, concatenated.
  std::vector<double> values;
  /// List only: row r holds values[offsets[r] .. offsets[r + 1]); offsets.size() = rows + 1.
  std::vector<std::size_t> offsets;
};

struct Element {
  std::string name;
  std::size_t count = 0;
  std::vector<Property> properties;
  const Property* find(std::string_view property) const;
};

struct File {
  Format format = Format::BinaryLittleEndian;
  std::vector<std::string> comments;
  std::vector<std::string> obj_info;
  std::vector<Element> elements;
  const Element* find(std::string_view element) const;
};

/// Reads a whole PLY file. Throws IoError (missing file, malformed header, truncated body,
/// values out of their type's range, trailing data that is not whitespace).
File read(const std::filesystem::path& path);
/// Same from a stream; `name` prefixes the error messages.
File read(std::istream& in, const std::string& name);

/// Writes `file` (every property's values must hold count entries, or count + 1 offsets for a
/// list). Throws IoError when the file cannot be written, on inconsistent sizes, on names that
/// PLY cannot hold (empty or with whitespace) and on values that are not integers in the range of
/// their integer type. Float values may be non-finite (binary keeps them; ascii writes nan/inf,
/// which read() accepts); callers that need finite data check it.
void write(const File& file, const std::filesystem::path& path);
void write(const File& file, std::ostream& out, const std::string& name);

}  // namespace scanbench::ply
