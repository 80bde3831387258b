// scanbench bench subdivide [--json FILE] [--resolution N] [--repeats N] [--threads N]
// GP-Loop (GPS paper sec. 4-5: Loop on the 9-number dual vertices, mapped back by eq. 12) against
// linear Loop on the same control mesh, levels 1-4, in one run; plus the accuracy of both limit
// surfaces against the known smooth original of coarse control meshes (sphere and torus).
#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <memory>

#include "commands.h"
#include "scanbench/algorithms/gps.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/procedural.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/timing.h"
#include "scanbench/harness/records.h"

namespace scanbench::harness {

namespace {

using algorithms::PolygonFaces;
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

void add_bench_subdivide(CLI::App* bench, Cli& cli) {
  struct Opts {
    std::string json;
    int resolution = 16;
    int repeats = 5;
    int threads = 0;
    double sigma_0 = 0.01;
  };
  auto opts = std::make_shared<Opts>();
  CLI::App* sub = bench->add_subcommand(
      "subdivide",
      "GP-Loop vs linear Loop on the same control mesh, levels 1-4 (median CPU seconds, ratio "
      "gp_loop/loop), and both limit surfaces' distance to the smooth original of coarse "
      "sphere and torus control meshes");
  sub->add_option("--json", opts->json, "Write the results as JSON to this file");
  sub->add_option("--resolution", opts->resolution,
                  "Cube-sphere resolution of the timed control mesh (12 n^2 triangles)")
      ->check(CLI::Range(1, 256));
  sub->add_option("--repeats", opts->repeats, "Timed repeats per case (medians are reported)")
      ->check(CLI::Range(1, 1000));
  sub->add_option("--threads", opts->threads, "Worker threads (0 = all)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--sigma0", opts->sigma_0,
                  "sigma_0 of the face-based covariance inference (eq. 17), fraction of the "
                  "bbox diagonal")
      ->check(CLI::Range(1e-6, 1.0));
  sub->callback([&cli, opts] {
    cli.action = [opts] {
      RunContext ctx(1, opts->threads);
      algorithms::InferenceParams ip;
      ip.sigma_0 = opts->sigma_0;
      Json out = Json::object();
      out["benchmark"] = "subdivide";
      // Version, compiler, SIMD path (isa, isa_flags) and allocator policy of this run.
      out["context"] = run_context_json();
      out["threads"] = opts->threads;
      out["repeats"] = opts->repeats;
      out["sigma_0_rel"] = opts->sigma_0;

      // Speed: the same control mesh, linear Loop on positions vs GP-Loop on covariances.
      const Control c = sphere_control(opts->resolution);
      const CovarianceMesh cm = algorithms::infer_covariances(c.positions, c.faces, ip, "bench");
      fmt::print("subdivide: control mesh {} ({} vertices, {} triangles), {} repeats\n", c.name,
                 c.positions.cols(), c.faces.num_faces(), opts->repeats);
      fmt::print("  {:>6} {:>10} {:>12} {:>12} {:>8}\n", "levels", "faces", "loop s", "gp_loop s",
                 "ratio");
      Json cases = Json::array();
      std::vector<double> ratios;
      for (int levels = 1; levels <= 4; ++levels) {
        SubdivideParams p;
        p.levels = levels;
        p.limit = true;
        std::vector<double> lin_cpu, gp_cpu, lin_wall, gp_wall;
        std::size_t faces = 0;
        for (int r = 0; r < opts->repeats; ++r) {
          {
            Eigen::Matrix3Xd x = c.positions;
            PolygonFaces f = c.faces;
            const double c0 = process_cpu_seconds();
            const auto w0 = std::chrono::steady_clock::now();
            algorithms::subdivide_linear(x, f, SubdivisionScheme::Loop, p, "bench");
            lin_wall.push_back(
                std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count());
            lin_cpu.push_back(process_cpu_seconds() - c0);
            faces = static_cast<std::size_t>(f.num_faces());
          }
          {
            const double c0 = process_cpu_seconds();
            const auto w0 = std::chrono::steady_clock::now();
            const CovarianceMesh g =
                algorithms::gp_subdivide(cm, SubdivisionScheme::Loop, p, ctx, "bench");
            gp_wall.push_back(
                std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count());
            gp_cpu.push_back(process_cpu_seconds() - c0);
            if (static_cast<std::size_t>(g.num_faces()) != faces)
              throw Error("bench subdivide: GP-Loop and Loop disagree on the face count");
          }
        }
        const double lc = median(lin_cpu), gc = median(gp_cpu);
        ratios.push_back(gc / lc);
        fmt::print("  {:>6} {:>10} {:>12.4f} {:>12.4f} {:>7.2f}x\n", levels, faces, lc, gc,
                   gc / lc);
        cases.push_back({{"levels", levels},
                         {"faces", faces},
                         {"loop_cpu_median_seconds", lc},
                         {"gp_loop_cpu_median_seconds", gc},
                         {"loop_wall_median_seconds", median(lin_wall)},
                         {"gp_loop_wall_median_seconds", median(gp_wall)},
                         {"loop_cpu_seconds", lin_cpu},
                         {"gp_loop_cpu_seconds", gp_cpu},
                         {"gp_loop_over_loop", gc / lc}});
      }
      out["control_mesh"] = c.name;
      out["cases"] = cases;
      out["timed"] =
          "loop: subdivide_linear (connectivity, stencils, values, limit mask); gp_loop: "
          "gp_subdivide (SPD check, dual map, the same, inverse map); not timed: the covariance "
          "inference";
      const double worst = *std::max_element(ratios.begin(), ratios.end());
      fmt::print("  gp_loop_over_loop  {:.2f}x median over levels, {:.2f}x worst (target <= 2)\n",
                 median(ratios), worst);
      out["ratios"] = {{"gp_loop_over_loop", median(ratios)},
                       {"gp_loop_over_loop_max", worst},
                       {"gp_loop_over_loop_largest", ratios.back()}};
      out["targets"] = {{"gp_loop_over_loop_max", 2.0}};

      // SurfaceDistance: limit surfaces of coarse control meshes against their smooth originals.
      fmt::print(
          "accuracy (distance of the limit vertices to the original, fraction of the bbox "
          "diagonal; face-based inference, sigma_0 = {})\n",
          opts->sigma_0);
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
              algorithms::gp_subdivide(km, SubdivisionScheme::Loop, p, ctx, k.name).means,
              k.distance);
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
      if (!opts->json.empty()) {
        std::ofstream f(opts->json, std::ios::binary | std::ios::trunc);
        f << out.dump(2) << "\n";
        f.flush();
        if (!f) throw IoError(fmt::format("{}: cannot write", opts->json));
      }
      return 0;
    };
  });
}

}  // namespace scanbench::harness
