#pragma once
// LOP and WLOP: the discrete locally optimal projection operators (Lipman et al. 2007; weighted
// variant Huang et al. 2009), as reviewed in the CLOP paper (Preiner et al. 2014) sections 3 and 7.
//
// Particles Q(0) are a seeded subset of the input points P (or, when more particles than points
// are requested, every point plus jittered copies). The first iteration is the L2 weighted mean
// (eq. 2); every further iteration sets q_i <- F1(q_i, P) + mu F2(q_i, Q) (eq. 3) with
//   F1(q) = sum_j p_j (alpha_j / v_j) / sum_j (alpha_j / v_j)            (eq. 4, 6; WLOP: eq. 25)
//           with alpha_j = theta(|p_j - q|) / |p_j - q|
//   F2(q) = sum_i' (q - q_i') beta_i' w_i' / sum_i' beta_i' w_i'   (eq. 5, 6; WLOP weights w_i')
//           with beta_i' = theta(r) / r, r = |q - q_i'|, since eta(r) = -r gives |eta'(r)| = 1
// WLOP: v_j = 1 + sum_{j' != j} theta(|p_j - p_j'|) once for the input, w_i' = 1 + sum_{i'' != i'}
// theta(|q_i' - q_i''|) every iteration (Huang et al. 2009; section 7); LOP: v = w = 1.
//
// Kernel: theta(r) = exp(-16 r^2 / h^2) (the LOP/CLOP convention, section 3; CGAL's WLOP uses
// exp(-4 r^2/R^2), i.e. R = h/2 for the same kernel), h a fraction of the input's bounding-box
// diagonal. Every sum runs over the support radius h (theta(h) = exp(-16) ~ 1.1e-7; nothing beyond
// h counts, so a particle with no other particle within h feels no repulsion). Neighbours come
// from the project's uniform neighbour grid (algorithms/src/spatial/neighbor_grid.h, cells of side h/2),
// streamed per particle and summed with vectorised float kernels; distances are clamped below at
// 0.01 h inside alpha and beta. With `interleave` (off by default) the repulsion vector F2 is
// recomputed only in the first, every second and the last iteration and reused in between, as
// resample.clop does (CLOP paper sec. 8). All particles move simultaneously (Jacobi update) and each
// particle's sums run in a fixed order, so the output is bit-identical for any thread count.
#include "scanbench/core/params.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/run_context.h"

namespace scanbench::algorithms {

struct LopParams {
  /// Kernel support radius h as a fraction of the input bbox diagonal.
  double h = 0.04;
  /// Repulsion weight mu of eq. 3, in [0, 0.5).
  double mu = 0.45;
  /// Number of iterations, counting the L2 first iteration (eq. 2).
  int iterations = 10;
  /// Share of the input in (0, 1], or a count > 1 (integer; may exceed the input: upsampling).
  double particles = 0.5;
  /// Recompute F2 only every second iteration and in the last (CLOP paper sec. 8).
  bool interleave = false;

  static void declare(ParamDeclarer<LopParams>& d) {
    d.real("h", &LopParams::h, Range::open_min(0.0, 1.0), "diag",
           "kernel support radius h as a fraction of the input bbox diagonal; theta(r) = "
           "exp(-16 r^2/h^2) (LOP/CLOP convention, CLOP paper sec. 3), searches within h");
    d.real("mu", &LopParams::mu, Range::half_open(0.0, 0.5), "",
           "repulsion weight mu of q <- F1 + mu F2 (CLOP paper eq. 3)");
    d.integer("iterations", &LopParams::iterations, Range::closed(1, 1000), "",
              "iterations including the L2 first iteration (eq. 2)");
    d.real("particles", &LopParams::particles, Range::above(0.0), "",
           "particles: a share of the input in (0, 1] or an integral count > 1 (a seeded subset; "
           "counts above the input size add jittered copies)");
    d.flag("interleave", &LopParams::interleave,
           "interleaved repulsion (CLOP paper sec. 8, which ran it for CLOP and WLOP alike, sec. "
           "10.2): recompute F2 only in every second iteration and in the last, reusing the "
           "previous F2 vector in between (resample.clop's interleave)");
  }
};

/// LOP (v = w = 1). Output: the particle positions only (no other attribute; the particles are
/// not input points). Seed stream "particles" of ctx. Phase timers: "init" (neighbour grid,
/// particle selection, L2 iteration), "attraction", "repulsion". Throws InputError for an empty or
/// invalid input, ParamError for an invalid particle count.
PointCloud lop(const PointCloud& input, const LopParams& p, RunContext& ctx);

/// WLOP (density weights v_j of the input once and w_i of the particles every iteration).
/// Same output and errors as lop(); timers "init", "density" (the v_j), "attraction" and
/// "repulsion" (the particle weights w_i and F2).
PointCloud wlop(const PointCloud& input, const LopParams& p, RunContext& ctx);

}  // namespace scanbench::algorithms
