#pragma once
// Internal to the algorithms module: one EM iteration of GPF (Lu et al. 2017, Algorithm 1 lines
// 3-4, eq. 3, 10, 11) on data already in GPF's working units (the public filter.gpf scales the
// input to a unit bbox diagonal first; see gpf.h). Exposed for the fidelity tests, which compare
// every term with a brute-force transcription of the equations.
#include <Eigen/Core>
#include <vector>

#include "scanbench/core/run_context.h"
#include "spatial/neighbor_grid.h"

namespace scanbench::algorithms::gpf_detail {

/// The fixed part of the problem: the inputs V with unit normals b_n, the kernel width h (in
/// scanbench's convention, h = 2 h_GPF), the input grid and the input densities rho_n.
class Problem {
 public:
  Problem(Eigen::Matrix3Xf v, Eigen::Matrix3Xf b, float h);
  /// Changes h (gap filling); recomputes rho_n.
  void set_h(float h);

  const Eigen::Matrix3Xf& v() const { return v_; }
  const Eigen::Matrix3Xf& b() const { return b_; }
  float h() const { return h_; }
  /// |v_n - x_m| <= data_radius() for the E-step and data-term pairs (h_GPF / 2 = h / 4).
  float data_radius() const { return 0.25f * h_; }
  /// Repulsion and density radius (h_GPF = h / 2).
  float repulsion_radius() const { return 0.5f * h_; }
  /// rho_n = 1 + sum_{n' != n, |v_n - v_n'| <= h/2} theta(|v_n - v_n'|), theta = exp(-16 r^2/h^2).
  const Eigen::VectorXf& rho() const { return rho_; }
  const detail::NeighborGrid& grid() const { return grid_; }
  /// Normals and 1 / rho in the grid's sorted order, padded like the grid's arrays.
  const std::vector<float>& sorted_b(int d) const { return sb_[d]; }
  const std::vector<float>& sorted_inv_rho() const { return sinv_rho_; }

 private:
  Eigen::Matrix3Xf v_, b_;
  float h_;
  detail::NeighborGrid grid_;
  Eigen::VectorXf rho_;
  std::vector<float> sb_[3];
  std::vector<float> sinv_rho_;
};

/// What one iteration computed.
struct Step {
  Eigen::Matrix3Xf x;                ///< x^{k+1} = x + data + mu * repulsion (eq. 10)
  Eigen::Matrix3Xf data;             ///< the data term of eq. 10 per particle (0 without pairs)
  Eigen::Matrix3Xf repulsion;        ///< the repulsion quotient of eq. 10 (before mu; 0 alone)
  Eigen::VectorXf denominator;       ///< per input: sum_m' exp(-|v_n - x_m'|^2/2 s2) + outlier term
  Eigen::VectorXf particle_weights;  ///< w_m per particle
  double outlier_term = 0.0;         ///< (2 pi s2)^(3/2) omega M / ((1 - omega) N)
  double s2 =
      0.0;  ///< eq. 11 (or its point reading) with x^{k+1}, floored at kMinS2; s2 if N_p = 0
  double np = 0.0;        ///< N_p = sum_mn p_mn
  double max_move = 0.0;  ///< max_m |x^{k+1}_m - x_m|
};

/// Floor of s2 (working units: fraction of the squared diagonal).
inline constexpr double kMinS2 = 1e-12;

/// The residual of the s2 update: Plane = eq. 11 as printed, ((v_n - x_m') . b_n)^2; Point =
/// |v_n - x_m'|^2, the M-step of the isotropic Gaussian mixture whose E-step eq. 3 is (CPD's).
enum class S2Residual { Plane, Point };

/// One E-step (eq. 3) and M-step (eq. 10, 11) from particles x with normals xb (unit) and s2.
/// `total_particles` is M of eq. 3 (x.cols()). Phases "e_step" and "m_step" go to ctx if given.
Step em_step(const Problem& problem, const Eigen::Matrix3Xf& x, const Eigen::Matrix3Xf& xb,
             double s2, double omega, double mu, RunContext* ctx = nullptr,
             S2Residual residual = S2Residual::Plane);

}  // namespace scanbench::algorithms::gpf_detail
