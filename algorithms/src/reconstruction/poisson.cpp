#include "scanbench/algorithms/reconstruction/poisson.h"

#include <fmt/format.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "input_checks.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/run_program.h"

namespace scanbench::algorithms {

namespace {

// The PLY reader below exists because core's (read_mesh) refuses non-finite coordinates by
// design (io.h: nothing is silently repaired) and must keep doing so for every other file; it
// runs only when read_mesh refused a file, to find and count the NaN vertices PoissonRecon 8.0
// writes (poisson.h). It reads the one layout PoissonRecon writes (binary little endian, scalar
// vertex properties, a face list); anything else stays read_mesh's error.

struct PlyProperty {
  std::string name;
  std::string type;        // scalar type, or the list's item type
  std::string count_type;  // the list's count type; empty for a scalar
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
};

// Bytes of a PLY scalar type (both spellings of the PLY 1.0 specification); 0 for another name.
std::size_t type_size(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "int32" || t == "uint32" || t == "float" || t == "float32")
    return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

template <typename T>
double load(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return static_cast<double>(v);
}

// The value of scalar type `t` at `p` (little endian, as the host: checked by the caller).
double scalar_at(const char* p, const std::string& t) {
  if (t == "char" || t == "int8") return load<std::int8_t>(p);
  if (t == "uchar" || t == "uint8") return load<std::uint8_t>(p);
  if (t == "short" || t == "int16") return load<std::int16_t>(p);
  if (t == "ushort" || t == "uint16") return load<std::uint16_t>(p);
  if (t == "int" || t == "int32") return load<std::int32_t>(p);
  if (t == "uint" || t == "uint32") return load<std::uint32_t>(p);
  if (t == "float" || t == "float32") return load<float>(p);
  return load<double>(p);
}

// The mesh of a PoissonRecon PLY with its non-finite vertices kept.
TriangleMesh read_ply_keeping_nonfinite(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(fmt::format("{}: cannot open: {}", name, std::strerror(errno)));
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto fail = [&](const std::string& what) {
    return IoError(fmt::format("{}: {}", name, what));
  };
  const std::size_t end = bytes.find("end_header\n");
  if (bytes.rfind("ply\n", 0) != 0 || end == std::string::npos) throw fail("not a PLY file");
  std::istringstream header(bytes.substr(0, end));
  std::vector<PlyElement> elements;
  std::string line;
  bool little_endian = false;
  while (std::getline(header, line)) {
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "format") {
      std::string format;
      ls >> format;
      little_endian = format == "binary_little_endian";
    } else if (word == "element") {
      PlyElement e;
      ls >> e.name >> e.count;
      if (!ls) throw fail("malformed header line '" + line + "'");
      elements.push_back(std::move(e));
    } else if (word == "property") {
      if (elements.empty()) throw fail("a property before any element");
      PlyProperty p;
      ls >> p.type;
      if (p.type == "list") ls >> p.count_type >> p.type;
      ls >> p.name;
      if (!ls || type_size(p.type) == 0 ||
          (!p.count_type.empty() && type_size(p.count_type) == 0)) {
        throw fail("malformed header line '" + line + "'");
      }
      elements.back().properties.push_back(std::move(p));
    }
  }
  if (!little_endian) throw fail("not a binary little endian PLY (PoissonRecon's layout)");

  TriangleMesh mesh;
  std::size_t at = end + std::string("end_header\n").size();
  const auto need = [&](std::size_t n) {
    if (bytes.size() - at < n) throw fail("truncated");
  };
  for (const PlyElement& e : elements) {
    const bool vertex = e.name == "vertex", face = e.name == "face";
    int xyz[3] = {-1, -1, -1};
    for (std::size_t k = 0; k < e.properties.size(); ++k) {
      for (int c = 0; c < 3; ++c) {
        if (e.properties[k].name == std::string(1, static_cast<char>('x' + c)) &&
            e.properties[k].count_type.empty())
          xyz[c] = static_cast<int>(k);
      }
    }
    if (vertex) {
      if (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0) throw fail("element vertex has no x, y, z");
      mesh.vertices.resize(3, static_cast<Eigen::Index>(e.count));
    }
    if (face) mesh.faces.resize(3, static_cast<Eigen::Index>(e.count));
    for (std::size_t r = 0; r < e.count; ++r) {
      for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const PlyProperty& p = e.properties[k];
        if (p.count_type.empty()) {
          const std::size_t size = type_size(p.type);
          need(size);
          for (int c = 0; c < 3; ++c) {
            if (vertex && xyz[c] == static_cast<int>(k)) {
              mesh.vertices(c, static_cast<Eigen::Index>(r)) =
                  static_cast<float>(scalar_at(bytes.data() + at, p.type));
            }
          }
          at += size;
          continue;
        }
        need(type_size(p.count_type));
        const double n = scalar_at(bytes.data() + at, p.count_type);
        at += type_size(p.count_type);
        const std::size_t size = type_size(p.type);
        if (!(n >= 0.0))
          throw fail(fmt::format("element {}, row {}: negative list size", e.name, r));
        need(static_cast<std::size_t>(n) * size);
        if (face && (p.name == "vertex_indices" || p.name == "vertex_index")) {
          if (n != 3.0) {
            throw fail(fmt::format("element face, row {}: {} vertices, expected a triangle", r, n));
          }
          for (int c = 0; c < 3; ++c) {
            const double v =
                scalar_at(bytes.data() + at + static_cast<std::size_t>(c) * size, p.type);
            if (!(v >= 0.0 && v < static_cast<double>(mesh.vertices.cols()))) {
              throw fail(fmt::format("element face, row {}: vertex index {} out of range", r, v));
            }
            mesh.faces(c, static_cast<Eigen::Index>(r)) = static_cast<int>(v);
          }
        }
        at += static_cast<std::size_t>(n) * size;
      }
    }
  }
  if (at != bytes.size())
    throw fail(fmt::format("{} bytes after the last element", bytes.size() - at));
  return mesh;
}

}  // namespace

PoissonMesh drop_nonfinite_vertices(TriangleMesh mesh) {
  PoissonMesh r;
  r.read_vertices = mesh.num_vertices();
  r.read_faces = mesh.num_faces();
  std::vector<int> new_index(static_cast<std::size_t>(mesh.num_vertices()), -1);
  Eigen::Index kept = 0;
  for (Eigen::Index v = 0; v < mesh.num_vertices(); ++v) {
    if (!mesh.vertices.col(v).allFinite()) continue;
    new_index[static_cast<std::size_t>(v)] = static_cast<int>(kept);
    mesh.vertices.col(kept++) = mesh.vertices.col(v);
  }
  r.dropped_vertices = mesh.num_vertices() - kept;
  if (r.dropped_vertices == 0) {
    r.mesh = std::move(mesh);
    return r;
  }
  Eigen::Index kept_faces = 0;
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f) {
    Eigen::Vector3i renumbered;
    for (int c = 0; c < 3; ++c)
      renumbered[c] = new_index[static_cast<std::size_t>(mesh.faces(c, f))];
    if (renumbered.minCoeff() < 0) continue;
    mesh.faces.col(kept_faces++) = renumbered;
  }
  r.dropped_faces = mesh.num_faces() - kept_faces;
  r.mesh.origin = mesh.origin;
  r.mesh.vertices = mesh.vertices.leftCols(kept);
  r.mesh.faces = mesh.faces.leftCols(kept_faces);
  return r;
}

PoissonMesh read_poisson_mesh(const std::filesystem::path& ply) {
  try {
    return drop_nonfinite_vertices(read_mesh(ply));
  } catch (const IoError&) {
    const std::exception_ptr refused = std::current_exception();
    PoissonMesh r;
    try {
      r = drop_nonfinite_vertices(read_ply_keeping_nonfinite(ply));
    } catch (const IoError&) {
      std::rethrow_exception(refused);
    }
    // Not the non-finite case: read_mesh's reason stands.
    if (r.dropped_vertices == 0) std::rethrow_exception(refused);
    return r;
  }
}

StageData poisson(const StageData& in, const PoissonParams& p, RunContext& ctx) {
  constexpr const char* stage = "reconstruct.poisson";
  const PointCloud& points = in.points;
  detail::check_points(points, stage);
  if (!points.has_normals()) {
    throw InputError(
        fmt::format("{}: needs oriented normals, the input points have none (chain "
                    "normals.pca -> reconstruct.poisson)",
                    stage));
  }
  const programs::TempDir dir("poisson");
  const auto input = dir.path() / "points.ply";
  const auto output = dir.path() / "mesh.ply";
  write_point_cloud_rgb(points, input);
  {
    auto timer = ctx.phase("poisson");
    programs::run_program(
        {"colmap", "poisson_mesher", "--input_path", input.string(), "--output_path",
         output.string(), "--PoissonMeshing.depth", std::to_string(p.depth),
         "--PoissonMeshing.point_weight", fmt::format("{}", p.point_weight),
         "--PoissonMeshing.trim", fmt::format("{}", p.trim), "--PoissonMeshing.num_threads", "1"},
        dir.path(), p.timeout_s, stage, ctx);
  }
  programs::require_output(output, dir.path(), "colmap poisson_mesher", "mesh", stage);
  const std::string unusable =
      fmt::format("{}: colmap poisson_mesher exited with code 0 but its mesh is unusable", stage);
  PoissonMesh read;
  try {
    read = read_poisson_mesh(output);
  } catch (const IoError& e) {
    throw Error(fmt::format("{}{}: {}", unusable,
                            p.trim > 0.0 ? " (trim may have removed every vertex)" : "", e.what()));
  }
  if (read.dropped_vertices > 0) {
    if (read.mesh.empty()) {
      throw Error(fmt::format("{}: every face uses one of its {} non-finite vertices", unusable,
                              read.dropped_vertices));
    }
    // The one channel a step has to its job's log (a run keeps a job's stderr in logs/<id>.log).
    std::fprintf(stderr, "%s\n",
                 fmt::format("{}: note: colmap poisson_mesher (PoissonRecon 8.0) placed {} of {} "
                             "vertices at NaN; dropped them and the {} faces using them ({} of {} "
                             "faces kept; the mesh has a hole there)",
                             stage, read.dropped_vertices, read.read_vertices, read.dropped_faces,
                             read.mesh.num_faces(), read.read_faces)
                     .c_str());
  }
  StageData out;
  out.mesh = std::move(read.mesh);
  return out;
}

}  // namespace scanbench::algorithms
