#pragma once
// File IO of meshes, point clouds and Gaussian mixtures. Every reader validates what it reads and
// throws IoError("<path>: <what>") for a missing, truncated or malformed file and for non-finite
// coordinates; nothing is silently repaired.
//
// Formats:
//  - meshes: read .off, .ply (ascii, binary little/big endian), .obj (tinyobjloader, polygons
//    fan-triangulated), .stl (ascii and binary; coincident vertices merged exactly);
//    write .ply (binary little endian) and .obj.
//  - point clouds: .ply with element `vertex` (x, y, z; optional nx, ny, nz; weight; scan_id; any
//    further float property kept by name) and an optional element `sensor` (x, y, z), one per
//    scan id. Writing is deterministic (no timestamps), so equal clouds give equal bytes.
//  - Gaussian mixtures: .ply with element `component` and properties x, y, z, covxx, covxy,
//    covxz, covyy, covyz, covzz, weight (the convention of the reference HEM tools) plus optional
//    nx, ny, nz, normal_spread for the normal-axis distribution.
#include <filesystem>

#include "scanbench/core/gaussian_mixture.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench {

enum class PlyFormat { Ascii, BinaryLittleEndian };

TriangleMesh read_mesh(const std::filesystem::path& path);
void write_mesh(const TriangleMesh& mesh, const std::filesystem::path& path);

PointCloud read_point_cloud(const std::filesystem::path& path);
void write_point_cloud(const PointCloud& cloud, const std::filesystem::path& path,
                       PlyFormat format = PlyFormat::BinaryLittleEndian);

GaussianMixture read_mixture(const std::filesystem::path& path);
void write_mixture(const GaussianMixture& mixture, const std::filesystem::path& path,
                   PlyFormat format = PlyFormat::BinaryLittleEndian);

}  // namespace scanbench
