// `scanbench bench subdivide`: GP-Loop (GPS paper sec. 4-5: Loop on the 9-number dual vertices,
// mapped back by eq. 12) against linear Loop on the same control mesh, levels 1-4, in interleaved
// rounds; plus the accuracy of both limit surfaces against the known smooth original of coarse
// control meshes (sphere and torus).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "scanbench/algorithms/gps/gps.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/procedural.h"
#include "scanbench/core/run_context.h"
#include "scanbench/harness/pipelines/bench.h"

namespace scanbench::harness {

namespace {

using algorithms::SubdivideParams;
using algorithms::SubdivisionScheme;

struct Control {
  std::string name;
  Eigen::Matrix3Xd positions;
  PolygonFaces faces;
  double (*distance)(const Eigen::Vector3d&);  // exact distance to the smooth original
};

constexpr double kTorusR = 1.0, kTorusr = 0.35;

Control sphere_control(int resolution) {
  SphereParams sp;
  sp.resolution = resolution;
  const TriangleMesh t = make_sphere(sp);
  return {fmt::format("sphere_r{}", resolution), t.vertices.cast<double>(), algorithms::faces_of(t),
          [](const Eigen::Vector3d& p) { return std::abs(p.norm() - 1); }};
}

Control torus_control(int major, int minor) {
  TorusParams tp;
  tp.major_radius = kTorusR;
  tp.minor_radius = kTorusr;
  tp.major_segments = major;
  tp.minor_segments = minor;
  const TriangleMesh t = make_torus(tp);
  return {fmt::format("torus_{}x{}", major, minor), t.vertices.cast<double>(),
          algorithms::faces_of(t), [](const Eigen::Vector3d& p) {
            const double rho = std::hypot(p.x(), p.y()) - kTorusR;
            return std::abs(std::hypot(rho, p.z()) - kTorusr);
          }};
}

struct SurfaceDistance {
  double mean = 0, rms = 0, max = 0;
};

SurfaceDistance surface_distance(const Eigen::Matrix3Xd& p,
                                 double (*distance)(const Eigen::Vector3d&)) {
  SurfaceDistance a;
  for (Eigen::Index i = 0; i < p.cols(); ++i) {
    const double d = distance(p.col(i));
    a.mean += d;
    a.rms += d * d;
    a.max = std::max(a.max, d);
  }
  a.mean /= static_cast<double>(p.cols());
  a.rms = std::sqrt(a.rms / static_cast<double>(p.cols()));
  return a;
}

}  // namespace

Json bench_subdivide(const SubdivideBenchOptions& opts) {
  SubdivideBenchOptions o = opts;
  if (o.quick) o.rounds = std::min(o.rounds, 2);
  RunContext ctx(o.seed, o.threads);
  algorithms::InferenceParams ip;
  ip.sigma_0 = o.sigma_0;
  Json out = {{"benchmark", "subdivide"},
              {"context", run_context_json()},
              {"threads", o.threads},
              {"sigma_0_rel", o.sigma_0}};

  // Speed: the same control mesh, linear Loop on positions vs GP-Loop on covariances.
  const Control c = sphere_control(o.resolution);
  const CovarianceMesh cm = algorithms::infer_covariances(c.positions, c.faces, ip, "bench");
  fmt::print("subdivide: control mesh {} ({} vertices, {} triangles), {} rounds + {} warm-up\n",
             c.name, c.positions.cols(), c.faces.num_faces(), o.rounds, o.warmup);
  std::vector<TimedCase> cases;
  std::vector<std::size_t> faces(5, 0);
  for (int levels = 1; levels <= 4; ++levels) {
    SubdivideParams p;
    p.levels = levels;
    p.limit = true;
    cases.push_back({fmt::format("loop_{}", levels), [&c, &faces, p, levels] {
                       Eigen::Matrix3Xd x = c.positions;
                       PolygonFaces f = c.faces;
                       const Sample s = timed([&] {
                         algorithms::subdivide_linear(x, f, SubdivisionScheme::Loop, p, "bench");
                       });
                       faces[static_cast<std::size_t>(levels)] =
                           static_cast<std::size_t>(f.num_faces());
                       return s;
                     }});
    cases.push_back(
        {fmt::format("gp_loop_{}", levels), [&cm, &ctx, &faces, p, levels] {
           long n = 0;
           const Sample s = timed([&] {
             n = algorithms::gp_subdivide(cm, SubdivisionScheme::Loop, p, ctx, "bench").num_faces();
           });
           if (static_cast<std::size_t>(n) != faces[static_cast<std::size_t>(levels)])
             throw Error("bench subdivide: GP-Loop and Loop disagree on the face count");
           return s;
         }});
  }
  const Rounds rounds = run_rounds(cases, o.rounds, o.warmup);
  std::vector<PairedRatio> ratios;
  Json cases_j = Json::array();
  for (int levels = 1; levels <= 4; ++levels) {
    const std::string lin = fmt::format("loop_{}", levels), gp = fmt::format("gp_loop_{}", levels);
    ratios.push_back(paired_ratio(rounds, fmt::format("gp_loop_over_loop_{}", levels), gp, lin,
                                  Target{2.0, false}, o.seed));
    const Sample l = median_sample(rounds, lin), g = median_sample(rounds, gp);
    cases_j.push_back({{"levels", levels},
                       {"faces", faces[static_cast<std::size_t>(levels)]},
                       {"loop_median_s", l.wall_s},
                       {"gp_loop_median_s", g.wall_s},
                       {"loop_cpu_s", l.cpu_s},
                       {"gp_loop_cpu_s", g.cpu_s}});
    fmt::print("  level {} ({} faces): loop {:.4f} s, gp_loop {:.4f} s\n", levels,
               faces[static_cast<std::size_t>(levels)], l.wall_s, g.wall_s);
  }
  for (const PairedRatio& r : ratios)
    fmt::print("{}\n", describe(r));
  out["control_mesh"] = c.name;
  out["cases"] = cases_j;
  out["rounds"] = to_json(rounds);
  out["ratios"] = ratios_json(ratios);
  out["timed"] =
      "loop: subdivide_linear (connectivity, stencils, values, limit mask); gp_loop: "
      "gp_subdivide (SPD check, dual map, the same, inverse map); not timed: the covariance "
      "inference";

  // SurfaceDistance: limit surfaces of coarse control meshes against their smooth originals.
  fmt::print(
      "accuracy (distance of the limit vertices to the original, fraction of the bbox "
      "diagonal; face-based inference, sigma_0 = {})\n",
      o.sigma_0);
  fmt::print("  {:<12} {:>6} {:>12} {:>12} {:>12} {:>12}\n", "control", "levels", "loop mean",
             "gp mean", "loop rms", "gp rms");
  Json acc = Json::array();
  for (const Control& k : {sphere_control(2), torus_control(12, 6)}) {
    const double diag =
        (k.positions.rowwise().maxCoeff() - k.positions.rowwise().minCoeff()).norm();
    const CovarianceMesh km = algorithms::infer_covariances(k.positions, k.faces, ip, k.name);
    for (int levels = 2; levels <= 4; ++levels) {
      SubdivideParams p;
      p.levels = levels;
      Eigen::Matrix3Xd x = k.positions;
      PolygonFaces f = k.faces;
      algorithms::subdivide_linear(x, f, SubdivisionScheme::Loop, p, k.name);
      const SurfaceDistance l = surface_distance(x, k.distance);
      const SurfaceDistance g = surface_distance(
          algorithms::gp_subdivide(km, SubdivisionScheme::Loop, p, ctx, k.name).means, k.distance);
      fmt::print("  {:<12} {:>6} {:>12.5f} {:>12.5f} {:>12.5f} {:>12.5f}\n", k.name, levels,
                 l.mean / diag, g.mean / diag, l.rms / diag, g.rms / diag);
      acc.push_back({{"control", k.name},
                     {"levels", levels},
                     {"loop_mean_rel", l.mean / diag},
                     {"gp_loop_mean_rel", g.mean / diag},
                     {"loop_rms_rel", l.rms / diag},
                     {"gp_loop_rms_rel", g.rms / diag},
                     {"loop_max_rel", l.max / diag},
                     {"gp_loop_max_rel", g.max / diag}});
    }
  }
  out["accuracy"] = acc;
  return out;
}

}  // namespace scanbench::harness
