#pragma once
// The directions of a tile's rays (scanner.cpp): normalise(forward + x right + y up) per ray, as
// a Highway kernel (ray_directions.cpp) dispatched to the active ISA's target
// (scanbench/core/simd.h). Each lane performs the same IEEE operations in the same order, so a
// direction does not depend on the target, the lane or the step it was computed in.
#include <cstddef>

namespace scanbench::scanner {

/// A camera's basis: forward, right, up (x, y, z each).
struct CameraBasis {
  float forward[3], right[3], up[3];
};

/// Arrays passed to the kernels hold a multiple of this many floats (the widest target's lanes),
/// start on a boundary of as many bytes, and are padded with finite values.
inline constexpr std::size_t kRayLanePad = 16;

/// a = forward + xs[j] right, for j < n (n a multiple of kRayLanePad): the part of a direction
/// that depends on the image-plane x only (shared by the rows of a tile).
void ray_dirs_x(const CameraBasis& c, const float* xs, std::size_t n, float* ax, float* ay,
                float* az);

/// d = normalise(a + (y + oy[j]) up), for j < n (a multiple of kRayLanePad), as d * (1 / sqrt(|d|^2)),
/// written interleaved as Embree's direction row: dir_time[4 j .. 4 j + 3] = d.x, d.y, d.z, 0 (the
/// ray's time); dir_time holds 4 n floats.
void ray_dirs_y(const CameraBasis& c, const float* ax, const float* ay, const float* az,
                const float* oy, float y, std::size_t n, float* dir_time);

}  // namespace scanbench::scanner
