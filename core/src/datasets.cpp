#include "scanbench/core/datasets.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>

#include "scanbench/core/io.h"
#include "scanbench/core/paths.h"
#include "scanbench/core/procedural.h"

namespace scanbench {

namespace {

template <class P>
DatasetRegistry::Entry procedural(std::string name, std::string doc,
                                  TriangleMesh (*make)(const P&)) {
  DatasetRegistry::Entry e;
  e.params = schema_of<P>();
  e.fn.load = [make, name](const Json& params) {
    return make(params_from_json<P>(params, "dataset " + name));
  };
  e.name = std::move(name);
  e.doc = std::move(doc);
  return e;
}

DatasetRegistry::Entry file_dataset(std::string name, const std::string& file, std::string doc) {
  DatasetRegistry::Entry e;
  e.name = std::move(name);
  e.doc = std::move(doc) + " (data/meshes/" + file + ", extracted from libcgal-demo by " +
          "scripts/setup.sh)";
  e.fn.file = data_root() / "meshes" / file;
  e.fn.load = [path = e.fn.file](const Json&) { return read_mesh(path); };
  return e;
}

DatasetRegistry build_registry() {
  DatasetRegistry r("dataset");
  r.add(procedural<SphereParams>(
      "sphere", "Sphere (cube-sphere triangulation, equal-angle map); smooth, constant curvature.",
      &make_sphere));
  r.add(procedural<TorusParams>(
      "torus", "Ring torus about z; smooth, with positive and negative Gaussian curvature.",
      &make_torus));
  r.add(procedural<CubeParams>(
      "cube", "Axis-aligned cube with 12 sharp 90-degree edges and 8 corners.", &make_cube));
  r.add(procedural<PlateParams>(
      "plate", "Thin square plate: a plane to within its thickness (GPF Fig. 4), with sharp rims.",
      &make_plate));
  r.add(procedural<FandiskBlockParams>(
      "fandisk_block",
      "Fandisk-like extruded block: sharp convex and concave creases plus a G1 cylindrical "
      "fillet (smooth blend).",
      &make_fandisk_block));
  r.add(procedural<RippleParams>(
      "ripple",
      "Radially symmetric ripple height field of CLOP (Preiner et al. 2014, Fig. 12a): sharp "
      "circular ridges of varying angle, curved trenches, conic apex; closed by a wall and a "
      "flat bottom.",
      &make_ripple));
  r.add(file_dataset("bunny", "bunny00.off", "Stanford bunny (closed)"));
  r.add(file_dataset("fandisk", "fandisk.off", "Fandisk CAD part: creases and smooth blends"));
  r.add(file_dataset("armadillo", "armadillo.off", "Armadillo: fine detail"));
  r.add(file_dataset("camel", "camel.off", "Camel: thin legs (the CLOP paper's timing model)"));
  r.add(file_dataset("elephant", "elephant.off", "Elephant: thin trunk and legs"));
  r.add(file_dataset("man", "man.off", "Man: thin limbs"));
  r.add(file_dataset("eight", "eight.off", "Eight: genus 2, smooth"));
  r.add(file_dataset("cow", "cow.off", "Cow: smooth with thin parts"));
  r.add(file_dataset("knot", "knot.off", "Trefoil-like knot tube: smooth, near self-contact"));
  r.add(file_dataset("hand", "hand.off", "Hand: thin fingers"));
  r.add(file_dataset("femur", "femur.off", "Femur bone: smooth, elongated"));
  return r;
}

}  // namespace

const DatasetRegistry& datasets() {
  static const DatasetRegistry registry = build_registry();
  return registry;
}

TriangleMesh load_dataset(std::string_view name_or_path, const Json& params) {
  if (const auto* e = datasets().find(name_or_path)) {
    const std::string where = "dataset " + e->name;
    const Json effective = e->params.validate(params, where);
    if (!e->fn.available()) {
      throw IoError(fmt::format("{}: file not found (dataset '{}'; run scripts/setup.sh)",
                                e->fn.file.string(), e->name));
    }
    TriangleMesh mesh = e->fn.load(effective);
    mesh.validate(where);
    return mesh;
  }
  const std::filesystem::path path{std::string(name_or_path)};
  std::error_code ec;
  if (std::filesystem::is_regular_file(path, ec)) {
    // A mesh file has no parameters: reject any so a typo is not silently ignored.
    ParamSchema().validate(params, "dataset " + path.string());
    return read_mesh(path);
  }
  std::string known;
  for (const auto& e : datasets().entries())
    known += (known.empty() ? "" : ", ") + e.name;
  throw UnknownNameError(fmt::format(
      "unknown dataset '{}': neither a registered name (known: {}) nor an existing mesh file",
      name_or_path, known));
}

}  // namespace scanbench
