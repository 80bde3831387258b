#pragma once
// Private to scanner-sim: the noise laws of the scanners (ScannerParams noise_family,
// noise_direction, noise_covariance and the shorthand noise_model; scanner.h item 5 and
// docs/scanner.md "Noise families"). One law per scan, resolved and validated once; the draws are
// inline so the range scanner's per-pixel loop pays one predictable branch for them.
//
// Every family draws a deviate of standard deviation 1 per displaced axis (times sigma in the
// caller), so "sigma" means the same in every family. PD-Flow's six families (Mao et al. 2022,
// unknownue/pdflow, dataset/scoredenoise/transforms.py at commit 78c4a67) do not hold the
// standard deviation equal; the differences are findings in docs/scanner.md.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <string>

#include "scanbench/core/params.h"
#include "scanbench/core/rng.h"
#include "scanbench/scanner/scanner.h"
#include "ziggurat.h"

namespace scanbench::scanner::detail {

enum class NoiseFamily { kGaussian, kLaplace, kUniform, kDiscrete, kAnisotropic, kUnidirectional };
enum class NoiseDirection { kRay, kNormal, kIsotropic };

/// The resolved noise law of one scan.
struct NoiseLaw {
  NoiseFamily family = NoiseFamily::kGaussian;
  NoiseDirection direction = NoiseDirection::kRay;
  /// Half-width of the uniform deviate: sqrt 3 (std 1); 1 under the shorthand noise_model =
  /// ray_uniform, whose sigma is the amplitude (std sigma / sqrt 3).
  double uniform_half_width = std::sqrt(3.0);
  /// anisotropic: the lower Cholesky factor L of the unit covariance 3 C / trace(C) (world
  /// frame), so sigma L z has mean per-axis variance sigma^2.
  Eigen::Matrix3d factor = Eigen::Matrix3d::Identity();

  /// One deviate along a unit direction (ray or normal): mean 0, std 1 (the families of one
  /// dimension; never kAnisotropic or kUnidirectional, which noise_law() pairs with kIsotropic).
  double along(Rng& rng, const ZigguratNormal& normal) const {
    switch (family) {
      case NoiseFamily::kGaussian:
        return normal(rng);
      case NoiseFamily::kUniform:
        return uniform_half_width * rng.uniform(-1.0, 1.0);
      case NoiseFamily::kLaplace:
        return laplace(rng);
      case NoiseFamily::kDiscrete: {
        const std::uint64_t slot = rng.below(10);
        if (slot >= 6) return 0.0;
        return (slot % 2 == 0 ? 1.0 : -1.0) * kDiscreteStep1;
      }
      case NoiseFamily::kAnisotropic:
      case NoiseFamily::kUnidirectional:
        break;
    }
    return normal(rng);
  }

  /// One displacement in the world frame (noise_direction = isotropic): per axis mean 0 and
  /// std 1 (anisotropic: covariance L L^T; unidirectional: x only).
  Eigen::Vector3d spread(Rng& rng, const ZigguratNormal& normal) const {
    switch (family) {
      case NoiseFamily::kDiscrete: {
        // PD-Flow's AddDiscreteNoise: one of the six steps +-x, +-y, +-z with probability 0.1
        // each, none with 0.4; length sqrt 5 gives each axis std 1.
        const std::uint64_t slot = rng.below(10);
        Eigen::Vector3d e = Eigen::Vector3d::Zero();
        if (slot < 6) e[static_cast<int>(slot / 2)] = (slot % 2 == 0 ? 1.0 : -1.0) * kDiscreteStep3;
        return e;
      }
      case NoiseFamily::kAnisotropic: {
        const double z0 = normal(rng);
        const double z1 = normal(rng);
        const double z2 = normal(rng);
        return factor * Eigen::Vector3d(z0, z1, z2);
      }
      case NoiseFamily::kUnidirectional:
        return Eigen::Vector3d(normal(rng), 0.0, 0.0);
      default: {
        const double x = along(rng, normal);
        const double y = along(rng, normal);
        const double z = along(rng, normal);
        return Eigen::Vector3d(x, y, z);
      }
    }
  }

  /// {"family", "direction", "sigma_is", "std_over_sigma", "unit_covariance" (anisotropic)}.
  Json to_json() const;

  /// 1-D discrete step: +-a with probability 0.3 each, 0 with 0.4: std a sqrt(0.6) = 1.
  static inline const double kDiscreteStep1 = 1.0 / std::sqrt(0.6);
  /// 3-D discrete step (one axis of six directions, probability 0.6): per-axis std a sqrt(0.2).
  static inline const double kDiscreteStep3 = std::sqrt(5.0);

 private:
  /// Laplace with scale b = 1/sqrt 2 (std 1) by the inverse CDF on u in (0, 1).
  static double laplace(Rng& rng) {
    const double u = (static_cast<double>(rng.next() >> 11) + 0.5) * 0x1.0p-53;
    const double b = 1.0 / std::sqrt(2.0);
    return u < 0.5 ? b * std::log(2.0 * u) : -b * std::log(2.0 - 2.0 * u);
  }
};

/// Resolves and checks the noise parameters of `p`: the shorthand noise_model (ray_gauss =
/// gaussian along the ray, normal_gauss = gaussian along the normal, ray_uniform = uniform along
/// the ray with sigma its amplitude) or noise_family and noise_direction; anisotropic and
/// unidirectional need noise_direction isotropic; anisotropic needs noise_covariance (9 numbers,
/// symmetric positive definite). Throws ParamError("<where>.<field>: ...") in one line.
NoiseLaw noise_law(const ScannerParams& p, const std::string& where);

}  // namespace scanbench::scanner::detail
