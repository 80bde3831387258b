#pragma once
// Private to scanner-sim: the surface-sample "scanner" (kind = "surface_samples"; scanner.h and
// docs/scanner.md "Surface samples"). No sensor: Poisson-disk samples of the mesh displaced by
// the scanner's noise law, as the learning literature builds its test sets (ScoreDenoise, Luo and
// Hu 2021, luost26/score-denoise: 10K and 50K Poisson-disk points, noise 1-3% of the bounding
// sphere's radius).
#include <Eigen/Core>
#include <cstdint>

#include "scanbench/scanner/scanner.h"

namespace scanbench::scanner::detail {

/// Poisson-disk samples of a mesh and the unit normal of the face each lies on.
struct SurfaceSamples {
  Eigen::Matrix3Xd points;
  Eigen::Matrix3Xd normals;
};

/// Exactly `n` Poisson-disk samples of `mesh` (local frame) by Open3D's
/// TriangleMesh::SamplePointsPoissonDisk (Yuksel 2015, sample elimination from 5 n uniform
/// samples), its global random engine seeded with `seed` under a process-wide lock (a
/// concurrent Open3D user outside scanbench would interleave with it). Open3D stays in this
/// function's source (poisson_disk.cpp). Throws InputError if Open3D returns another count.
SurfaceSamples poisson_disk_samples(const TriangleMesh& mesh, int n, std::uint32_t seed);

/// The scan of kind surface_samples: Poisson-disk samples (stream "scan.samples"), each
/// displaced by sigma times the noise law (stream "scan.sample_noise", drawn in sample order,
/// so the result depends on no thread count); sigma = noise_sigma times the diagonal or, with
/// noise_scale = sphere_radius, the largest distance of a vertex from the bbox centre.
Scan surface_samples_scan(const TriangleMesh& mesh, const ScannerParams& p, RunContext& ctx);

}  // namespace scanbench::scanner::detail
