#include "scanbench/scanner/scanner.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <numeric>
#include <optional>
#include <sstream>

#include "noise.h"
#include "photo.h"
#include "ray_directions.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/files.h"
#include "scanbench/core/io.h"
#include "scanner_engine.h"
#include "surface_samples.h"
#include "ziggurat.h"

namespace scanbench::scanner {

void ScannerParams::declare(ParamDeclarer<ScannerParams>& d) {
  using P = ScannerParams;
  d.integer("views", &P::views, Range::closed(1, 10000), "",
            "number of scans (range cameras) around the object");
  d.integer("resolution", &P::resolution, Range::closed(1, 8192), "px",
            "pixels per side of each range image");
  d.real("fov_deg", &P::fov_deg, Range::half_open(0, 170), "deg",
         "full field of view; 0 = fit the bbox's bounding sphere (2 asin(diag/2 / distance))");
  d.text("poses", &P::poses,
         "explicit sensor positions 'x y z; x y z; ...' relative to the bbox centre in diag "
         "units (count must equal views); empty = Fibonacci spiral at range_min + diag/2");
  d.real("range_min", &P::range_min, Range::closed(0, 100), "diag",
         "minimum measurable range; sensors sit at range_min + diag/2 from the centre (Berger "
         "et al. 2013)");
  d.real("range_max", &P::range_max, Range::open_min(0, 1000), "diag",
         "maximum measurable range (farther surfaces give no return)");
  d.real("noise_sigma", &P::noise_sigma, Range::closed(0, 1), "diag",
         "standard deviation of the noise per displaced axis (HELIOS++ accuracy along the ray by "
         "default; noise_family and noise_direction say which law and where; surface_samples: "
         "in noise_scale units)");
  d.real("noise_range_slope", &P::noise_range_slope, Range::closed(0, 1), "",
         "noise growth with range: sigma += slope * range (diag per diag)");
  d.real("noise_incidence_slope", &P::noise_incidence_slope, Range::closed(0, 1), "diag",
         "noise growth with incidence: sigma += slope * (1/max(cos(incidence), 0.01) - 1)");
  d.choice("noise_family", &P::noise_family,
           {"gaussian", "laplace", "uniform", "discrete", "anisotropic", "unidirectional"},
           "the noise law, each with std sigma per displaced axis (PD-Flow's six families): "
           "gaussian; laplace (scale sigma/sqrt 2); uniform U[-sqrt3 sigma, sqrt3 sigma]; "
           "discrete (60% of points move one step, PD-Flow's; 1-D +-sigma/sqrt 0.6, isotropic "
           "one of +-x, +-y, +-z by sqrt5 sigma); anisotropic N(0, sigma^2 3C/trace C) with "
           "C = noise_covariance in the world frame; unidirectional N(0, sigma) along world x "
           "(the last two need noise_direction isotropic)");
  d.choice("noise_direction", &P::noise_direction, {"ray", "normal", "isotropic"},
           "where the noise moves a point: ray (along its ray, as a range error), normal (along "
           "the face normal at the clean point), isotropic (3-D, each world axis independently)");
  d.text("noise_covariance", &P::noise_covariance,
         "anisotropic family: the 3 x 3 covariance C (9 numbers, row-major, world frame, "
         "symmetric positive definite), scaled to trace 3 so the mean per-axis std is sigma");
  d.choice("noise_model", &P::noise_model, {"", "ray_gauss", "normal_gauss", "ray_uniform"},
           "shorthand (the names before noise families; leave noise_family and noise_direction "
           "at their defaults): ray_gauss = gaussian along the ray; normal_gauss = gaussian along "
           "the normal; ray_uniform = uniform along the ray with sigma an amplitude, U[-sigma, "
           "sigma] (std sigma/sqrt 3); empty = use noise_family and noise_direction");
  d.real("max_incidence_deg", &P::max_incidence_deg, Range::open_min(0, 90), "deg",
         "grazing-angle drop-out: hits whose incidence angle exceeds this are lost (90 = off)");
  d.real("beam_divergence_deg", &P::beam_divergence_deg, Range::closed(0, 10), "deg",
         "full beam divergence angle; with sub_rays > 1 gives mixed pixels at depth edges");
  d.integer("sub_rays", &P::sub_rays, Range::closed(1, 16), "",
            "rays per pixel over the beam footprint (HELIOS++ sub-rays); a pixel returns when "
            "at least half hit, at their mean range");
  d.real("flying_pixel_prob", &P::flying_pixel_prob, Range::closed(0, 1), "",
         "probability that a pixel at a depth discontinuity becomes a flying pixel (outlier)");
  d.real("flying_depth_jump", &P::flying_depth_jump, Range::open_min(0, 10), "diag",
         "range difference to a 4-neighbour that counts as a depth discontinuity");
  d.real("flying_spread", &P::flying_spread, Range::closed(0, 10), "diag",
         "how far behind a silhouette (neighbour without hit) a flying pixel may land");
  d.real("misalign_fraction", &P::misalign_fraction, Range::closed(0, 1), "",
         "share of scans that get a registration error: round(fraction * views) scans chosen "
         "at random (SCUTSurface: 0.5)");
  d.real("misalign_deg", &P::misalign_deg, Range::closed(0, 180), "deg",
         "registration error: rotation about a random axis through the scan's centre of mass "
         "(Berger et al. 2013)");
  d.real("misalign_shift", &P::misalign_shift, Range::closed(0, 1), "diag",
         "registration error: translation of this length in a random direction");
  d.real("outlier_fraction", &P::outlier_fraction, Range::closed(0, 0.9), "",
         "probability that an output point is a uniform outlier in the enlarged bbox");
  d.real("outlier_box_scale", &P::outlier_box_scale, Range::closed(1, 10), "",
         "outliers are uniform in the bbox grown by this factor about its centre (Berger: 1.1)");
  d.real("outlier_box_min", &P::outlier_box_min, Range::closed(0, 10), "diag",
         "each side of the outlier box widened about its centre to at least this (0 = none): "
         "room for outliers off a flat model's plane");
  d.text("kind", &P::kind,
         "range (the range scanner), photo (rendered images through COLMAP's sparse "
         "triangulation), photo_dense (COLMAP's patch_match_stereo: needs a CUDA build) or "
         "surface_samples (Poisson-disk samples of the mesh with noise, no sensor: the learning "
         "literature's test sets, e.g. ScoreDenoise's)");
  d.integer("image_width", &P::image_width, Range::closed(16, 8192), "px",
            "photo: width of each rendered image");
  d.integer("image_height", &P::image_height, Range::closed(16, 8192), "px",
            "photo: height of each rendered image");
  d.real("ring_elevation_deg", &P::ring_elevation_deg, Range::closed(-89, 89), "deg",
         "photo: cameras on a ring this far above the horizontal plane (unless poses are given)");
  d.real("texture_scale", &P::texture_scale, Range::open_min(0, 1), "diag",
         "photo: feature size of the procedural solid texture");
  d.real("image_noise", &P::image_noise, Range::closed(0, 1), "",
         "photo: standard deviation of Gaussian grey noise (grey levels in [0, 1])");
  d.real("image_blur_px", &P::image_blur_px, Range::closed(0, 20), "px",
         "photo: standard deviation of a Gaussian blur of each image (0 = none)");
  d.real("outlier_threshold", &P::outlier_threshold, Range::open_min(0, 10), "diag",
         "photo: a point farther than this from the mesh is flagged outlier");
  d.integer("colmap_threads", &P::colmap_threads, Range::closed(1, 256), "",
            "photo: COLMAP's threads for point_triangulator (SIFT extraction and geometric "
            "verification use 1; the descriptor matching uses the run's threads); the scan does "
            "not depend on it (docs/scanner.md, Determinism)");
  d.text("registration", &P::registration,
         "photo: known (point_triangulator with the rendered poses) or mapper (COLMAP's "
         "incremental mapper estimates the poses, then model_aligner aligns its camera centres "
         "to the rendered ones by a least-squares similarity: the scan includes the "
         "registration error)");
  d.real("colmap_timeout_s", &P::colmap_timeout_s, Range::open_min(0, 86400), "s",
         "photo: time limit of each COLMAP step");
  d.integer("points", &P::points, Range::closed(1, 100000000), "",
            "surface_samples: number of Poisson-disk samples (ScoreDenoise: 10000 and 50000)");
  d.choice(
      "noise_scale", &P::noise_scale, {"diag", "sphere_radius"},
      "surface_samples: the unit of noise_sigma: diag (bbox diagonal, as every other length) "
      "or sphere_radius (the largest distance of a vertex from the bbox centre: ScoreDenoise's "
      "unit sphere, where 1%, 2%, 3% noise is noise_sigma 0.01, 0.02, 0.03)");
}

namespace detail {

std::vector<Eigen::Vector3d> parse_poses(const std::string& text, const std::string& where) {
  std::vector<Eigen::Vector3d> out;
  std::stringstream all(text);
  std::string item;
  int index = 0;
  while (std::getline(all, item, ';')) {
    ++index;
    std::string cleaned = item;
    for (char& c : cleaned) {
      if (c == ',') c = ' ';
    }
    std::istringstream in(cleaned);
    Eigen::Vector3d v;
    std::string rest;
    if (!(in >> v.x() >> v.y() >> v.z()) || (in >> rest) || !v.allFinite()) {
      throw ParamError(fmt::format("{}.poses: pose {}: expected three finite numbers, got '{}'",
                                   where, index, item));
    }
    out.push_back(v);
  }
  return out;
}

}  // namespace detail

namespace {

using detail::parse_poses;

Json vec_json(const Eigen::Vector3f& v) {
  return Json::array(
      {static_cast<double>(v.x()), static_cast<double>(v.y()), static_cast<double>(v.z())});
}
Json vec_json(const Eigen::Vector3d& v) {
  return Json::array({v.x(), v.y(), v.z()});
}

constexpr double kGoldenAngle = 2.399963229728653;  // pi (3 - sqrt 5)

}  // namespace

// The types of one run (ScannerEngine::Run's fields; outside the anonymous namespace, so that a
// class of the header may hold them).
namespace detail {

constexpr std::size_t kGroupPixels = std::size_t{1} << 21;  // pixels of the views done together

/// What passes A and B learn about one pixel (one byte per pixel).
/// What a pixel returned, and the kind of an output point (kPoint: surface, kFlying, kUniform).
/// An enumeration, not a character type, so stores through it alias nothing else.
enum class Px : std::uint8_t { kMiss, kPoint, kFlying, kGrazing, kOutOfRange, kUniform };

/// Pass A's per-pixel results for a group of views, structure of arrays (pass B reads the ranges
/// of the 4-neighbours). Default-initialised storage: pass A writes `range` and `status` of every
/// pixel, and the other fields of every kPoint pixel, before pass B reads them.
struct GroupImage {
  explicit GroupImage(std::size_t n)
      : range(new float[n]),
        status(new Px[n]),
        position(new Eigen::Vector3f[n]),
        clean(new Eigen::Vector3f[n]),
        outliers(new std::int32_t[n]) {}
  /// Beam range when the beam returned (before drop-outs), else +inf.
  std::unique_ptr<float[]> range;
  std::unique_ptr<Px[]> status;                 ///< kMiss, kPoint, kGrazing or kOutOfRange
  std::unique_ptr<Eigen::Vector3f[]> position;  ///< the noisy surface point (true frame)
  std::unique_ptr<Eigen::Vector3f[]> clean;     ///< the noise-free surface hit
  std::unique_ptr<std::int32_t[]> outliers;     ///< uniform outliers that follow the point
};

struct Counters {
  std::atomic<std::int64_t> misses{0}, grazing{0}, out_of_range{0}, mixed{0}, flying{0}, uniform{0},
      returned{0};
};

}  // namespace detail

void validate(const ScannerParams& p, const std::string& where) {
  schema_of<ScannerParams>().validate(params_to_json(p), where);
  if (!(p.range_max > p.range_min)) {
    throw ParamError(fmt::format("{}.range_max: expected more than range_min = {}, got {}", where,
                                 p.range_min, p.range_max));
  }
  if (p.kind != "range" && p.kind != "photo" && p.kind != "photo_dense" &&
      p.kind != "surface_samples") {
    throw ParamError(fmt::format(
        "{}.kind: expected range, photo, photo_dense or surface_samples, got '{}'", where, p.kind));
  }
  detail::noise_law(p, where);
  if (p.kind == "surface_samples") {
    if (p.noise_direction == "ray" && p.noise_model.empty()) {
      throw ParamError(fmt::format(
          "{}.noise_direction: surface_samples has no rays; expected isotropic or normal", where));
    }
    if (!p.noise_model.empty() && p.noise_model != "normal_gauss") {
      throw ParamError(
          fmt::format("{}.noise_model: surface_samples has no rays; '{}' displaces along them",
                      where, p.noise_model));
    }
    if (p.noise_range_slope != 0.0 || p.noise_incidence_slope != 0.0) {
      throw ParamError(
          fmt::format("{}.{}: surface_samples has no range or incidence; expected 0", where,
                      p.noise_range_slope != 0.0 ? "noise_range_slope" : "noise_incidence_slope"));
    }
  }
  if (p.registration != "known" && p.registration != "mapper") {
    throw ParamError(
        fmt::format("{}.registration: expected known or mapper, got '{}'", where, p.registration));
  }
  if (!p.poses.empty()) {
    const auto poses = parse_poses(p.poses, where);
    if (static_cast<int>(poses.size()) != p.views) {
      throw ParamError(
          fmt::format("{}.poses: {} poses given but views = {}", where, poses.size(), p.views));
    }
  }
}

namespace detail {

ScannerEngine::ScannerEngine(const TriangleMesh& mesh, const ScannerParams& p)
    : mesh_(mesh), p_(p) {
  validate(p_, "scanner");
  mesh.validate("scan");
  degenerate_faces_ = mesh.count_degenerate_faces();
  if (degenerate_faces_ == mesh.num_faces()) {
    throw InputError(fmt::format("scan: all {} triangles of the mesh are degenerate (zero area)",
                                 mesh.num_faces()));
  }
  // The bbox of the referenced vertices only.
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f) {
    for (int k = 0; k < 3; ++k)
      box_.extend(mesh.vertices.col(mesh.faces(k, f)));
  }
  center_ = box_.center();
  diag_ = box_.diagonal();
  sub_rays_ = p_.sub_rays;
  resolution_ = p_.resolution;
  tiles_x_ = (resolution_ + kTile - 1) / kTile;
  tiles_ = tiles_x_ * tiles_x_;

  // Rig.
  std::vector<Eigen::Vector3d> offsets;
  if (p_.poses.empty()) {
    const double dist = p_.range_min + 0.5;
    for (int i = 0; i < p_.views; ++i) {
      const double z = 1.0 - (2.0 * i + 1.0) / p_.views;
      const double rho = std::sqrt(std::max(0.0, 1.0 - z * z));
      const double phi = kGoldenAngle * i;
      offsets.emplace_back(dist * rho * std::cos(phi), dist * rho * std::sin(phi), dist * z);
    }
  } else {
    offsets = parse_poses(p_.poses, "scanner");
  }
  for (std::size_t i = 0; i < offsets.size(); ++i) {
    const double len = offsets[i].norm();
    if (!(len > 1e-6)) {
      throw ParamError(fmt::format("scanner.poses: pose {} is at the bbox centre", i + 1));
    }
    Camera c;
    c.origin = center_ + (offsets[i] * diag_).cast<float>();
    const Eigen::Vector3d fwd = -offsets[i] / len;
    const Eigen::Vector3d up_ref =
        std::abs(fwd.z()) > 0.999 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d right = fwd.cross(up_ref).normalized();
    const Eigen::Vector3d up = right.cross(fwd);
    c.forward = fwd.cast<float>();
    c.right = right.cast<float>();
    c.up = up.cast<float>();
    double fov = p_.fov_deg;
    if (fov == 0.0) {
      // Fit the bounding sphere of the bbox (radius diag/2); 120 deg when inside it.
      const double s = 0.5 / len;
      fov = s < 1.0 ? std::min(120.0, 2.0 * std::asin(s) * 180.0 / M_PI) : 120.0;
    }
    c.fov_deg = static_cast<float>(fov);
    c.tan_half = static_cast<float>(std::tan(0.5 * fov * M_PI / 180.0));
    cameras_.push_back(c);
  }

  // Beam footprint: sub-ray 0 on the axis, the rest on a sunflower spiral over the disk of
  // radius tan(divergence / 2).
  const double b = std::tan(0.5 * p_.beam_divergence_deg * M_PI / 180.0);
  beam_offsets_.assign(static_cast<std::size_t>(sub_rays_), Eigen::Vector2f::Zero());
  for (int k = 1; k < sub_rays_; ++k) {
    const double r = b * std::sqrt(static_cast<double>(k) / (sub_rays_ - 1));
    beam_offsets_[static_cast<std::size_t>(k)] =
        Eigen::Vector2f(static_cast<float>(r * std::cos(kGoldenAngle * k)),
                        static_cast<float>(r * std::sin(kGoldenAngle * k)));
  }

  device_ = std::make_unique<EmbreeDevice>();
  scene_ = std::make_unique<EmbreeScene>(*device_, mesh);
}

std::int64_t ScannerEngine::rays_per_run() const {
  return static_cast<std::int64_t>(cameras_.size()) * resolution_ * resolution_ * sub_rays_;
}

ScannerEngine::Tile ScannerEngine::tile(int t) const {
  const int tx = t % tiles_x_;
  const int ty = t / tiles_x_;
  return {tx * kTile, std::min(resolution_, (tx + 1) * kTile), ty * kTile,
          std::min(resolution_, (ty + 1) * kTile)};
}

namespace {

CameraBasis basis_of(const Camera& c) {
  return {{c.forward.x(), c.forward.y(), c.forward.z()},
          {c.right.x(), c.right.y(), c.right.z()},
          {c.up.x(), c.up.y(), c.up.z()}};
}

/// Embree's ray stream for n rays from the camera: per ray three 16-byte rows (origin and tnear 0;
/// the direction and time 0 of dir_time, ray_directions.h; tfar, every mask bit, id and flags 0)
/// and geomID and instID[0] invalid (the fields the casts read).
void write_rays(const Camera& cam, float tfar, const float* dir_time, std::size_t n,
                RTCRayHit* out) {
  const float org_tnear[4] = {cam.origin.x(), cam.origin.y(), cam.origin.z(), 0.0f};
  const std::uint32_t tail[4] = {std::bit_cast<std::uint32_t>(tfar), ~0u, 0u, 0u};
  constexpr std::uint64_t invalid_ids =
      std::uint64_t{RTC_INVALID_GEOMETRY_ID} | (std::uint64_t{RTC_INVALID_GEOMETRY_ID} << 32);
  for (std::size_t l = 0; l < n; ++l) {
    RTCRayHit& r = out[l];
    std::memcpy(&r.ray.org_x, org_tnear, sizeof org_tnear);
    std::memcpy(&r.ray.dir_x, dir_time + 4 * l, 4 * sizeof(float));
    std::memcpy(&r.ray.tfar, tail, sizeof tail);
    std::memcpy(&r.hit.geomID, &invalid_ids, sizeof invalid_ids);
  }
}

static_assert(offsetof(RTCRay, tnear) == 12 && offsetof(RTCRay, time) == 28 &&
                  offsetof(RTCRay, tfar) == 32 && offsetof(RTCRay, flags) == 44 &&
                  offsetof(RTCHit, instID) == offsetof(RTCHit, geomID) + 4,
              "RTCRayHit layout: org+tnear, dir+time, tfar+mask+id+flags as three 16-byte rows; "
              "geomID and instID[0] adjacent");

/// Image-plane coordinates of pixel centres (tangent-plane units) of an R x R image.
inline float image_x(const Camera& cam, int resolution, int u) {
  const float inv = 2.0f / static_cast<float>(resolution);
  return ((static_cast<float>(u) + 0.5f) * inv - 1.0f) * cam.tan_half;
}
inline float image_y(const Camera& cam, int resolution, int v) {
  const float inv = 2.0f / static_cast<float>(resolution);
  return (1.0f - (static_cast<float>(v) + 0.5f) * inv) * cam.tan_half;
}

}  // namespace

Eigen::Vector3f ScannerEngine::axis_dir(const Camera& cam, int u, int v) const {
  // The kernels of make_tile_rays for sub-ray 0, so the direction is bit-identical to the cast
  // ray's.
  const CameraBasis basis = basis_of(cam);
  const Eigen::Vector2f& o = beam_offsets_[0];
  constexpr std::size_t n = kRayLanePad;
  alignas(64) float xs[n] = {}, oy[n] = {}, ax[n], ay[n], az[n], dir_time[4 * n];
  xs[0] = image_x(cam, resolution_, u) + o.x();
  oy[0] = o.y();
  ray_dirs_x(basis, xs, n, ax, ay, az);
  ray_dirs_y(basis, ax, ay, az, oy, image_y(cam, resolution_, v), n, dir_time);
  return {dir_time[0], dir_time[1], dir_time[2]};
}

void ScannerEngine::make_tile_rays(const Camera& cam, const Tile& t, RTCRayHit* out) const {
  // Runs for every ray. The rays of a tile row are (pixel, sub-ray) pairs in the same order in
  // every row, so the x-dependent half of the directions is computed once per tile; then each
  // row's directions, written into Embree's ray stream.
  const CameraBasis basis = basis_of(cam);
  const float tfar = static_cast<float>(p_.range_max) * diag_;
  const std::size_t n = static_cast<std::size_t>((t.u1 - t.u0) * sub_rays_);
  constexpr std::size_t kRow =
      (static_cast<std::size_t>(kTile * kMaxSubRays) + kRayLanePad - 1) / kRayLanePad * kRayLanePad;
  alignas(64) float xs[kRow], oy[kRow], ax[kRow], ay[kRow], az[kRow], dir_time[4 * kRow];
  std::size_t j = 0;
  for (int u = t.u0; u < t.u1; ++u) {
    const float x = image_x(cam, resolution_, u);
    for (int k = 0; k < sub_rays_; ++k, ++j) {
      const Eigen::Vector2f& o = beam_offsets_[static_cast<std::size_t>(k)];
      xs[j] = x + o.x();
      oy[j] = o.y();
    }
  }
  for (; j % kRayLanePad != 0; ++j) {
    xs[j] = 0.0f;
    oy[j] = 0.0f;
  }
  const std::size_t padded = j;
  ray_dirs_x(basis, xs, padded, ax, ay, az);
  for (int v = t.v0; v < t.v1; ++v) {
    ray_dirs_y(basis, ax, ay, az, oy, image_y(cam, resolution_, v), padded, dir_time);
    write_rays(cam, tfar, dir_time, n, out);
    out += n;
  }
}

std::vector<RTCRayHit> ScannerEngine::make_all_rays() const {
  std::vector<RTCRayHit> rays(static_cast<std::size_t>(rays_per_run()));
  std::size_t offset = 0;
  for (const Camera& cam : cameras_) {
    for (int t = 0; t < tiles_; ++t) {
      const Tile tl = tile(t);
      make_tile_rays(cam, tl, rays.data() + offset);
      offset += static_cast<std::size_t>(tile_ray_count(tl));
    }
  }
  return rays;
}

void ScannerEngine::cast_all(std::vector<RTCRayHit>& rays) const {
  const RayCaster caster(*scene_);
  // Offsets of each (view, tile) chunk, as in the scanner.
  const int chunks = static_cast<int>(cameras_.size()) * tiles_;
  std::vector<std::size_t> start(static_cast<std::size_t>(chunks) + 1, 0);
  for (int c = 0; c < chunks; ++c) {
    start[static_cast<std::size_t>(c) + 1] =
        start[static_cast<std::size_t>(c)] +
        static_cast<std::size_t>(tile_ray_count(tile(c % tiles_)));
  }
  tbb::parallel_for(tbb::blocked_range<int>(0, chunks, 1), [&](const tbb::blocked_range<int>& r) {
    for (int c = r.begin(); c < r.end(); ++c) {
      const std::size_t s = start[static_cast<std::size_t>(c)];
      caster.intersect(rays.data() + s,
                       static_cast<unsigned>(start[static_cast<std::size_t>(c) + 1] - s));
    }
  });
}

/// One run of the scanner: its constants (from the parameters and the mesh), the buffers of a
/// group of views, the output, and the passes that fill them (ScannerEngine::run).
class ScannerEngine::Run {
 public:
  Run(const ScannerEngine& engine, RunContext& ctx);
  /// Passes A, B and C for the views g0 .. g0 + gv - 1.
  void scan_group(int g0, int gv);
  /// The cloud's properties and the scan record (after every group).
  Scan finish();
  /// Views per group.
  int group() const { return group_; }

 private:
  /// Which scans are misaligned: a seeded partial Fisher-Yates shuffle.
  void choose_misaligned();
  /// Pass A for the tiles r of the group: cast every beam, evaluate it, and for returned pixels
  /// draw the range noise and the number of uniform outliers from the tile's stream (pixels in
  /// row-major order).
  void cast_tiles(int g0, const tbb::blocked_range<int>& r, std::vector<RTCRayHit>& buf);
  /// Serial: the output offsets of the group's rows (point counts do not depend on flying
  /// pixels); grows the output by the group's points.
  void place_rows(int rows_g);
  /// Pass B for the rows of the group: flying pixels (they replace the noisy point; no range
  /// noise), then the row's points in pixel order, each followed by its uniform outliers, in the
  /// true frame; per-row sums of surface points (reduced by settle() in fixed order).
  void emit_rows(int g0, const tbb::blocked_range<int>& rows);
  /// Per scan, in fixed row order: centre of mass and misalignment.
  void settle(int g0, int lv);
  /// Pass C: misaligned scans move as a whole (surface and flying points; uniform outliers stay).
  void move_misaligned(int g0, const tbb::blocked_range<int>& rows);
  /// The scan record of view g0 + lv.
  Json scan_record(int g0, int lv) const;

  const ScannerEngine& e_;
  RunContext& ctx_;
  const RayCaster caster_;
  const int R_;
  const std::size_t npix_;
  const int views_;
  float cos_max_ = 0, range_lo_ = 0, range_hi_ = 0, jump_ = 0, spread_ = 0;
  double f_out_ = 0, flying_prob_ = 0;
  BoundingBox obox_;
  int need_ = 0;
  std::uint64_t flying_seed_ = 0, outlier_seed_ = 0, misalign_seed_ = 0, out_threshold_ = 0;
  std::vector<std::uint64_t> view_pixel_seeds_;
  std::vector<char> misaligned_;
  // Noise sigma = a + b r + c (1 / max(cos, 0.01) - 1), in the mesh's units.
  double noise_a_ = 0, noise_b_ = 0, noise_c_ = 0;
  NoiseLaw noise_;

  // Views are processed in groups that share one fork-join per pass (few synchronisation points,
  // bounded memory).
  int group_ = 1;
  std::unique_ptr<GroupImage> image_;
  // Output points per (row, tile column), then the rows' output offsets.
  std::unique_ptr<std::int64_t[]> segment_points_;  // every entry written by pass A
  std::vector<std::int64_t> row_start_;
  std::vector<std::int64_t> row_surface_, row_outliers_;
  std::vector<Eigen::Vector3d> row_sum_;
  tbb::enumerable_thread_specific<std::vector<RTCRayHit>> buffers_;
  Counters counters_;
  // The group's first output point.
  Eigen::Index base_ = 0;
  // Per scan of the group: misalignment and its record.
  std::vector<Eigen::Matrix3d> rots_;
  std::vector<Eigen::Vector3d> transl_, centres_, axes_, shifts_;
  std::vector<std::int64_t> scan_outliers_;

  Scan s_;
  Eigen::VectorXf cx_, cy_, cz_, flag_;
  std::unique_ptr<Px[]> kind_;  // per output point of the group: kPoint, kFlying or kUniform
  std::size_t kind_size_ = 0;
  Eigen::Matrix3Xf origins_;
  Json scans_ = Json::array();
  double t_rays_ = 0, t_artifacts_ = 0;
};

ScannerEngine::Run::Run(const ScannerEngine& engine, RunContext& ctx)
    : e_(engine),
      ctx_(ctx),
      caster_(*engine.scene_),
      R_(engine.resolution_),
      npix_(static_cast<std::size_t>(R_) * static_cast<std::size_t>(R_)),
      views_(static_cast<int>(engine.cameras_.size())),
      buffers_([this] {
        return std::vector<RTCRayHit>(static_cast<std::size_t>(kTile * kTile * e_.sub_rays_));
      }),
      origins_(3, views_) {
  const ScannerParams& p = e_.p_;
  const float diag = e_.diag_;
  cos_max_ = p.max_incidence_deg >= 90.0
                 ? -1.0f
                 : static_cast<float>(std::cos(p.max_incidence_deg * M_PI / 180.0));
  range_lo_ = static_cast<float>(p.range_min) * diag;
  range_hi_ = static_cast<float>(p.range_max) * diag;
  jump_ = static_cast<float>(p.flying_depth_jump) * diag;
  spread_ = static_cast<float>(p.flying_spread) * diag;
  f_out_ = p.outlier_fraction;
  flying_prob_ = p.flying_pixel_prob;
  obox_ = e_.box_.scaled(static_cast<float>(p.outlier_box_scale));
  const float box_min = static_cast<float>(p.outlier_box_min) * diag;
  for (int k = 0; k < 3; ++k) {  // only the sides shorter than the minimum move
    if (obox_.max[k] - obox_.min[k] >= box_min) continue;
    const float c = 0.5f * (obox_.min[k] + obox_.max[k]);
    obox_.min[k] = c - 0.5f * box_min;
    obox_.max[k] = c + 0.5f * box_min;
  }
  need_ = (e_.sub_rays_ + 1) / 2;

  const std::uint64_t pixel_seed = ctx.stream_seed("scan.pixels");
  flying_seed_ = ctx.stream_seed("scan.flying");
  outlier_seed_ = ctx.stream_seed("scan.outliers");
  misalign_seed_ = ctx.stream_seed("scan.misalign");
  view_pixel_seeds_.resize(static_cast<std::size_t>(views_));
  for (int view = 0; view < views_; ++view) {
    view_pixel_seeds_[static_cast<std::size_t>(view)] =
        derive_seed(pixel_seed, static_cast<std::uint64_t>(view));
  }
  // rng.uniform() < f_out  <=>  (rng.next() >> 11) < ceil(f_out 2^53): uniform() is
  // (next() >> 11) 2^-53 exactly, and f_out 2^53 is exact.
  out_threshold_ = static_cast<std::uint64_t>(std::ceil(p.outlier_fraction * 0x1.0p53));
  choose_misaligned();

  group_ = static_cast<int>(
      std::clamp<std::size_t>(kGroupPixels / npix_, 1, static_cast<std::size_t>(views_)));
  const std::size_t group_rows = static_cast<std::size_t>(group_) * static_cast<std::size_t>(R_);
  image_ = std::make_unique<GroupImage>(static_cast<std::size_t>(group_) * npix_);
  segment_points_.reset(new std::int64_t[group_rows * static_cast<std::size_t>(e_.tiles_x_)]);
  row_start_.resize(group_rows + 1);
  row_surface_.resize(group_rows);
  row_outliers_.resize(group_rows);
  row_sum_.resize(group_rows);
  noise_a_ = diag * p.noise_sigma;
  noise_b_ = p.noise_range_slope;
  noise_c_ = diag * p.noise_incidence_slope;
  noise_ = noise_law(p, "scanner");
  s_.cloud.resize(0);
}

void ScannerEngine::Run::choose_misaligned() {
  const int views = views_;
  misaligned_.assign(static_cast<std::size_t>(views), 0);
  const int k = static_cast<int>(std::llround(e_.p_.misalign_fraction * views));
  std::vector<int> order(static_cast<std::size_t>(views));
  std::iota(order.begin(), order.end(), 0);
  Rng rng(misalign_seed_);
  for (int i = 0; i < k; ++i) {
    const int j = i + static_cast<int>(rng.below(static_cast<std::uint64_t>(views - i)));
    std::swap(order[static_cast<std::size_t>(i)], order[static_cast<std::size_t>(j)]);
    misaligned_[static_cast<std::size_t>(order[static_cast<std::size_t>(i)])] = 1;
  }
}

void ScannerEngine::Run::cast_tiles(int g0, const tbb::blocked_range<int>& r,
                                    std::vector<RTCRayHit>& buf) {
  const int R = R_, tiles = e_.tiles_, tiles_x = e_.tiles_x_, need = need_;
  const std::size_t npix = npix_;
  const float cos_max = cos_max_, range_lo = range_lo_, range_hi = range_hi_, jump = jump_;
  const double f_out = f_out_, noise_a = noise_a_, noise_b = noise_b_, noise_c = noise_c_;
  const std::uint64_t out_threshold = out_threshold_;
  const ZigguratNormal& normal = ZigguratNormal::instance();
  const NoiseLaw& noise = noise_;
  const int sub = e_.sub_rays_;
  std::int64_t c_miss = 0, c_grazing = 0, c_range = 0, c_mixed = 0;
  for (int gt = r.begin(); gt < r.end(); ++gt) {
    const int lv = gt / tiles;
    const int view = g0 + lv;
    const int t = gt % tiles;
    const Camera& cam = e_.cameras_[static_cast<std::size_t>(view)];
    const std::size_t base = static_cast<std::size_t>(lv) * npix;
    float* range = image_->range.get() + base;
    Px* status = image_->status.get() + base;
    Eigen::Vector3f* position = image_->position.get() + base;
    Eigen::Vector3f* clean = image_->clean.get() + base;
    std::int32_t* outliers = image_->outliers.get() + base;
    const Tile tl = e_.tile(t);
    e_.make_tile_rays(cam, tl, buf.data());
    caster_.intersect(buf.data(), static_cast<unsigned>(e_.tile_ray_count(tl)));
    // The tile's stream, seeded at its first returned point (most tiles have none).
    std::optional<Rng> tile_rng;
    auto rng = [&]() -> Rng& {
      if (!tile_rng) {
        tile_rng.emplace(derive_seed(view_pixel_seeds_[static_cast<std::size_t>(view)],
                                     static_cast<std::uint64_t>(t)));
      }
      return *tile_rng;
    };
    const RTCRayHit* rh = buf.data();
    for (int v = tl.v0; v < tl.v1; ++v) {
      std::int64_t points = 0;
      for (int u = tl.u0; u < tl.u1; ++u, rh += sub) {
        const std::size_t i = static_cast<std::size_t>(v) * R + u;
        // Hit counts first: the sub-rays of most pixels all hit or all miss.
        int hits = 0;
        for (int k = 0; k < sub; ++k)
          hits += rh[k].hit.geomID != RTC_INVALID_GEOMETRY_ID;
        if (hits < need) {
          c_mixed += hits > 0;  // some but not all sub-rays hit
          range[i] = std::numeric_limits<float>::infinity();
          status[i] = Px::kMiss;
          ++c_miss;
          continue;
        }
        int first = 0;
        if (hits < sub) {
          while (rh[first].hit.geomID == RTC_INVALID_GEOMETRY_ID)
            ++first;
        }
        const RTCRayHit& h = rh[first];
        float raw = h.ray.tfar;
        if (hits > 1) {
          double sum = 0.0;
          float lo = raw, hi = raw;
          for (int k = first; k < sub; ++k) {
            if (hits < sub && rh[k].hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
            const float tk = rh[k].ray.tfar;
            sum += tk;
            lo = std::min(lo, tk);
            hi = std::max(hi, tk);
          }
          raw = static_cast<float>(sum / hits);
          c_mixed += hits < sub || hi - lo > jump;
        } else {
          c_mixed += hits < sub;
        }
        range[i] = raw;
        // Incidence between the ray and the unoriented face normal, without dividing:
        // cos = |n.d| / |n|; grazing when cos < cos_max; 1 / max(cos, 0.01) for the noise.
        const Eigen::Vector3f d(h.ray.dir_x, h.ray.dir_y, h.ray.dir_z);
        const Eigen::Vector3f ng(h.hit.Ng_x, h.hit.Ng_y, h.hit.Ng_z);
        const float len = ng.norm();
        const float dot = std::abs(ng.dot(d));
        if (dot < cos_max * len || (len == 0.0f && cos_max > 0.0f)) {
          status[i] = Px::kGrazing;
          ++c_grazing;
          continue;
        }
        if (raw < range_lo || raw > range_hi) {
          status[i] = Px::kOutOfRange;
          ++c_range;
          continue;
        }
        status[i] = Px::kPoint;
        clean[i] = cam.origin + h.ray.tfar * d;
        const float inv_cos =
            len > 0.0f ? std::max(1.0f, len / std::max(dot, 0.01f * len)) : 100.0f;
        const double sigma = noise_a + noise_b * static_cast<double>(raw) +
                             noise_c * (static_cast<double>(inv_cos) - 1.0);
        float noisy = raw;
        Eigen::Vector3f off_surface = Eigen::Vector3f::Zero();
        if (sigma > 0.0) {
          // Along the ray the noise is a range error; otherwise an offset of the point (none
          // where the face normal is degenerate).
          if (noise.direction == NoiseDirection::kRay) {
            noisy += static_cast<float>(sigma * noise.along(rng(), normal));
          } else if (noise.direction == NoiseDirection::kNormal) {
            if (len > 0.0f) {
              off_surface = static_cast<float>(sigma * noise.along(rng(), normal)) * (ng / len);
            }
          } else {
            off_surface = (sigma * noise.spread(rng(), normal)).cast<float>();
          }
        }
        // Along the beam axis: sub-ray 0.
        const Eigen::Vector3f axis(rh[0].ray.dir_x, rh[0].ray.dir_y, rh[0].ray.dir_z);
        position[i] = cam.origin + noisy * axis;
        if (noise.direction != NoiseDirection::kRay) position[i] += off_surface;
        std::int32_t n_out = 0;
        if (f_out > 0.0) {
          while ((rng().next() >> 11) < out_threshold)  // rng.uniform() < f_out
            ++n_out;
        }
        outliers[i] = n_out;
        points += 1 + n_out;
      }
      segment_points_[(static_cast<std::size_t>(lv) * R + v) * tiles_x + t % tiles_x] = points;
    }
  }
  counters_.misses += c_miss;
  counters_.grazing += c_grazing;
  counters_.out_of_range += c_range;
  counters_.mixed += c_mixed;
}

void ScannerEngine::Run::place_rows(int rows_g) {
  PointCloud& cloud = s_.cloud;
  const int tiles_x = e_.tiles_x_;
  base_ = cloud.size();
  row_start_[0] = 0;
  for (std::size_t gr = 0; gr < static_cast<std::size_t>(rows_g); ++gr) {
    std::int64_t n_row = 0;
    for (int tx = 0; tx < tiles_x; ++tx)
      n_row += segment_points_[gr * tiles_x + tx];
    row_start_[gr + 1] = row_start_[gr] + n_row;
  }
  const Eigen::Index n_group = row_start_[static_cast<std::size_t>(rows_g)];
  const Eigen::Index total = base_ + n_group;
  cloud.positions.conservativeResize(3, total);
  cloud.scan_ids.conservativeResize(total);
  cx_.conservativeResize(total);
  cy_.conservativeResize(total);
  cz_.conservativeResize(total);
  flag_.conservativeResize(total);
  if (static_cast<std::size_t>(n_group) > kind_size_) {
    kind_size_ = static_cast<std::size_t>(n_group);
    kind_.reset(new Px[kind_size_]);
  }
}

void ScannerEngine::Run::emit_rows(int g0, const tbb::blocked_range<int>& rows) {
  const int R = R_;
  const std::size_t npix = npix_;
  const float jump = jump_, spread = spread_;
  const double flying_prob = flying_prob_;
  const BoundingBox& obox = obox_;
  const Eigen::Index base = base_;
  std::int64_t c_flying = 0, c_uniform = 0, c_returned = 0;
  for (int gr = rows.begin(); gr < rows.end(); ++gr) {
    const int lv = gr / R;
    const int v = gr % R;
    const int view = g0 + lv;
    const Camera& cam = e_.cameras_[static_cast<std::size_t>(view)];
    const std::size_t img_base = static_cast<std::size_t>(lv) * npix;
    const float* range = image_->range.get() + img_base;
    const Px* status = image_->status.get() + img_base;
    const Eigen::Vector3f* position = image_->position.get() + img_base;
    const Eigen::Vector3f* clean = image_->clean.get() + img_base;
    const std::int32_t* outliers = image_->outliers.get() + img_base;
    const std::uint64_t view_flying_seed =
        derive_seed(flying_seed_, static_cast<std::uint64_t>(view));
    const std::uint64_t view_outlier_seed =
        derive_seed(outlier_seed_, static_cast<std::uint64_t>(view));
    const Eigen::Index row_first = base + row_start_[static_cast<std::size_t>(gr)];
    Eigen::Index j = row_first;
    std::int64_t surface = 0, n_outliers = 0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    float* out_pos = s_.cloud.positions.data();
    float* out_cx = cx_.data();
    float* out_cy = cy_.data();
    float* out_cz = cz_.data();
    float* out_flag = flag_.data();
    int* out_id = s_.cloud.scan_ids.data();
    Px* out_kind = kind_.get();  // indexed from the group's first point
    const std::int64_t* segments =
        segment_points_.get() + static_cast<std::size_t>(gr) * e_.tiles_x_;
    for (int u = 0; u < R; ++u) {
      if (u % kTile == 0 && segments[u / kTile] == 0) {
        u += kTile - 1;  // no point in this tile's part of the row
        continue;
      }
      const std::size_t i = static_cast<std::size_t>(v) * R + u;
      if (status[i] != Px::kPoint) continue;
      ++c_returned;
      Eigen::Vector3f p = position[i];
      bool flying = false;
      if (flying_prob > 0.0) {
        // The 4-neighbour with the largest range difference; behind a silhouette (no hit)
        // the far end is range + flying_spread.
        const float r0 = range[i];
        float target = r0;
        float best = 0.0f;
        bool edge = false;
        auto look = [&](int nu, int nv) {
          if (nu < 0 || nv < 0 || nu >= R || nv >= R) return;
          const float nr = range[static_cast<std::size_t>(nv) * R + nu];
          float cand;
          if (!std::isfinite(nr)) {
            cand = r0 + spread;
          } else if (std::abs(nr - r0) > jump) {
            cand = nr;
          } else {
            return;
          }
          edge = true;
          if (std::abs(cand - r0) > best) {
            best = std::abs(cand - r0);
            target = cand;
          }
        };
        look(u - 1, v);
        look(u + 1, v);
        look(u, v - 1);
        look(u, v + 1);
        if (edge) {
          Rng frng(derive_seed(view_flying_seed, i));
          if (frng.uniform() < flying_prob) {
            const float depth = r0 + static_cast<float>(frng.uniform()) * (target - r0);
            p = cam.origin + depth * e_.axis_dir(cam, u, v);
            flying = true;
            ++c_flying;
          }
        }
      }
      if (flying) {
        ++n_outliers;
      } else {
        sum += p.cast<double>();
        ++surface;
      }
      out_pos[3 * j] = p.x();
      out_pos[3 * j + 1] = p.y();
      out_pos[3 * j + 2] = p.z();
      out_cx[j] = clean[i].x();
      out_cy[j] = clean[i].y();
      out_cz[j] = clean[i].z();
      out_flag[j] = flying ? 1.0f : 0.0f;
      out_id[j] = view;
      out_kind[j - base] = flying ? Px::kFlying : Px::kPoint;
      ++j;
      const std::int32_t n_out = outliers[i];
      if (n_out == 0) continue;
      n_outliers += n_out;
      c_uniform += n_out;
      Rng orng(derive_seed(view_outlier_seed, i));
      for (int o = 0; o < n_out; ++o, ++j) {
        float q[3];
        for (int k = 0; k < 3; ++k)
          q[k] = static_cast<float>(orng.uniform(obox.min[k], obox.max[k]));
        out_pos[3 * j] = out_cx[j] = q[0];
        out_pos[3 * j + 1] = out_cy[j] = q[1];
        out_pos[3 * j + 2] = out_cz[j] = q[2];
        out_flag[j] = 1.0f;
        out_id[j] = view;
        out_kind[j - base] = Px::kUniform;
      }
    }
    row_surface_[static_cast<std::size_t>(gr)] = surface;
    row_outliers_[static_cast<std::size_t>(gr)] = n_outliers;
    row_sum_[static_cast<std::size_t>(gr)] = sum;
  }
  counters_.flying += c_flying;
  counters_.uniform += c_uniform;
  counters_.returned += c_returned;
}

void ScannerEngine::Run::settle(int g0, int lv) {
  const int R = R_;
  const auto l = static_cast<std::size_t>(lv);
  const int view = g0 + lv;
  std::int64_t n_surface = 0;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (int v = 0; v < R; ++v) {
    const std::size_t gr = l * R + v;
    n_surface += row_surface_[gr];
    scan_outliers_[l] += row_outliers_[gr];
    centre += row_sum_[gr];
  }
  if (n_surface > 0) centre /= static_cast<double>(n_surface);
  centres_[l] = centre;
  if (misaligned_[static_cast<std::size_t>(view)]) {
    Rng rng(derive_seed(misalign_seed_, static_cast<std::uint64_t>(view)));
    auto random_unit = [&rng] {
      while (true) {
        // One draw per statement (argument evaluation order is unspecified, so a
        // constructor with three draws gave GCC and clang builds different axes); z first
        // keeps the scans of GCC builds as they were.
        const double z = rng.normal();
        const double y = rng.normal();
        const double x = rng.normal();
        const Eigen::Vector3d a(x, y, z);
        const double n = a.norm();
        if (n > 1e-6) return Eigen::Vector3d(a / n);
      }
    };
    axes_[l] = random_unit();
    shifts_[l] = random_unit() * (e_.p_.misalign_shift * e_.diag_);
    rots_[l] = Eigen::AngleAxisd(e_.p_.misalign_deg * M_PI / 180.0, axes_[l]).toRotationMatrix();
    transl_[l] = centre - rots_[l] * centre + shifts_[l];
  }
  const Eigen::Vector3d reg_origin =
      rots_[l] * e_.cameras_[static_cast<std::size_t>(view)].origin.cast<double>() + transl_[l];
  origins_.col(view) = reg_origin.cast<float>();
}

void ScannerEngine::Run::move_misaligned(int g0, const tbb::blocked_range<int>& rows) {
  PointCloud& cloud = s_.cloud;
  const Eigen::Index base = base_;
  for (int gr = rows.begin(); gr < rows.end(); ++gr) {
    const int lv = gr / R_;
    if (!misaligned_[static_cast<std::size_t>(g0 + lv)]) continue;
    const Eigen::Matrix3d& rot = rots_[static_cast<std::size_t>(lv)];
    const Eigen::Vector3d& trans = transl_[static_cast<std::size_t>(lv)];
    const Eigen::Index end = base + row_start_[static_cast<std::size_t>(gr) + 1];
    for (Eigen::Index j = base + row_start_[static_cast<std::size_t>(gr)]; j < end; ++j) {
      if (kind_[static_cast<std::size_t>(j - base)] == Px::kUniform) continue;
      cloud.positions.col(j) = (rot * cloud.positions.col(j).cast<double>() + trans).cast<float>();
    }
  }
}

Json ScannerEngine::Run::scan_record(int g0, int lv) const {
  const auto l = static_cast<std::size_t>(lv);
  const int view = g0 + lv;
  const int R = R_;
  const Camera& cam = e_.cameras_[static_cast<std::size_t>(view)];
  Json scan_rec = Json::object();
  scan_rec["id"] = view;
  scan_rec["sensor_origin"] = vec_json(cam.origin);
  Json mis = Json(nullptr);
  if (misaligned_[static_cast<std::size_t>(view)]) {
    mis = Json::object();
    mis["center"] = vec_json(centres_[l]);
    mis["axis"] = vec_json(axes_[l]);
    mis["angle_deg"] = e_.p_.misalign_deg;
    mis["shift"] = vec_json(shifts_[l]);
    Json rows = Json::array();
    for (int a = 0; a < 3; ++a)
      rows.push_back(Json::array({rots_[l](a, 0), rots_[l](a, 1), rots_[l](a, 2)}));
    mis["rotation"] = rows;
    mis["translation"] = vec_json(transl_[l]);
  }
  scan_rec["registered_origin"] =
      vec_json(Eigen::Vector3d(rots_[l] * cam.origin.cast<double>() + transl_[l]));
  scan_rec["forward"] = vec_json(cam.forward);
  scan_rec["up"] = vec_json(cam.up);
  scan_rec["fov_deg"] = static_cast<double>(cam.fov_deg);
  scan_rec["resolution"] = R;
  scan_rec["points"] = row_start_[static_cast<std::size_t>(lv + 1) * R] -
                       row_start_[static_cast<std::size_t>(lv) * R];
  scan_rec["outliers"] = scan_outliers_[l];
  scan_rec["misaligned"] = misaligned_[static_cast<std::size_t>(view)] != 0;
  scan_rec["misalignment"] = mis;
  return scan_rec;
}

void ScannerEngine::Run::scan_group(int g0, int gv) {
  using Clock = std::chrono::steady_clock;
  const int R = R_;
  const int rows_g = gv * R;
  const auto t0 = Clock::now();
  tbb::parallel_for(tbb::blocked_range<int>(0, gv * e_.tiles_, 1),
                    [&](const tbb::blocked_range<int>& r) { cast_tiles(g0, r, buffers_.local()); });
  const auto t1 = Clock::now();
  t_rays_ += std::chrono::duration<double>(t1 - t0).count();

  place_rows(rows_g);
  rots_.assign(static_cast<std::size_t>(gv), Eigen::Matrix3d::Identity());
  transl_.assign(static_cast<std::size_t>(gv), Eigen::Vector3d::Zero());
  centres_.resize(static_cast<std::size_t>(gv));
  axes_.resize(static_cast<std::size_t>(gv));
  shifts_.resize(static_cast<std::size_t>(gv));
  scan_outliers_.assign(static_cast<std::size_t>(gv), 0);
  std::vector<Json> view_records(static_cast<std::size_t>(gv));
  // Passes B and C per scan (C depends on the scan's centre of mass only), scans in parallel:
  // a thread waiting for the rows of one scan runs other scans' rows.
  tbb::parallel_for(tbb::blocked_range<int>(0, gv, 1), [&](const tbb::blocked_range<int>& vr) {
    for (int lv = vr.begin(); lv < vr.end(); ++lv) {
      const tbb::blocked_range<int> rows(lv * R, (lv + 1) * R, 1);
      tbb::parallel_for(rows, [&](const tbb::blocked_range<int>& rr) { emit_rows(g0, rr); });
      settle(g0, lv);
      if (misaligned_[static_cast<std::size_t>(g0 + lv)]) {
        tbb::parallel_for(rows,
                          [&](const tbb::blocked_range<int>& rr) { move_misaligned(g0, rr); });
      }
      view_records[static_cast<std::size_t>(lv)] = scan_record(g0, lv);
    }
  });
  for (Json& rec : view_records)
    scans_.push_back(std::move(rec));
  t_artifacts_ += std::chrono::duration<double>(Clock::now() - t1).count();
}

Scan ScannerEngine::Run::finish() {
  ctx_.add_phase_time("scan.rays", t_rays_);
  ctx_.add_phase_time("scan.artifacts", t_artifacts_);
  PointCloud& cloud = s_.cloud;
  const Eigen::Index n = cloud.size();
  cloud.sensor_origins = origins_;
  cloud.properties["outlier"] = std::move(flag_);
  cloud.properties["clean_x"] = std::move(cx_);
  cloud.properties["clean_y"] = std::move(cy_);
  cloud.properties["clean_z"] = std::move(cz_);

  Json& rec = s_.record;
  rec = Json::object();
  rec["params"] = params_to_json(e_.p_);
  rec["noise"] = noise_.to_json();
  rec["seed"] = ctx_.seed();
  Json mesh = Json::object();
  mesh["vertices"] = e_.mesh_.num_vertices();
  mesh["faces"] = e_.mesh_.num_faces();
  mesh["degenerate_faces"] = e_.degenerate_faces_;
  mesh["bbox_min"] = vec_json(e_.box_.min);
  mesh["bbox_max"] = vec_json(e_.box_.max);
  mesh["diagonal"] = static_cast<double>(e_.diag_);
  rec["mesh"] = mesh;
  Json counts = Json::object();
  counts["rays"] = e_.rays_per_run();
  counts["pixels"] = static_cast<std::int64_t>(npix_) * views_;
  counts["points"] = static_cast<std::int64_t>(n);
  counts["returned_pixels"] = counters_.returned.load();
  counts["misses"] = counters_.misses.load();
  counts["dropped_grazing"] = counters_.grazing.load();
  counts["dropped_range"] = counters_.out_of_range.load();
  counts["mixed_pixels"] = counters_.mixed.load();
  counts["flying_pixels"] = counters_.flying.load();
  counts["uniform_outliers"] = counters_.uniform.load();
  counts["outliers"] = counters_.flying.load() + counters_.uniform.load();
  rec["counts"] = counts;
  rec["scans"] = std::move(scans_);
  return std::move(s_);
}

Scan ScannerEngine::run(RunContext& ctx) const {
  Run run(*this, ctx);
  const int views = static_cast<int>(cameras_.size());
  auto phase = ctx.phase("scan");
  for (int g0 = 0; g0 < views; g0 += run.group()) {
    ctx.check_cancelled("scan");
    run.scan_group(g0, std::min(run.group(), views - g0));
  }
  return run.finish();
}

}  // namespace detail

Scan scan(const TriangleMesh& mesh, const ScannerParams& p, RunContext& ctx) {
  if (p.kind != "range") {
    validate(p, "scanner");
    Scan s = p.kind == "surface_samples" ? detail::surface_samples_scan(mesh, p, ctx)
                                         : detail::photo_scan(mesh, p, ctx);
    s.cloud.origin = mesh.origin;
    if (!mesh.origin.isZero(0.0)) {
      s.record["origin"] = {mesh.origin.x(), mesh.origin.y(), mesh.origin.z()};
    }
    return s;
  }
  const detail::ScannerEngine engine(mesh, p);
  // The scan happens in the mesh's local frame (core stage_data.h, "Local origin"): a mesh far
  // from the world origin scans exactly as the same mesh at the origin, and the cloud gets its
  // origin (written back into world coordinates by write_scan).
  Scan s = engine.run(ctx);
  s.cloud.origin = mesh.origin;
  if (!mesh.origin.isZero(0.0)) {
    s.record["origin"] = {mesh.origin.x(), mesh.origin.y(), mesh.origin.z()};
  }
  return s;
}

std::filesystem::path sidecar_path(const std::filesystem::path& ply) {
  std::filesystem::path j = ply;
  j += ".json";
  return j;
}

void write_scan(const Scan& s, const std::filesystem::path& ply) {
  namespace fs = std::filesystem;
  // Each file whole (write_file_atomic); the workspace is copied to a temp folder beside its
  // final name and renamed in, so a failed copy leaves neither a part nor a temp behind.
  if (s.workspace) {
    fs::path ws = ply;
    ws += ".colmap";
    fs::path tmp =
        ply.parent_path() / fmt::format(".{}.colmap.tmp.{}", ply.filename().string(), ::getpid());
    std::error_code ec;
    fs::remove_all(tmp, ec);
    fs::copy(s.workspace->path(), tmp, fs::copy_options::recursive, ec);
    if (!ec) fs::remove_all(ws, ec);
    if (!ec) fs::rename(tmp, ws, ec);
    if (ec) {
      std::error_code ignored;
      fs::remove_all(tmp, ignored);
      throw IoError(
          fmt::format("{}: cannot copy the COLMAP workspace: {}", ws.string(), ec.message()));
    }
  }
  write_point_cloud(s.cloud, ply, PlyFormat::BinaryLittleEndian);
  write_file_atomic(sidecar_path(ply), s.record.dump(2) + "\n");
}

}  // namespace scanbench::scanner
