#include "embree_scene.h"

#include <fmt/format.h>

#include "scanbench/core/errors.h"

namespace scanbench::scanner::detail {

namespace {
const char* error_name(RTCError code) {
  switch (code) {
    case RTC_ERROR_NONE:
      return "no error";
    case RTC_ERROR_UNKNOWN:
      return "unknown error";
    case RTC_ERROR_INVALID_ARGUMENT:
      return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION:
      return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY:
      return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU:
      return "unsupported CPU";
    case RTC_ERROR_CANCELLED:
      return "cancelled";
  }
  return "error";
}
}  // namespace

EmbreeDevice::EmbreeDevice() {
  device_ = rtcNewDevice(nullptr);
  if (device_ == nullptr) {
    throw Error(fmt::format("scan: embree: cannot create a device: {}",
                            error_name(rtcGetDeviceError(nullptr))));
  }
  rtcSetDeviceErrorFunction(device_, &EmbreeDevice::on_error, this);
}

EmbreeDevice::~EmbreeDevice() {
  rtcReleaseDevice(device_);
}

void EmbreeDevice::on_error(void* self, RTCError code, const char* message) {
  auto* d = static_cast<EmbreeDevice*>(self);
  std::lock_guard<std::mutex> lock(d->mutex_);
  if (d->first_error_.empty()) {
    d->first_error_ = fmt::format("{} ({})", error_name(code), message ? message : "");
  }
}

void EmbreeDevice::check(const char* what) {
  const RTCError code = rtcGetDeviceError(device_);
  std::string message;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    message.swap(first_error_);
  }
  if (code != RTC_ERROR_NONE || !message.empty()) {
    throw Error(fmt::format("scan: embree: {}: {}", what,
                            message.empty() ? std::string(error_name(code)) : message));
  }
}

EmbreeScene::EmbreeScene(EmbreeDevice& device, const TriangleMesh& mesh) {
  scene_ = rtcNewScene(device.get());
  device.check("new scene");
  try {
    RTCGeometry geom = rtcNewGeometry(device.get(), RTC_GEOMETRY_TYPE_TRIANGLE);
    device.check("new geometry");
    // New (Embree-owned) buffers are padded by Embree for its 16-byte vertex loads.
    auto* v = static_cast<float*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                3 * sizeof(float), static_cast<size_t>(mesh.num_vertices())));
    auto* f = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(unsigned), static_cast<size_t>(mesh.num_faces())));
    if (v == nullptr || f == nullptr) {
      rtcReleaseGeometry(geom);
      device.check("geometry buffers");
      throw Error("scan: embree: cannot allocate geometry buffers");
    }
    for (Eigen::Index i = 0; i < mesh.num_vertices(); ++i) {
      for (int k = 0; k < 3; ++k)
        v[3 * i + k] = mesh.vertices(k, i);
    }
    for (Eigen::Index i = 0; i < mesh.num_faces(); ++i) {
      for (int k = 0; k < 3; ++k)
        f[3 * i + k] = static_cast<unsigned>(mesh.faces(k, i));
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometry(scene_, geom);
    rtcReleaseGeometry(geom);
    // Robust traversal: no rays slip through shared edges of a closed mesh.
    rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
    rtcCommitScene(scene_);
    device.check("commit scene");
  } catch (...) {
    rtcReleaseScene(scene_);
    throw;
  }
}

EmbreeScene::~EmbreeScene() {
  rtcReleaseScene(scene_);
}

}  // namespace scanbench::scanner::detail
