// libFuzzer target for the path-based readers as the CLI calls them: the first byte picks an
// extension (.ply .off .obj .stl .xyz .pwn), the rest is written to a file of that extension and
// read by read_stage_file (which tells points, meshes, mixtures and covariance meshes apart by
// content) and by the reader of each kind that accepts the extension (read_mesh, read_point_cloud,
// read_mixture, read_covariance_mesh). This is the only target that reaches the OBJ reader
// (tinyobjloader reads from a path). A reader may only return a valid object or throw IoError.
#include <unistd.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"

namespace {

template <class F>
void expect_io_error_only(F&& read) {
  try {
    read();
  } catch (const scanbench::IoError&) {
    // The expected outcome for malformed input.
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  static constexpr std::array<const char*, 6> kExt{".ply", ".off", ".obj", ".stl", ".xyz", ".pwn"};
  const std::string ext = kExt[data[0] % kExt.size()];
  static const std::filesystem::path dir = std::filesystem::temp_directory_path();
  const std::filesystem::path path = dir / ("scanbench-fuzz-" + std::to_string(::getpid()) + ext);
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data) + 1, static_cast<std::streamsize>(size - 1));
  }
  expect_io_error_only([&] { (void)scanbench::read_stage_file(path); });
  if (ext != ".xyz" && ext != ".pwn") {
    expect_io_error_only([&] { (void)scanbench::read_mesh(path); });
  }
  if (ext != ".obj" && ext != ".stl") {
    expect_io_error_only([&] { (void)scanbench::read_point_cloud(path); });
  }
  if (ext == ".ply") {
    expect_io_error_only([&] { (void)scanbench::read_mixture(path); });
    expect_io_error_only([&] { (void)scanbench::read_covariance_mesh(path); });
  }
  return 0;
}
