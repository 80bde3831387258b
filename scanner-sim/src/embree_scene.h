#pragma once
// Private to scanner-sim: Embree 3 behind small RAII types. Every Embree error is recorded by the
// device's error callback and turned into scanbench::Error("scan: embree: ...") by check().
#include <embree3/rtcore.h>

#include <mutex>
#include <string>

#include "scanbench/core/triangle_mesh.h"

namespace scanbench::scanner::detail {

class EmbreeDevice {
 public:
  EmbreeDevice();
  ~EmbreeDevice();
  EmbreeDevice(const EmbreeDevice&) = delete;
  EmbreeDevice& operator=(const EmbreeDevice&) = delete;

  RTCDevice get() const { return device_; }
  /// Throws Error("scan: embree: <what>: <message>") when an Embree call failed since the last
  /// check.
  void check(const char* what);

 private:
  static void on_error(void* self, RTCError code, const char* message);
  RTCDevice device_ = nullptr;
  std::mutex mutex_;
  std::string first_error_;
};

/// A committed scene of one triangle geometry (a copy of the mesh; geomID 0, primID = face index).
class EmbreeScene {
 public:
  EmbreeScene(EmbreeDevice& device, const TriangleMesh& mesh);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  RTCScene get() const { return scene_; }

 private:
  RTCScene scene_ = nullptr;
};

/// Casts streams of rays with rtcIntersect1M (coherent context). Thread-safe.
class RayCaster {
 public:
  explicit RayCaster(const EmbreeScene& scene) : scene_(scene.get()) {}
  void intersect(RTCRayHit* rays, unsigned count) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    rtcIntersect1M(scene_, &context, rays, count, sizeof(RTCRayHit));
  }

 private:
  RTCScene scene_;
};

}  // namespace scanbench::scanner::detail
