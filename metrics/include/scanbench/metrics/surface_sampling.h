#pragma once
// Uniform, area-weighted random samples on a triangle mesh, seeded and independent of the thread
// count: sample i draws from its own stream Rng(derive_seed(seed, i)), picks a face with
// probability proportional to its area (binary search in the prefix sums of the areas, in
// double) and a uniform point in it (u = sqrt(r1): p = (1-u) a + u (1-r2) b + u r2 c).
#include <cstdint>

#include "scanbench/core/point_cloud.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench::metrics {

/// `count` samples of `mesh` with the unit face normal of the sampled face as normal and the
/// face index in property "face". Throws InputError for a mesh without positive area or a
/// negative count.
PointCloud sample_surface(const TriangleMesh& mesh, Eigen::Index count, std::uint64_t seed);

}  // namespace scanbench::metrics
