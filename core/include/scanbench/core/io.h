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
//  - covariance meshes (GPS paper sec. 4): .ply with element `vertex` (x, y, z, covxx, covxy,
//  covxz,
//    covyy, covyz, covzz; written as double) and element `face` (list vertex_indices; polygons
//    kept).
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

PointCloud read_point_cloud(const std::filesystem::path& path);
void write_point_cloud(const PointCloud& cloud, const std::filesystem::path& path,
                       PlyFormat format = PlyFormat::BinaryLittleEndian);

GaussianMixture read_mixture(const std::filesystem::path& path);
void write_mixture(const GaussianMixture& mixture, const std::filesystem::path& path,
                   PlyFormat format = PlyFormat::BinaryLittleEndian);

CovarianceMesh read_covariance_mesh(const std::filesystem::path& path);
void write_covariance_mesh(const CovarianceMesh& mesh, const std::filesystem::path& path,
                           PlyFormat format = PlyFormat::BinaryLittleEndian);

/// Reads a file as the stage data it holds, told apart by content: a PLY with element `component`
/// is a mixture; a PLY whose vertices have covxx..covzz a covariance mesh; a PLY with faces a mesh;
/// any other PLY a point cloud; .off, .obj and .stl are meshes.
StageData read_stage_file(const std::filesystem::path& path);
/// Writes the `kind` of `data` (throws InputError when `data` does not hold it).
void write_stage_kind(const StageData& data, DataKind kind, const std::filesystem::path& path);

}  // namespace scanbench
