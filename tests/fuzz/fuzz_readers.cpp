// libFuzzer target for core's hand-written readers (PLY codec and its mesh/cloud/mixture/covariance
// mesh mapping, OFF, STL, XYZ/PWN, point-only OFF; COLMAP's cameras, images and points3D in .bin
// and .txt, and fused.ply.vis), on data in memory. The first byte picks the
// reader, the rest is the file content. A reader may only return a valid object or throw IoError;
// any other exception, crash, leak or sanitizer report is a bug. Build and run: see
// tests/fuzz/CMakeLists.txt.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>
#include <string_view>

#include "colmap_readers.h"
#include "io_readers.h"
#include "ply.h"
#include "scanbench/core/errors.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view body(reinterpret_cast<const char*>(data) + 1, size - 1);
  const std::string name = "fuzz";
  try {
    switch (data[0] % 15) {
      case 0: {
        std::istringstream in{std::string(body)};
        (void)scanbench::io_detail::mesh_from_ply(scanbench::ply::read(in, name), name);
        break;
      }
      case 1: {
        std::istringstream in{std::string(body)};
        (void)scanbench::io_detail::cloud_from_ply(scanbench::ply::read(in, name), name);
        break;
      }
      case 2: {
        std::istringstream in{std::string(body)};
        (void)scanbench::io_detail::mixture_from_ply(scanbench::ply::read(in, name), name);
        break;
      }
      case 3:
        (void)scanbench::io_detail::read_off(body, name);
        break;
      case 4:
        (void)scanbench::io_detail::read_stl(body, name);
        break;
      case 5:
        (void)scanbench::io_detail::cloud_from_xyz(body, name);
        break;
      case 6: {
        std::istringstream in{std::string(body)};
        (void)scanbench::io_detail::covariance_mesh_from_ply(scanbench::ply::read(in, name), name);
        break;
      }
      case 7:
        (void)scanbench::colmap::detail::parse_cameras_bin(body, name);
        break;
      case 8:
        (void)scanbench::colmap::detail::parse_cameras_txt(body, name);
        break;
      case 9:
        (void)scanbench::colmap::detail::parse_images_bin(body, name);
        break;
      case 10:
        (void)scanbench::colmap::detail::parse_images_txt(body, name);
        break;
      case 11:
        (void)scanbench::colmap::detail::parse_points_bin(body, name);
        break;
      case 12:
        (void)scanbench::colmap::detail::parse_points_txt(body, name);
        break;
      case 13:
        (void)scanbench::colmap::detail::parse_vis(body, name);
        break;
      default:
        (void)scanbench::io_detail::cloud_from_off(scanbench::io_detail::parse_off(body, name),
                                                   name);
        break;
    }
  } catch (const scanbench::IoError&) {
    // The expected outcome for malformed input.
  }
  return 0;
}
