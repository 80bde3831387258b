#pragma once
// Private to scanner-sim: the scanner with its BVH built once, so the throughput benchmark can
// time scans and bare Embree on one scene and one set of rays.
#include <embree3/rtcore.h>

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "embree_scene.h"
#include "scanbench/scanner/scanner.h"

namespace scanbench::scanner::detail {

/// A pinhole range camera looking at the bbox centre.
struct Camera {
  Eigen::Vector3f origin;
  Eigen::Vector3f forward;
  Eigen::Vector3f right;
  Eigen::Vector3f up;
  float tan_half = 0;  ///< tan(fov / 2)
  float fov_deg = 0;
};

class ScannerEngine {
 public:
  /// Validates mesh and parameters and builds the BVH. Throws InputError / ParamError.
  ScannerEngine(const TriangleMesh& mesh, const ScannerParams& p);

  Scan run(RunContext& ctx) const;

  /// views * resolution^2 * sub_rays.
  std::int64_t rays_per_run() const;
  /// Every ray of one run, in the order the scanner casts them (view, tile, pixel, sub-ray).
  std::vector<RTCRayHit> make_all_rays() const;
  /// The bare loop: rtcIntersect1M over `rays` in the scanner's tiles, TBB-parallel.
  void cast_all(std::vector<RTCRayHit>& rays) const;

  static constexpr int kTile = 8;         ///< tiles of kTile x kTile pixels
  static constexpr int kMaxSubRays = 16;  ///< the schema's bound of sub_rays

 private:
  class Run;  // one run's state and its passes (scanner.cpp)
  struct Tile {
    int u0, u1, v0, v1;
  };
  Tile tile(int t) const;
  int tile_ray_count(const Tile& t) const { return (t.u1 - t.u0) * (t.v1 - t.v0) * sub_rays_; }
  /// The unit direction of pixel (u, v)'s beam axis, bit-identical to its cast sub-ray 0.
  Eigen::Vector3f axis_dir(const Camera& cam, int u, int v) const;
  /// Every ray of tile `t` (pixel rows, pixels, sub-rays), ready for rtcIntersect1M.
  void make_tile_rays(const Camera& cam, const Tile& t, RTCRayHit* out) const;

  const TriangleMesh& mesh_;
  ScannerParams p_;
  BoundingBox box_;
  Eigen::Vector3f center_;
  float diag_ = 0;
  Eigen::Index degenerate_faces_ = 0;
  std::vector<Camera> cameras_;
  std::vector<Eigen::Vector2f> beam_offsets_;  ///< per sub-ray, in tangent-plane units
  int sub_rays_ = 1;
  int resolution_ = 1;
  int tiles_x_ = 1;
  int tiles_ = 1;
  std::unique_ptr<EmbreeDevice> device_;
  std::unique_ptr<EmbreeScene> scene_;
};

}  // namespace scanbench::scanner::detail
