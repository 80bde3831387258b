#pragma once
// Private entry points of core's readers, on data already in memory, shared by the path-based
// functions of io.h and by the fuzz target (tests/fuzz/fuzz_readers.cpp). Each throws
// IoError("<name>: ...") for malformed input; none of them touches the file system.
//
// OFF and STL are hand-written: Debian 12 has no maintained library for them other than assimp,
// which is not a chosen dependency of scanbench (large, and it silently repairs meshes).
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "ply.h"
#include "scanbench/core/covariance_mesh.h"
#include "scanbench/core/gaussian_mixture.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench::io_detail {

/// The extension of `path` in lower case, with its dot (".ply"); "" when it has none.
std::string lower_extension(const std::filesystem::path& path);

/// The whole file; IoError("<path>: cannot open for reading") when it cannot be read.
std::string slurp(const std::filesystem::path& path);

/// Element `vertex` (x, y, z) and element `face` (list vertex_indices or vertex_index; polygons
/// fan-triangulated). A PLY without faces is not a mesh.
TriangleMesh mesh_from_ply(const ply::File& file, const std::string& name);
/// See io.h for the mapping of properties.
PointCloud cloud_from_ply(const ply::File& file, const std::string& name);
GaussianMixture mixture_from_ply(const ply::File& file, const std::string& name);
/// Element `vertex` (x, y, z, covxx ... covzz) and an optional element `face` (polygons kept).
CovarianceMesh covariance_mesh_from_ply(const ply::File& file, const std::string& name);

/// An OFF file as read: vertex coordinates (3 per vertex), per-vertex normals (3 per vertex, only
/// for the NOFF variants), the fan-triangulated faces (3 indices each) and the face count of the
/// header (0 for a point-only OFF such as CGAL's data/points_3/kitten.off).
struct OffData {
  std::vector<float> xyz;  ///< local coordinates (x - origin), see float_precision.h
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  std::vector<float> normals;
  std::vector<int> tri;
  std::int64_t faces = 0;
};
/// Parses an OFF file (the variants of read_off); faces may be absent.
OffData parse_off(std::string_view text, const std::string& name);

/// OFF, with the [ST][C][N][4]OFF header variants (extra per-vertex values after x y z are
/// skipped; 4OFF divides by w), '#' comments, counts on the header line or the next one, and
/// polygons fan-triangulated. Binary OFF and nOFF are rejected.
TriangleMesh read_off(std::string_view text, const std::string& name);
/// A point-only OFF (0 faces) as a point cloud (NOFF: with normals). Throws IoError for an OFF
/// with faces (a mesh: read_mesh).
PointCloud cloud_from_off(const OffData& off, const std::string& name);
/// The mesh of a parsed OFF (IoError when it has no faces).
TriangleMesh mesh_from_off(const OffData& off, const std::string& name);
/// XYZ / PWN text: one point per line, `x y z` or `x y z nx ny nz` (CGAL's read_XYZ and Open3D's
/// xyz/xyzn/pwn); see io.h for the exact rules.
PointCloud cloud_from_xyz(std::string_view text, const std::string& name);
/// True for the extensions of the plain point formats (.xyz, .pwn; .off is a mesh or points).
bool is_xyz_extension(std::string_view lower_ext);

/// STL: binary when the size is exactly 84 + 50 n for the n in its header, else ascii ("solid").
/// Exactly coincident vertices are merged (weld_coincident_vertices).
TriangleMesh read_stl(std::string_view data, const std::string& name);

/// Binary little-endian PLY: element vertex (float x, y, z), element face (list uchar int
/// vertex_indices).
void write_mesh_ply(const TriangleMesh& mesh, const std::filesystem::path& path);

/// Throws IoError("<name>: ...") unless the mesh has faces, finite vertices and indices in range.
void check_mesh(const TriangleMesh& mesh, const std::string& name);

}  // namespace scanbench::io_detail
