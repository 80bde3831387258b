#pragma once
// Ground-truth datasets: built-in procedural shapes that need no files (sphere, torus, cube,
// fandisk-like block, CLOP ripple), the classic meshes extracted by scripts/setup.sh from the
// libcgal-demo package into data/meshes/, and any mesh file by path.
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>

#include "scanbench/core/registry.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench {

struct DatasetFn {
  /// Builds or loads the mesh from validated parameters.
  std::function<TriangleMesh(const Json& params)> load;
  /// The file behind a file dataset (empty for procedural ones).
  std::filesystem::path file;
  /// True when the mesh can be loaded now (always for procedural ones).
  bool available() const { return file.empty() || std::filesystem::exists(file); }
};
using DatasetRegistry = Registry<DatasetFn>;

/// Every registered dataset, in one explicit list.
const DatasetRegistry& datasets();

/// A registered dataset by name, or else a mesh file by path. `params` is validated against the
/// dataset's schema (path "dataset <name>"). Throws UnknownNameError, ParamError or IoError.
TriangleMesh load_dataset(std::string_view name_or_path, const Json& params = Json::object());

}  // namespace scanbench
