#include "noise.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <sstream>
#include <vector>

#include "scanbench/core/errors.h"

namespace scanbench::scanner::detail {

namespace {

const char* family_name(NoiseFamily f) {
  switch (f) {
    case NoiseFamily::kGaussian:
      return "gaussian";
    case NoiseFamily::kLaplace:
      return "laplace";
    case NoiseFamily::kUniform:
      return "uniform";
    case NoiseFamily::kDiscrete:
      return "discrete";
    case NoiseFamily::kAnisotropic:
      return "anisotropic";
    case NoiseFamily::kUnidirectional:
      return "unidirectional";
  }
  return "?";
}

const char* direction_name(NoiseDirection d) {
  switch (d) {
    case NoiseDirection::kRay:
      return "ray";
    case NoiseDirection::kNormal:
      return "normal";
    case NoiseDirection::kIsotropic:
      return "isotropic";
  }
  return "?";
}

/// The 3 x 3 covariance of noise_covariance: 9 numbers, row-major, separated by spaces, commas
/// or semicolons.
Eigen::Matrix3d parse_covariance(const std::string& text, const std::string& field) {
  std::string cleaned = text;
  for (char& c : cleaned) {
    if (c == ',' || c == ';') c = ' ';
  }
  std::istringstream in(cleaned);
  std::vector<double> v;
  double x = 0;
  while (in >> x)
    v.push_back(x);
  std::string rest;
  in.clear();
  if ((in >> rest) || v.size() != 9) {
    throw ParamError(
        fmt::format("{}: expected 9 numbers (a 3 x 3 matrix, row-major), got '{}'", field, text));
  }
  Eigen::Matrix3d c;
  for (int i = 0; i < 9; ++i)
    c(i / 3, i % 3) = v[static_cast<std::size_t>(i)];
  if (!c.allFinite()) throw ParamError(fmt::format("{}: not finite: '{}'", field, text));
  const double tol = 1e-9 * c.cwiseAbs().maxCoeff();
  if (!((c - c.transpose()).cwiseAbs().maxCoeff() <= tol)) {
    throw ParamError(fmt::format("{}: not symmetric: '{}'", field, text));
  }
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(c).eigenvalues();
  if (!(ev.minCoeff() > 1e-12 * ev.maxCoeff()) || !(ev.maxCoeff() > 0.0)) {
    throw ParamError(fmt::format("{}: not positive definite (eigenvalues {:g} {:g} {:g}): '{}'",
                                 field, ev[0], ev[1], ev[2], text));
  }
  return c;
}

}  // namespace

Json NoiseLaw::to_json() const {
  Json j = Json::object();
  j["family"] = family_name(family);
  j["direction"] = direction_name(direction);
  const bool amplitude = family == NoiseFamily::kUniform && uniform_half_width == 1.0;
  j["sigma_is"] = amplitude ? "half_width" : "std_per_axis";
  j["std_over_sigma"] = amplitude ? 1.0 / std::sqrt(3.0) : 1.0;
  if (family == NoiseFamily::kAnisotropic) {
    const Eigen::Matrix3d s = factor * factor.transpose();
    j["unit_covariance"] = Json::array();
    for (int i = 0; i < 9; ++i)
      j["unit_covariance"].push_back(s(i / 3, i % 3));
  }
  return j;
}

NoiseLaw noise_law(const ScannerParams& p, const std::string& where) {
  NoiseLaw law;
  if (!p.noise_model.empty()) {
    if (p.noise_family != "gaussian" || p.noise_direction != "ray") {
      throw ParamError(fmt::format(
          "{}.noise_model: '{}' is a shorthand for noise_family and noise_direction; leave it "
          "empty when they are set (got noise_family '{}', noise_direction '{}')",
          where, p.noise_model, p.noise_family, p.noise_direction));
    }
    if (p.noise_model == "ray_gauss") return law;
    if (p.noise_model == "normal_gauss") {
      law.direction = NoiseDirection::kNormal;
      return law;
    }
    if (p.noise_model == "ray_uniform") {
      law.family = NoiseFamily::kUniform;
      law.uniform_half_width = 1.0;
      return law;
    }
    throw ParamError(fmt::format(
        "{}.noise_model: expected ray_gauss, normal_gauss, ray_uniform or empty, got '{}'", where,
        p.noise_model));
  }
  static const NoiseFamily families[] = {NoiseFamily::kGaussian,    NoiseFamily::kLaplace,
                                         NoiseFamily::kUniform,     NoiseFamily::kDiscrete,
                                         NoiseFamily::kAnisotropic, NoiseFamily::kUnidirectional};
  bool found = false;
  for (NoiseFamily f : families) {
    if (p.noise_family == family_name(f)) {
      law.family = f;
      found = true;
    }
  }
  if (!found) {
    throw ParamError(fmt::format(
        "{}.noise_family: expected gaussian, laplace, uniform, discrete, anisotropic or "
        "unidirectional, got '{}'",
        where, p.noise_family));
  }
  if (p.noise_direction == "ray") {
    law.direction = NoiseDirection::kRay;
  } else if (p.noise_direction == "normal") {
    law.direction = NoiseDirection::kNormal;
  } else if (p.noise_direction == "isotropic") {
    law.direction = NoiseDirection::kIsotropic;
  } else {
    throw ParamError(fmt::format("{}.noise_direction: expected ray, normal or isotropic, got '{}'",
                                 where, p.noise_direction));
  }
  const bool world_law =
      law.family == NoiseFamily::kAnisotropic || law.family == NoiseFamily::kUnidirectional;
  if (world_law && law.direction != NoiseDirection::kIsotropic) {
    throw ParamError(fmt::format(
        "{}.noise_direction: the {} family is a 3-D law in the world frame (PD-Flow's {}); "
        "expected isotropic, got '{}'",
        where, p.noise_family,
        law.family == NoiseFamily::kAnisotropic ? "AddCovNoise" : "AddUniDirectional",
        p.noise_direction));
  }
  if (law.family == NoiseFamily::kAnisotropic) {
    if (p.noise_covariance.empty()) {
      throw ParamError(
          fmt::format("{}.noise_covariance: the anisotropic family needs a covariance (9 "
                      "numbers, row-major, symmetric positive definite)",
                      where));
    }
    const Eigen::Matrix3d c = parse_covariance(p.noise_covariance, where + ".noise_covariance");
    const Eigen::Matrix3d unit = (3.0 / c.trace()) * c;
    law.factor = unit.llt().matrixL();
  } else if (!p.noise_covariance.empty()) {
    throw ParamError(fmt::format(
        "{}.noise_covariance: only the anisotropic family takes a covariance (noise_family '{}')",
        where, p.noise_family));
  }
  return law;
}

}  // namespace scanbench::scanner::detail
