#pragma once
// File IO of meshes, point clouds and Gaussian mixtures. Every reader validates what it reads and
// throws IoError("<path>: <what>") for a missing, truncated or malformed file and for non-finite
// coordinates; nothing is silently repaired.
//
// Survey-scale coordinates (stage_data.h, "Local origin"): every reader reads positions in double.
// When float32 would move a coordinate by more than 1e-5 of the data's bounding-box diagonal (e.g.
// UTM coordinates near 1e6..1e7 m), the result gets a local origin (the bounding-box centre rounded
// to a multiple of 2^k, 2^k the largest power of two not above the diagonal) and stores
// float(x - origin); otherwise the origin is zero and the floats are the file's. A PLY comment
// `scanbench_origin X Y Z` states the origin (the reader then uses it). Writers restore it: with a
// nonzero origin, PLY positions (and sensor positions) are written as double origin + local with
// that comment, OBJ vertices as the shortest decimal of the double; at origin zero every file is
// written exactly as without local origins (float32).
//
// Formats:
//  - meshes: read .off, .ply (ascii, binary little/big endian), .obj (tinyobjloader, polygons
//    fan-triangulated), .stl (ascii and binary; coincident vertices merged exactly);
//    write .ply (binary little endian) and .obj.
//  - point clouds: .ply with element `vertex` (x, y, z; optional nx, ny, nz; weight; scan_id; any
//    further float property kept by name) and an optional element `sensor` (x, y, z), one per
//    scan id. Writing is deterministic (no timestamps), so equal clouds give equal bytes.
//    Also read (not written), as CGAL's read_XYZ / read_OFF and Open3D read them:
//    .xyz and .pwn text, one point per line: `x y z` or `x y z nx ny nz`; '#' comments and blank
//    lines skipped; an optional first line holding only the point count (checked). Every line
//    must have the first line's number of values (at least 3); another count is kept: values
//    4.. become float properties `column4`, `column5`... (CGAL would read columns 4-6 of a
//    9-column file as a normal; we do not guess). Six columns whose last three are all zero are
//    points without normals (CGAL writes zeros then). Non-numbers, NaN/inf, fewer than 3 values
//    or a changing column count are IoError("<path>: line <n>: ...").
//    Point-only .off (an OFF with 0 faces, as CGAL's data/points_3/kitten.off; NOFF with normals).
//  - Gaussian mixtures: .ply with element `component` and properties x, y, z, covxx, covxy,
//    covxz, covyy, covyz, covzz, weight (the convention of the reference HEM tools) plus optional
//    nx, ny, nz, normal_spread for the normal-axis distribution.
//  - covariance meshes (GPS paper sec. 4): .ply with element `vertex` (x, y, z, covxx, covxy,
//  covxz,
//    covyy, covyz, covzz; written as double) and element `face` (list vertex_indices; polygons
//    kept).
#include <cstdint>
#include <filesystem>

#include "scanbench/core/covariance_mesh.h"
#include "scanbench/core/gaussian_mixture.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/stage_data.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench {

enum class PlyFormat { Ascii, BinaryLittleEndian };

TriangleMesh read_mesh(const std::filesystem::path& path);
void write_mesh(const TriangleMesh& mesh, const std::filesystem::path& path);

/// .ply, .xyz, .pwn or point-only .off (by extension; see above).
PointCloud read_point_cloud(const std::filesystem::path& path);
void write_point_cloud(const PointCloud& cloud, const std::filesystem::path& path,
                       PlyFormat format = PlyFormat::BinaryLittleEndian);

/// Binary PLY of positions (in the LOCAL frame, the origin is not written: external tools read
/// float32) and normals (when present) as float x y z [nx ny nz] plus uchar red
/// green blue, all set to `gray`: the layout external tools built on PoissonRecon require (COLMAP's
/// poisson_mesher reads nothing, and exits 0, from a PLY without uchar colours).
void write_point_cloud_rgb(const PointCloud& cloud, const std::filesystem::path& path,
                           std::uint8_t gray = 128);

GaussianMixture read_mixture(const std::filesystem::path& path);
void write_mixture(const GaussianMixture& mixture, const std::filesystem::path& path,
                   PlyFormat format = PlyFormat::BinaryLittleEndian);

CovarianceMesh read_covariance_mesh(const std::filesystem::path& path);
void write_covariance_mesh(const CovarianceMesh& mesh, const std::filesystem::path& path,
                           PlyFormat format = PlyFormat::BinaryLittleEndian);

/// Reads a file as the stage data it holds, told apart by content: a PLY with element `component`
/// is a mixture; a PLY whose vertices have covxx..covzz a covariance mesh; a PLY with faces a mesh;
/// any other PLY a point cloud; .xyz and .pwn are point clouds; an .off is a mesh, or a point cloud
/// when it has 0 faces; .obj and .stl are meshes.
StageData read_stage_file(const std::filesystem::path& path);
/// Writes the `kind` of `data` (throws InputError when `data` does not hold it).
void write_stage_kind(const StageData& data, DataKind kind, const std::filesystem::path& path);

}  // namespace scanbench
