// Mesh files: dispatch by extension, OFF and STL (hand-written, see io_readers.h), OBJ through
// tinyobjloader, and the OBJ writer.
#include <fmt/format.h>
#include <tiny_obj_loader.h>

#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <vector>

#include "float_precision.h"
#include "io_readers.h"
#include "ply.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/files.h"
#include "scanbench/core/io.h"
#include "scanbench/core/procedural.h"
#include "text_lines.h"

namespace scanbench {

namespace {

using io_detail::Lines;
using io_detail::localize;
using io_detail::lower_extension;
using io_detail::parse_number;
using io_detail::slurp;
using io_detail::space;
using io_detail::Tokens;

TriangleMesh to_mesh(const std::vector<float>& xyz, const std::vector<int>& tri) {
  TriangleMesh m;
  m.vertices =
      Eigen::Map<const Eigen::Matrix3Xf>(xyz.data(), 3, static_cast<Eigen::Index>(xyz.size() / 3));
  m.faces =
      Eigen::Map<const Eigen::Matrix3Xi>(tri.data(), 3, static_cast<Eigen::Index>(tri.size() / 3));
  return m;
}

TriangleMesh read_obj(const std::filesystem::path& path) {
  const std::string name = path.string();
  const std::string text = slurp(path);
  // tinyobjloader reads an unparsable coordinate ("nan", "1,5", a missing z) as 0 without a
  // warning; scanbench never repairs silently, so geometric vertex lines are checked first.
  Lines lines(text);
  std::string_view line;
  std::vector<double> xyz_d;  // x y z of every `v` in double, for the local origin
  while (lines.next(line)) {
    Tokens t(line);
    std::string_view tok;
    t.next(tok);
    if (tok == "f") {
      // tinyobjloader reads indices with atoi ("1.5" -> 1, "x" -> 0): check each v[/vt[/vn]].
      while (t.next(tok)) {
        const std::string_view v = tok.substr(0, tok.find('/'));
        std::int64_t index = 0;
        if (!parse_number(v, index) || index == 0) {
          throw IoError(fmt::format("{}: line {}: face index '{}' is not a nonzero integer", name,
                                    lines.number(), tok.substr(0, 40)));
        }
      }
      continue;
    }
    if (tok != "v") continue;
    int n = 0;
    while (t.next(tok)) {
      double x = 0.0;
      if (!parse_number(tok, x) || !std::isfinite(x)) {
        throw IoError(fmt::format("{}: line {}: vertex coordinate '{}' is not a finite number",
                                  name, lines.number(), tok.substr(0, 40)));
      }
      if (n < 3) xyz_d.push_back(x);
      ++n;
    }
    if (n < 3 || n > 7) {
      throw IoError(
          fmt::format("{}: line {}: vertex with {} values (expected x y z [w] or x y z "
                      "r g b)",
                      name, lines.number(), n));
    }
  }
  tinyobj::ObjReaderConfig config;
  config.triangulate = false;  // our own fan, with index checks; tinyobj skips bad faces quietly
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  // Materials are not used: no .mtl file is read.
  if (!reader.ParseFromString(text, std::string(), config)) {
    std::string err = reader.Error();
    while (!err.empty() && space(err.back()))
      err.pop_back();
    for (char& c : err)
      if (c == '\n') c = ' ';
    throw IoError(fmt::format("{}: {}", name, err.empty() ? "cannot parse OBJ" : err));
  }
  const std::string& warn = reader.Warning();
  if (warn.find("Degenerated face") != std::string::npos ||
      warn.find("invalid") != std::string::npos) {
    throw IoError(fmt::format("{}: malformed face ({})", name, warn.substr(0, warn.find('\n'))));
  }
  const auto& attrib = reader.GetAttrib();
  if (attrib.vertices.size() != xyz_d.size()) {
    throw IoError(fmt::format("{}: {} vertices read, {} `v` lines", name,
                              attrib.vertices.size() / 3, xyz_d.size() / 3));
  }
  // tinyobjloader reads float32; the positions are taken from the double values instead.
  Eigen::Matrix3Xf local;
  const Eigen::Vector3d origin = localize(
      static_cast<Eigen::Index>(xyz_d.size() / 3),
      [&](int k, Eigen::Index i) { return xyz_d[static_cast<std::size_t>(3 * i + k)]; }, local,
      name, "vertex");
  std::vector<float> xyz(local.data(), local.data() + local.size());
  const auto nv = static_cast<std::int64_t>(xyz.size() / 3);
  std::vector<int> tri;
  for (const auto& shape : reader.GetShapes()) {
    std::size_t base = 0;
    for (std::size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f) {
      const std::size_t n = shape.mesh.num_face_vertices[f];
      if (n < 3) throw IoError(fmt::format("{}: face with {} vertices", name, n));
      for (std::size_t k = 0; k < n; ++k) {
        const int v = shape.mesh.indices[base + k].vertex_index;
        if (v < 0 || v >= nv) {
          throw IoError(fmt::format("{}: face refers to vertex {} of {}", name, v + 1, nv));
        }
      }
      for (std::size_t k = 1; k + 1 < n; ++k) {
        tri.push_back(shape.mesh.indices[base].vertex_index);
        tri.push_back(shape.mesh.indices[base + k].vertex_index);
        tri.push_back(shape.mesh.indices[base + k + 1].vertex_index);
      }
      base += n;
    }
  }
  TriangleMesh m = to_mesh(xyz, tri);
  m.origin = origin;
  io_detail::check_mesh(m, name);
  return m;
}

void write_obj(const TriangleMesh& mesh, const std::filesystem::path& path) {
  mesh.validate(path.string());
  std::string buf = "# scanbench mesh\n";
  const bool local = !mesh.origin.isZero(0.0);
  if (local) buf += "# " + io_detail::origin_comment(mesh.origin) + "\n";
  for (Eigen::Index v = 0; v < mesh.num_vertices(); ++v) {
    // Shortest representation that reads back to the same float (the same double: world
    // coordinates origin + local when the mesh has a local origin).
    if (local) {
      const Eigen::Vector3d w = mesh.origin + mesh.vertices.col(v).cast<double>();
      fmt::format_to(std::back_inserter(buf), "v {} {} {}\n", w.x(), w.y(), w.z());
    } else {
      fmt::format_to(std::back_inserter(buf), "v {} {} {}\n", mesh.vertices(0, v),
                     mesh.vertices(1, v), mesh.vertices(2, v));
    }
  }
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f) {
    fmt::format_to(std::back_inserter(buf), "f {} {} {}\n", mesh.faces(0, f) + 1,
                   mesh.faces(1, f) + 1, mesh.faces(2, f) + 1);
  }
  write_file_atomic(path, buf);
}

float read_le_float(const char* p) {
  std::uint32_t u;
  std::memcpy(&u, p, 4);
  if constexpr (std::endian::native == std::endian::big) u = __builtin_bswap32(u);
  return std::bit_cast<float>(u);
}

}  // namespace

namespace io_detail {

std::string lower_extension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  for (char& c : ext)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(fmt::format("{}: cannot open for reading", path.string()));
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw IoError(fmt::format("{}: read failed", path.string()));
  return data;
}

OffData parse_off(std::string_view text, const std::string& name) {
  Lines lines(text);
  std::string_view line;
  auto fail = [&](const std::string& what) -> void {
    throw IoError(fmt::format("{}: line {}: {}", name, lines.number(), what));
  };
  if (!lines.next(line)) throw IoError(fmt::format("{}: empty OFF file", name));
  Tokens head(line);
  std::string_view tok;
  head.next(tok);
  bool homogeneous = false;
  bool with_normals = false;
  std::vector<std::string_view> counts;
  if (tok.size() >= 3 && tok.substr(tok.size() - 3) == "OFF") {
    std::string_view prefix = tok.substr(0, tok.size() - 3);
    auto eat = [&](std::string_view s) {
      if (prefix.substr(0, s.size()) != s) return false;
      prefix.remove_prefix(s.size());
      return true;
    };
    eat("ST");
    eat("C");
    with_normals = eat("N");
    homogeneous = eat("4");
    if (eat("n")) fail("nOFF (arbitrary dimension) is not supported");
    if (!prefix.empty()) fail(fmt::format("unknown OFF header '{}'", tok));
    while (head.next(tok)) {
      if (tok == "BINARY") fail("binary OFF is not supported");
      counts.push_back(tok);
    }
    if (counts.empty()) {
      if (!lines.next(line)) fail("missing vertex and face counts");
      Tokens t(line);
      while (t.next(tok))
        counts.push_back(tok);
    }
  } else {
    // The OFF keyword is optional in the format; the first line then holds the counts.
    counts.push_back(tok);
    while (head.next(tok))
      counts.push_back(tok);
  }
  std::int64_t nv = 0;
  std::int64_t nf = 0;
  std::int64_t ne = 0;
  if (counts.size() < 2 || counts.size() > 3 || !parse_number(counts[0], nv) ||
      !parse_number(counts[1], nf) || (counts.size() == 3 && !parse_number(counts[2], ne))) {
    fail("expected '<vertices> <faces> [<edges>]'");
  }
  constexpr std::int64_t kMax = std::numeric_limits<std::int32_t>::max() / 3;
  if (nv < 0 || nf < 0 || nv > kMax || nf > kMax || ne < 0) {
    fail(fmt::format("invalid counts {} {}", nv, nf));
  }
  // Each vertex and face takes at least two bytes, so larger counts cannot fit in the file.
  if (static_cast<std::uint64_t>(nv + nf) > text.size()) {
    fail(fmt::format("counts {} vertices and {} faces exceed the file size", nv, nf));
  }
  OffData off;
  std::vector<float>& xyz = off.xyz;
  std::vector<double> xyz_d;  // in double, for the local origin (float_precision.h)
  xyz_d.reserve(static_cast<std::size_t>(3 * nv));
  for (std::int64_t v = 0; v < nv; ++v) {
    if (!lines.next(line)) {
      throw IoError(fmt::format("{}: unexpected end of file at vertex {} of {}", name, v, nv));
    }
    Tokens t(line);
    std::array<double, 4> c{0.0, 0.0, 0.0, 1.0};
    for (int k = 0; k < (homogeneous ? 4 : 3); ++k) {
      if (!t.next(tok) || !parse_number(tok, c[static_cast<std::size_t>(k)])) {
        fail(fmt::format("vertex {}: expected {} coordinates", v, homogeneous ? 4 : 3));
      }
    }
    for (int k = 0; k < 3; ++k) {
      const double x = c[static_cast<std::size_t>(k)] / c[3];
      if (!std::isfinite(static_cast<float>(x))) {
        fail(fmt::format("vertex {}: non-finite coordinate", v));
      }
      xyz_d.push_back(x);
    }
    if (with_normals) {
      for (int k = 0; k < 3; ++k) {
        float x = 0.0f;
        if (!t.next(tok) || !parse_number(tok, x) || !std::isfinite(x)) {
          fail(fmt::format("vertex {}: expected a finite normal after the coordinates", v));
        }
        off.normals.push_back(x);
      }
    }
  }
  {
    Eigen::Matrix3Xf local;
    off.origin = localize(
        static_cast<Eigen::Index>(nv),
        [&](int k, Eigen::Index i) { return xyz_d[static_cast<std::size_t>(3 * i + k)]; }, local,
        name, "vertex");
    xyz.assign(local.data(), local.data() + local.size());
  }
  std::vector<int>& tri = off.tri;
  tri.reserve(static_cast<std::size_t>(3 * nf));
  std::vector<int> poly;
  for (std::int64_t f = 0; f < nf; ++f) {
    if (!lines.next(line)) {
      throw IoError(fmt::format("{}: unexpected end of file at face {} of {}", name, f, nf));
    }
    Tokens t(line);
    std::int64_t n = 0;
    if (!t.next(tok) || !parse_number(tok, n)) fail(fmt::format("face {}: expected a count", f));
    if (n < 3) fail(fmt::format("face {}: polygon with {} vertices", f, n));
    poly.clear();
    for (std::int64_t k = 0; k < n; ++k) {
      std::int64_t v = -1;
      if (!t.next(tok) || !parse_number(tok, v)) {
        fail(fmt::format("face {}: expected {} vertex indices", f, n));
      }
      if (v < 0 || v >= nv) fail(fmt::format("face {}: vertex index {} out of range", f, v));
      poly.push_back(static_cast<int>(v));
    }
    // Anything after the indices is a face colour, which scanbench does not keep.
    for (std::size_t k = 1; k + 1 < poly.size(); ++k) {
      tri.push_back(poly[0]);
      tri.push_back(poly[k]);
      tri.push_back(poly[k + 1]);
    }
  }
  if (lines.next(line)) fail("unexpected content after the last face");
  off.faces = nf;
  return off;
}

TriangleMesh read_off(std::string_view text, const std::string& name) {
  return mesh_from_off(parse_off(text, name), name);
}

TriangleMesh mesh_from_off(const OffData& off, const std::string& name) {
  TriangleMesh m = to_mesh(off.xyz, off.tri);
  m.origin = off.origin;
  check_mesh(m, name);
  return m;
}

TriangleMesh read_stl(std::string_view data, const std::string& name) {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // binary STL is float32: never needs one
  std::vector<float> xyz;
  std::vector<int> tri;
  auto add_vertex = [&](float x, float y, float z) {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) return false;
    tri.push_back(static_cast<int>(xyz.size() / 3));
    xyz.push_back(x);
    xyz.push_back(y);
    xyz.push_back(z);
    return true;
  };
  std::uint32_t n = 0;
  if (data.size() >= 84) std::memcpy(&n, data.data() + 80, 4);
  if constexpr (std::endian::native == std::endian::big) n = __builtin_bswap32(n);
  if (data.size() >= 84 && data.size() == 84 + 50 * static_cast<std::uint64_t>(n)) {
    if (n > static_cast<std::uint32_t>(std::numeric_limits<std::int32_t>::max() / 3)) {
      throw IoError(fmt::format("{}: too many triangles ({})", name, n));
    }
    xyz.reserve(9 * std::size_t{n});
    tri.reserve(3 * std::size_t{n});
    for (std::uint32_t t = 0; t < n; ++t) {
      const char* p = data.data() + 84 + 50 * std::size_t{t} + 12;  // skip the facet normal
      for (int k = 0; k < 3; ++k, p += 12) {
        if (!add_vertex(read_le_float(p), read_le_float(p + 4), read_le_float(p + 8))) {
          throw IoError(fmt::format("{}: triangle {}: non-finite coordinate", name, t));
        }
      }
    }
  } else {
    std::size_t start = 0;
    while (start < data.size() && space(data[start]))
      ++start;
    if (data.substr(start, 5) != "solid") {
      if (data.size() >= 84) {
        throw IoError(fmt::format(
            "{}: not an ascii STL (no 'solid') and not a binary STL (size {} != 84 + 50 * {})",
            name, data.size(), n));
      }
      throw IoError(fmt::format("{}: not an STL file (too short for binary, no 'solid')", name));
    }
    Lines lines(data);
    std::string_view line;
    std::string_view tok;
    // States: 0 outside solid, 1 in solid, 2 in facet, 3 in loop (k vertices read), 4 loop closed.
    int state = 0;
    int k = 0;
    std::vector<double> xyz_d;  // in double, for the local origin (float_precision.h)
    auto fail = [&](const std::string& what) -> void {
      throw IoError(fmt::format("{}: line {}: {}", name, lines.number(), what));
    };
    while (lines.next(line)) {
      Tokens t(line);
      t.next(tok);
      if (tok == "solid" && state == 0) {
        state = 1;
      } else if (tok == "endsolid" && state == 1) {
        state = 0;
      } else if (tok == "facet" && state == 1) {
        state = 2;  // the facet normal is recomputed from the vertices by every consumer
      } else if (tok == "outer" && state == 2) {
        if (!t.next(tok) || tok != "loop") fail("expected 'outer loop'");
        state = 3;
        k = 0;
      } else if (tok == "vertex" && state == 3) {
        if (k == 3) fail("facet with more than 3 vertices");
        std::array<double, 3> c{};
        for (int a = 0; a < 3; ++a) {
          if (!t.next(tok) || !parse_number(tok, c[static_cast<std::size_t>(a)])) {
            fail("expected 'vertex <x> <y> <z>'");
          }
        }
        xyz_d.insert(xyz_d.end(), c.begin(), c.end());
        if (!add_vertex(static_cast<float>(c[0]), static_cast<float>(c[1]),
                        static_cast<float>(c[2]))) {
          fail("non-finite coordinate");
        }
        ++k;
      } else if (tok == "endloop" && state == 3) {
        if (k != 3) fail(fmt::format("facet with {} vertices", k));
        state = 4;
      } else if (tok == "endfacet" && state == 4) {
        state = 1;
      } else {
        fail(fmt::format("unexpected '{}'", tok.substr(0, 40)));
      }
    }
    if (state != 0) {
      throw IoError(fmt::format("{}: unexpected end of file (missing endsolid)", name));
    }
    Eigen::Matrix3Xf local;
    origin = localize(
        static_cast<Eigen::Index>(xyz_d.size() / 3),
        [&](int k, Eigen::Index i) { return xyz_d[static_cast<std::size_t>(3 * i + k)]; }, local,
        name, "vertex");
    xyz.assign(local.data(), local.data() + local.size());
  }
  TriangleMesh m = weld_coincident_vertices(to_mesh(xyz, tri));
  m.origin = origin;
  check_mesh(m, name);
  return m;
}

}  // namespace io_detail

TriangleMesh read_mesh(const std::filesystem::path& path) {
  const std::string ext = lower_extension(path);
  const std::string name = path.string();
  if (ext == ".ply") return io_detail::mesh_from_ply(ply::read(path), name);
  if (ext == ".off") return io_detail::read_off(slurp(path), name);
  if (ext == ".stl") return io_detail::read_stl(slurp(path), name);
  if (ext == ".obj") return read_obj(path);
  throw IoError(fmt::format("{}: unsupported mesh format '{}' (expected .off, .ply, .obj, .stl)",
                            name, path.extension().string()));
}

void write_mesh(const TriangleMesh& mesh, const std::filesystem::path& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".ply") return io_detail::write_mesh_ply(mesh, path);
  if (ext == ".obj") return write_obj(mesh, path);
  throw IoError(fmt::format("{}: unsupported mesh output format '{}' (expected .ply, .obj)",
                            path.string(), path.extension().string()));
}

}  // namespace scanbench
