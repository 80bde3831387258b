#pragma once
// The virtual scanner: turns a ground-truth triangle mesh into a point cloud with the artifacts of
// real range acquisition (after Berger et al. 2013 "A benchmark for surface reconstruction",
// HELIOS++, SCUTSurface). Rays are cast with Embree (an implementation detail of scanner-sim/src).
//
// The rig. `views` range cameras sit around the object at distance range_min + diag/2 from the
// centre of its bounding box (diag = bbox diagonal; Berger et al.: sensors on a sphere of radius
// min_range + half the diagonal). Their directions are a Fibonacci spiral over the sphere
// (z_i = 1 - (2i+1)/views, azimuth i * golden angle: deterministic, nearly uniform), or the
// explicit `poses`. Each camera is a pinhole with `resolution` x `resolution` pixels and a full
// field of view `fov_deg`, looking at the bbox centre (up = world z, or world y when looking
// along z).
//
// One pixel, in this order. Every random number comes from a stream derived from the run seed and
// the view, so no result depends on the thread count: range noise and outlier counts from the
// stream of the pixel's 8 x 8 tile ("scan.pixels"; returned pixels in row-major order within the
// tile), flying-pixel draws and outlier positions from per-pixel streams ("scan.flying",
// "scan.outliers"). Normal deviates use a ziggurat (Marsaglia and Tsang 2000) on those streams.
//  1. Beam: `sub_rays` rays in a cone of full angle `beam_divergence_deg` (sub-ray 0 on the axis,
//     the others on a sunflower spiral over the footprint disk). The pixel returns when at least
//     ceil(sub_rays/2) sub-rays hit; its range is the mean hit distance of those sub-rays, reported
//     along the axis. Sub-rays that straddle a depth discontinuity give mixed pixels between the
//     surfaces (HELIOS++ beam divergence).
//  2. The clean point: the hit of the lowest-numbered sub-ray that hit (on the surface).
//  3. Drop-outs: incidence angle at the clean point (between the ray and the unoriented face
//     normal) above `max_incidence_deg`; range outside [range_min, range_max] (diag). Rays end at
//     range_max. range_min is also the minimum measurable range: with explicit poses nearer than
//     that, lower range_min too.
//  4. Flying pixels: a pixel whose 4-neighbour has no hit (silhouette) or a range differing by more
//     than `flying_depth_jump` becomes, with probability `flying_pixel_prob`, a point on its own
//     ray at a uniform depth between its range and the far neighbour's range (range +
//     `flying_spread` behind a silhouette). Flagged outlier = 1; no range noise.
//  5. Noise of standard deviation sigma per displaced axis, with
//        sigma = diag * (noise_sigma + noise_range_slope * r / diag
//                        + noise_incidence_slope * (1 / max(cos(incidence), 0.01) - 1)),
//     i.e. constant accuracy (HELIOS++) growing linearly with range and with 1/cos(incidence).
//     Papers say "x% noise" without saying which law or where; two parameters state it.
//     `noise_direction`: ray (default; a range error along the beam axis), normal (along the
//     unit face normal at the clean point; none where that normal is degenerate) or isotropic
//     (3-D, each world axis independently). `noise_family`, every one with std sigma per
//     displaced axis (PD-Flow's six, Mao et al. 2022, unknownue/pdflow
//     dataset/scoredenoise/transforms.py at 78c4a67, with the std held equal):
//       gaussian (default) N(0, sigma^2), kurtosis 3;
//       laplace, scale b = sigma / sqrt 2, kurtosis 6;
//       uniform U[-sqrt3 sigma, sqrt3 sigma], kurtosis 1.8;
//       discrete, PD-Flow's AddDiscreteNoise: 60% of the points move one step, 40% stay; along a
//         direction +-sigma/sqrt(0.6) with probability 0.3 each (kurtosis 1/0.6); isotropic one of
//         +-x, +-y, +-z with probability 0.1 each, length sqrt5 sigma (per axis kurtosis 5);
//       anisotropic N(0, sigma^2 3 C / trace C), C = `noise_covariance` (3 x 3, symmetric
//         positive definite, world frame, as PD-Flow's AddCovNoise; mean per-axis variance
//         sigma^2);
//       unidirectional N(0, sigma^2) along world x only (PD-Flow's AddUniDirectional).
//     anisotropic and unidirectional are world-frame 3-D laws: noise_direction must be isotropic.
//     `noise_model` is the older shorthand, kept for configs and records: ray_gauss = (gaussian,
//     ray), normal_gauss = (gaussian, normal), ray_uniform = (uniform, ray) with sigma the
//     amplitude, U[-sigma, sigma] (std sigma / sqrt 3); empty (the default) = the two parameters.
//     One law per scan (recorded as "noise"); the deviates come from the tile's stream in the
//     pixel order of the returned points (isotropic and anisotropic: x, y, z in turn).
//  6. Uniform outliers: after each returned point, further points uniform in the bbox grown by
//     `outlier_box_scale` about its centre (Berger et al.: 1.1), each side then widened about the
//     centre to at least `outlier_box_min` * diag (room off a flat model's plane), follow with
//     probability `outlier_fraction` each (a geometric run), so every output point is independently a uniform
//     outlier with probability outlier_fraction (flying pixels aside). Flagged outlier = 1.
// Then per scan, for round(misalign_fraction * views) scans chosen at random (SCUTSurface: 50%):
//  7. Misalignment (registration error, Berger et al.): rotation by `misalign_deg` about a random
//     axis through the centre of mass of the scan's non-outlier points, then a shift of length
//     misalign_shift * diag in a random direction: p' = R p + t with t = c - R c + s. Applied to
//     the scan's surface and flying points and to its sensor origin (the scan is registered
//     wrongly as a whole); not to uniform outliers nor to the clean points.
//
// Output order is fixed: by view, then pixel (row-major), then the pixel's point before its
// uniform outliers.
//
// The photogrammetric scanner (kind = "photo", presets photo_*; photo.cpp). Instead of ranges it
// renders `views` grey images of `image_width` x `image_height` pixels with Embree (pinhole
// cameras at range_min + diag/2 from the bbox centre, on a ring at `ring_elevation_deg` above the
// horizontal plane, evenly spaced in azimuth, or at the explicit `poses`; all looking at the
// centre with world z up; full horizontal field of view fov_deg, 0 = fit the sphere about the bbox
// centre through the farthest vertex into the shorter side). The albedo is a procedural solid
// texture (value noise of three octaves, feature size `texture_scale` diag, at the surface point:
// any mesh gets features SIFT can find, consistent across views), shaded Lambertian under a light
// at the camera (albedo * (0.25 + 0.75 |cos|)), 2 x 2 samples per pixel, background black; then an
// optional Gaussian blur
// (`image_blur_px`) and Gaussian grey noise (`image_noise`, stream "scan.photo_noise" per view).
// The images go to COLMAP (the real program, on the CPU): feature_extractor (one PINHOLE camera
// with the known intrinsics, one thread); scanbench's exact matching of the SIFT descriptors of
// every image pair (scanner-sim/src/sift_match.h, COLMAP's definitions; hand-written because
// COLMAP 3.8's exhaustive_matcher is not repeatable); matches_importer (COLMAP's geometric
// verification only); and point_triangulator on a text model holding the known poses (intrinsics
// and poses kept fixed; `colmap_threads` threads), or with `registration` = "mapper" COLMAP's
// incremental mapper (intrinsics fixed) and model_aligner (a least-squares similarity taking its
// camera centres onto the rendered ones), so the scan includes the registration error.
// The output is the sparse model as a scan: positions, scan_id (first view seeing the point),
// sensors at the camera centres, "reprojection_error" (px), "track_length", "surface_distance"
// (unsigned distance to the mesh, mesh units) and "outlier" (surface_distance above
// `outlier_threshold` diag). The COLMAP workspace (images/, database.db, known/, sparse/) is kept
// in Scan::workspace and written beside the scan as <ply>.colmap/. COLMAP's random seed is derived
// from the run seed. Repeatable for a given COLMAP version: with COLMAP 3.8 every step repeats bit
// for bit, so the scan does, whatever the run context's and COLMAP's thread counts
// (docs/scanner.md, Determinism). kind = "photo_dense" asks for COLMAP's
// patch_match_stereo, which needs CUDA: refused in one line when `colmap help` says "without CUDA".
//
// Surface samples (kind = "surface_samples"; surface_samples.cpp): the learning literature's test
// sets on any mesh (ScoreDenoise, Luo and Hu 2021, luost26/score-denoise: Poisson-disk samples of
// 10K and 50K points, isotropic Gaussian noise of 1, 2, 3% of the bounding sphere's radius).
// Exactly `points` Poisson-disk samples (Open3D's TriangleMesh::SamplePointsPoissonDisk: Yuksel's
// sample elimination from 5 x points uniform samples; its global engine seeded from stream
// "scan.samples"), each displaced by sigma times the noise law (noise_direction isotropic or
// normal: there are no rays; stream "scan.sample_noise", in sample order). sigma = noise_sigma
// times the bbox diagonal, or with `noise_scale` = sphere_radius times the radius of
// ScoreDenoise's normalize_sphere (centre = bbox centre, radius = the largest vertex distance
// from it), so the noise is the stated share in the unit-sphere frame that convention.scoredenoise
// scores in. No sensor: no sensor origins, no scan ids; "outlier" 0 and "clean_x/y/z" (the sample
// before noise) as for ranges; the record says so and gives the sphere and sigma. The other
// range and photo parameters are ignored; noise_range_slope and noise_incidence_slope must be 0.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include "scanbench/core/params.h"
#include "scanbench/core/point_cloud.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/run_program.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench::scanner {

/// Version of the scan model: bumped whenever the same parameters and seed give different points
/// (random streams, artifact model). Part of the harness's scan cache key, so a resumed
/// experiment never mixes scans of two models. 2: per-tile noise streams, ziggurat normals.
/// 3: photo scans match descriptors exactly in scanbench (not with exhaustive_matcher).
inline constexpr int kScanModelVersion = 3;

/// Every parameter of the virtual scanner. Lengths are fractions of the bbox diagonal ("diag"),
/// angles in degrees. Defaults: a clean scanner (8 views of 256 x 256 pixels, no artifacts).
struct ScannerParams {
  int views = 8;
  int resolution = 256;
  double fov_deg = 0.0;
  std::string poses;
  double range_min = 0.5;
  double range_max = 10.0;
  double noise_sigma = 0.0;
  double noise_range_slope = 0.0;
  double noise_incidence_slope = 0.0;
  std::string noise_family = "gaussian";
  std::string noise_direction = "ray";
  std::string noise_covariance;
  std::string noise_model;
  double max_incidence_deg = 90.0;
  double beam_divergence_deg = 0.0;
  int sub_rays = 1;
  double flying_pixel_prob = 0.0;
  double flying_depth_jump = 0.02;
  double flying_spread = 0.05;
  double misalign_fraction = 1.0;
  double misalign_deg = 0.0;
  double misalign_shift = 0.0;
  double outlier_fraction = 0.0;
  double outlier_box_scale = 1.1;
  double outlier_box_min = 0.0;
  // The photogrammetric scanner (kind "photo"; see above). Ignored by the range scanner.
  std::string kind = "range";
  int image_width = 640;
  int image_height = 480;
  double ring_elevation_deg = 20.0;
  double texture_scale = 0.02;
  double image_noise = 0.0;
  double image_blur_px = 0.0;
  double outlier_threshold = 0.01;
  int colmap_threads = 2;
  std::string registration = "known";
  double colmap_timeout_s = 1800.0;
  // Surface samples (kind "surface_samples"; see above). Ignored by the other kinds.
  int points = 10000;
  std::string noise_scale = "diag";

  static void declare(ParamDeclarer<ScannerParams>& d);
};

/// Checks what the schema cannot: range_max > range_min and the `poses` text (count = views).
/// Throws ParamError("<where>.<key>: ..."). scan() calls it (and the schema's range checks).
void validate(const ScannerParams& p, const std::string& where = "scanner");

/// The output of one scan.
struct Scan {
  /// positions; scan_ids; sensor_origins (one per view, in the scan's registered frame, i.e.
  /// misaligned with it); properties "outlier" (0/1: uniform outliers and flying pixels) and
  /// "clean_x", "clean_y", "clean_z" (the noise-free surface hit in the true frame; for uniform
  /// outliers, which have none, the outlier's own position). A mesh with a local origin (core
  /// stage_data.h) is scanned in its local frame: positions, sensor origins and clean_* are local,
  /// and cloud.origin is the mesh's (recorded as "origin" in the record).
  PointCloud cloud;
  /// {"params", "noise" (the resolved law: family, direction, sigma_is, std_over_sigma,
  ///  unit_covariance for anisotropic), "seed", "mesh", "counts",
  ///  "scans": [{"id", "sensor_origin", "registered_origin",
  ///  "forward", "up", "fov_deg", "resolution", "points", "outliers", "misaligned",
  ///  "misalignment": {"center", "axis", "angle_deg", "shift", "rotation", "translation"}}]};
  /// rotation is row-major 3x3, p_registered = rotation * p + translation (identity for scans
  /// that are not misaligned). Lengths in the mesh's units.
  Json record;
  /// The photogrammetric scanner's COLMAP workspace (a temporary folder, removed with the last
  /// copy of the Scan); empty for the range scanner. write_scan copies it to <ply>.colmap/.
  std::shared_ptr<programs::TempDir> workspace;
};

/// Scans `mesh`. Throws InputError for an empty mesh, non-finite vertices, bad face indices or a
/// mesh whose triangles are all degenerate (single degenerate triangles are legal geometry: they
/// are never hit; their count is recorded), and ParamError for invalid parameters (zero views,
/// range_max <= range_min, malformed poses, an unknown noise family, a noise covariance that is
/// not symmetric positive definite). Random streams: "scan.pixels", "scan.flying",
/// "scan.outliers", "scan.misalign" of ctx (surface samples: "scan.samples",
/// "scan.sample_noise").
Scan scan(const TriangleMesh& mesh, const ScannerParams& p, RunContext& ctx);

/// Writes the cloud as binary PLY (core write_point_cloud; deterministic bytes) and the record as
/// `<ply>.json` (e.g. out.ply.json); a photogrammetric scan's workspace goes to `<ply>.colmap/`
/// (replacing an older one). Throws IoError naming the file.
void write_scan(const Scan& s, const std::filesystem::path& ply);

/// The sidecar path of a scan PLY: "<ply>.json".
std::filesystem::path sidecar_path(const std::filesystem::path& ply);

}  // namespace scanbench::scanner
