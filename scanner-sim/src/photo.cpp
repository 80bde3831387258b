// The photogrammetric scanner: Embree renders, OpenImageIO writes, COLMAP triangulates (photo.h).
#include "photo.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <type_traits>

#include "embree_scene.h"
#include "scanbench/core/closest_point.h"
#include "scanbench/core/colmap.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/files.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/timing.h"
#include "sift_match.h"

namespace scanbench::scanner::detail {

namespace {

namespace fs = std::filesystem;

/// A COLMAP camera: x right, y down, z forward; world to camera p_c = R (p - c).
struct View {
  Eigen::Vector3d centre, right, down, forward;
};

struct Rig {
  std::vector<View> views;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double diag = 0;
};

Rig make_rig(const TriangleMesh& mesh, const ScannerParams& p) {
  Rig rig;
  const BoundingBox box = bounding_box(mesh.vertices);
  rig.centre = 0.5 * (box.min + box.max).cast<double>();
  rig.diag = static_cast<double>((box.max - box.min).norm());
  const double dist = (p.range_min + 0.5) * rig.diag;
  const double pi = std::acos(-1.0);
  std::vector<Eigen::Vector3d> offsets;
  if (!p.poses.empty()) {
    for (const Eigen::Vector3d& o : parse_poses(p.poses, "scanner"))
      offsets.push_back(o * rig.diag);
  } else {
    const double e = p.ring_elevation_deg * pi / 180.0;
    for (int i = 0; i < p.views; ++i) {
      const double a = 2.0 * pi * i / p.views;
      offsets.emplace_back(dist * std::cos(e) * std::cos(a), dist * std::cos(e) * std::sin(a),
                           dist * std::sin(e));
    }
  }
  for (const Eigen::Vector3d& o : offsets) {
    View v;
    v.centre = rig.centre + o;
    v.forward = (-o).normalized();
    // World z up, or world y when looking along z (as the range scanner).
    const Eigen::Vector3d up =
        std::abs(v.forward.z()) > 0.99 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitZ();
    v.right = v.forward.cross(up).normalized();
    v.down = v.forward.cross(v.right);
    rig.views.push_back(v);
  }
  const double w = p.image_width, h = p.image_height;
  double f = 0;
  if (p.fov_deg > 0) {
    f = 0.5 * w / std::tan(0.5 * p.fov_deg * pi / 180.0);
  } else {
    // The bounding sphere about the bbox centre (largest vertex distance), so the object fills
    // the shorter side of the image.
    const double radius = static_cast<double>(
        (mesh.vertices.colwise() - rig.centre.cast<float>()).colwise().norm().maxCoeff());
    const double half = std::asin(std::min(0.999, radius / dist));
    f = 0.5 * std::min(w, h) / std::tan(half);
  }
  rig.fx = rig.fy = f;
  rig.cx = 0.5 * w;
  rig.cy = 0.5 * h;
  return rig;
}

// Value noise on the integer lattice (hash per lattice point, smoothstep trilinear blend).
float lattice(std::int64_t x, std::int64_t y, std::int64_t z) {
  std::uint64_t h = static_cast<std::uint64_t>(x) * 0x9E3779B97F4A7C15ull ^
                    static_cast<std::uint64_t>(y) * 0xC2B2AE3D27D4EB4Full ^
                    static_cast<std::uint64_t>(z) * 0x165667B19E3779F9ull;
  h = derive_seed(h, std::uint64_t{0});
  return static_cast<float>(h >> 40) * 0x1.0p-24f;
}

float value_noise(const Eigen::Vector3d& q) {
  const Eigen::Vector3d f = q.array().floor();
  const Eigen::Vector3d t = q - f;
  const Eigen::Vector3d s = t.array() * t.array() * (3.0 - 2.0 * t.array());
  const auto x = static_cast<std::int64_t>(f.x());
  const auto y = static_cast<std::int64_t>(f.y());
  const auto z = static_cast<std::int64_t>(f.z());
  double v = 0;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    const double wgt =
        (dx ? s.x() : 1 - s.x()) * (dy ? s.y() : 1 - s.y()) * (dz ? s.z() : 1 - s.z());
    v += wgt * lattice(x + dx, y + dy, z + dz);
  }
  return static_cast<float>(v);
}

/// Albedo in [0.05, 0.95]: three octaves of value noise, contrast-stretched.
float albedo(const Eigen::Vector3d& p, double scale) {
  const Eigen::Vector3d q = p / scale;
  const float n = 0.5f * value_noise(q) +
                  0.3f * value_noise(2.03 * q + Eigen::Vector3d(17, 5, 11)) +
                  0.2f * value_noise(4.07 * q + Eigen::Vector3d(3, 29, 7));
  return std::clamp(0.5f + 2.2f * (n - 0.5f), 0.05f, 0.95f);
}

/// One grey image in [0, 1], row-major; 2 x 2 samples per pixel, rows in parallel (each pixel
/// independent: no dependence on the thread count).
std::vector<float> render(const EmbreeScene& scene, const Rig& rig, const View& v,
                          const ScannerParams& p) {
  const int w = p.image_width, h = p.image_height;
  std::vector<float> img(static_cast<std::size_t>(w) * h, 0.0f);
  const RayCaster caster(scene);
  tbb::parallel_for(0, h, [&](int row) {
    std::vector<RTCRayHit> rays(static_cast<std::size_t>(w) * 4);
    for (int u = 0; u < w; ++u) {
      for (int s = 0; s < 4; ++s) {
        const double px = u + 0.25 + 0.5 * (s & 1), py = row + 0.25 + 0.5 * (s >> 1);
        const Eigen::Vector3d d =
            (v.forward + v.right * (px - rig.cx) / rig.fx + v.down * (py - rig.cy) / rig.fy)
                .normalized();
        RTCRayHit& r = rays[static_cast<std::size_t>(4 * u + s)];
        r.ray.org_x = static_cast<float>(v.centre.x());
        r.ray.org_y = static_cast<float>(v.centre.y());
        r.ray.org_z = static_cast<float>(v.centre.z());
        r.ray.dir_x = static_cast<float>(d.x());
        r.ray.dir_y = static_cast<float>(d.y());
        r.ray.dir_z = static_cast<float>(d.z());
        r.ray.tnear = 0.0f;
        r.ray.tfar = std::numeric_limits<float>::infinity();
        r.ray.time = 0.0f;
        r.ray.mask = 0xFFFFFFFFu;
        r.ray.id = 0;
        r.ray.flags = 0;
        r.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      }
    }
    caster.intersect(rays.data(), static_cast<unsigned>(rays.size()));
    for (int u = 0; u < w; ++u) {
      float sum = 0.0f;
      for (int s = 0; s < 4; ++s) {
        const RTCRayHit& r = rays[static_cast<std::size_t>(4 * u + s)];
        if (r.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
        const Eigen::Vector3d d(r.ray.dir_x, r.ray.dir_y, r.ray.dir_z);
        const Eigen::Vector3d n = Eigen::Vector3d(r.hit.Ng_x, r.hit.Ng_y, r.hit.Ng_z).normalized();
        const Eigen::Vector3d x = v.centre + static_cast<double>(r.ray.tfar) * d;
        const double shade = 0.25 + 0.75 * std::abs(n.dot(d));
        sum += static_cast<float>(albedo(x, p.texture_scale * rig.diag) * shade);
      }
      img[static_cast<std::size_t>(row) * w + u] = 0.25f * sum;
    }
  });
  return img;
}

/// Separable Gaussian blur (clamped borders), sigma in pixels.
void blur(std::vector<float>& img, int w, int h, double sigma) {
  const int r = static_cast<int>(std::ceil(3 * sigma));
  std::vector<float> k(static_cast<std::size_t>(2 * r + 1));
  float ksum = 0;
  for (int i = -r; i <= r; ++i)
    ksum += k[static_cast<std::size_t>(i + r)] =
        static_cast<float>(std::exp(-0.5 * i * i / (sigma * sigma)));
  for (float& x : k)
    x /= ksum;
  std::vector<float> tmp(img.size());
  auto at = [&](const std::vector<float>& a, int x, int y) {
    return a[static_cast<std::size_t>(std::clamp(y, 0, h - 1)) * w + std::clamp(x, 0, w - 1)];
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float s = 0;
      for (int i = -r; i <= r; ++i)
        s += k[static_cast<std::size_t>(i + r)] * at(img, x + i, y);
      tmp[static_cast<std::size_t>(y) * w + x] = s;
    }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float s = 0;
      for (int i = -r; i <= r; ++i)
        s += k[static_cast<std::size_t>(i + r)] * at(tmp, x, y + i);
      img[static_cast<std::size_t>(y) * w + x] = s;
    }
}

void write_png(const fs::path& path, const std::vector<float>& img, int w, int h) {
  std::vector<unsigned char> bytes(img.size());
  for (std::size_t i = 0; i < img.size(); ++i)
    bytes[i] = static_cast<unsigned char>(std::lround(std::clamp(img[i], 0.0f, 1.0f) * 255.0f));
  // Encoded in memory (OIIO's IO proxy), written by write_file_atomic: OIIO's PNG writer does
  // not report a failed write to a full disk, write_file_atomic checks each one.
  std::vector<unsigned char> png;
  OIIO::Filesystem::IOVecOutput proxy(png);
  auto out = OIIO::ImageOutput::create("png");
  const OIIO::ImageSpec spec(w, h, 1, OIIO::TypeDesc::UINT8);
  if (!out || !out->set_ioproxy(&proxy) || !out->open(path.string(), spec) ||
      !out->write_image(OIIO::TypeDesc::UINT8, bytes.data()) || !out->close() || png.empty()) {
    throw IoError(fmt::format("{}: cannot encode image: {}", path.string(),
                              out ? out->geterror() : OIIO::geterror()));
  }
  write_file_atomic(path, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// One COLMAP step with its log in ws/logs/<step>/ (stdout.txt, stderr.txt); adds its time to
/// `timings[step]`.
void colmap_step(const std::string& step, std::vector<std::string> args, const fs::path& ws,
                 const ScannerParams& p, RunContext& ctx, Json& timings) {
  const fs::path logs = ws / "logs" / step;
  fs::create_directories(logs);
  args.insert(args.begin(), {"colmap", step});
  const double t0 = wall_seconds();
  programs::run_program(args, logs, p.colmap_timeout_s, "scan: colmap " + step, ctx);
  timings[step + "_s"] = wall_seconds() - t0;
}

/// Unsigned distance of every point to the mesh: Embree point queries (BVH pruning) with the
/// exact point-triangle routine of core.
Eigen::VectorXf surface_distances(const EmbreeScene& scene, const TriangleMesh& mesh,
                                  const Eigen::Matrix3Xf& pts) {
  struct Query {
    const TriangleMesh* mesh;
    Eigen::Vector3d p;
    double best;
  };
  Eigen::VectorXf out(pts.cols());
  tbb::parallel_for(Eigen::Index{0}, pts.cols(), [&](Eigen::Index i) {
    Query q{&mesh, pts.col(i).cast<double>(), std::numeric_limits<double>::infinity()};
    RTCPointQuery pq;
    pq.x = pts(0, i);
    pq.y = pts(1, i);
    pq.z = pts(2, i);
    pq.time = 0.0f;
    pq.radius = std::numeric_limits<float>::infinity();
    RTCPointQueryContext context;
    rtcInitPointQueryContext(&context);
    rtcPointQuery(
        scene.get(), &pq, &context,
        [](RTCPointQueryFunctionArguments* a) -> bool {
          auto* self = static_cast<Query*>(a->userPtr);
          const Eigen::Vector3i f = self->mesh->faces.col(a->primID);
          const auto vtx = [&](int k) { return self->mesh->vertices.col(f[k]).cast<double>(); };
          const double d =
              (closest_point_on_triangle(self->p, vtx(0), vtx(1), vtx(2)) - self->p).norm();
          if (!(d < self->best)) return false;
          self->best = d;
          // Shrink the search sphere (rounded up so the float radius never excludes the best).
          a->query->radius =
              std::nextafter(static_cast<float>(d), std::numeric_limits<float>::max());
          return true;
        },
        &q);
    out[i] = static_cast<float>(q.best);
  });
  return out;
}

/// What `colmap help` prints (its first line names the version, e.g. "COLMAP 3.8 -- ...").
std::string colmap_help(RunContext& ctx) {
  programs::TempDir tmp("scan-colmap-help");
  programs::run_program({"colmap", "help"}, tmp.path(), 60, "scan: colmap help", ctx);
  return read_all(tmp.path() / "stdout.txt") + read_all(tmp.path() / "stderr.txt");
}

/// kind "photo_dense": refused unless COLMAP has CUDA (patch_match_stereo needs it).
void require_cuda(const ScannerParams& p, const std::string& help) {
  if (help.find("without CUDA") != std::string::npos) {
    throw Error(fmt::format(
        "scan: kind {} needs COLMAP's patch_match_stereo, which needs CUDA, and this COLMAP is "
        "built without CUDA ('colmap help'); use kind photo (sparse)",
        p.kind));
  }
  throw Error(
      "scan: kind photo_dense is not supported yet (this COLMAP has CUDA; run "
      "patch_match_stereo and stereo_fusion yourself, then scanbench import colmap)");
}

}  // namespace

namespace {

/// The image file of view i (COLMAP's image name).
std::string view_name(std::size_t i) {
  return fmt::format("view_{:03d}.png", i);
}

/// Renders every view into ws/images/view_NNN.png and writes the known model to ws/known/.
void render_views(const EmbreeScene& scene, const Rig& rig, const ScannerParams& p,
                  const fs::path& ws, RunContext& ctx) {
  fs::create_directories(ws / "images");
  const std::uint64_t noise_seed = ctx.stream_seed("scan.photo_noise");
  colmap::Model known;
  known.cameras.push_back({1,
                           "PINHOLE",
                           static_cast<std::uint64_t>(p.image_width),
                           static_cast<std::uint64_t>(p.image_height),
                           {rig.fx, rig.fy, rig.cx, rig.cy}});
  for (std::size_t i = 0; i < rig.views.size(); ++i) {
    const View& v = rig.views[i];
    std::vector<float> img = render(scene, rig, v, p);
    if (p.image_blur_px > 0) blur(img, p.image_width, p.image_height, p.image_blur_px);
    if (p.image_noise > 0) {
      Rng rng(derive_seed(noise_seed, i));
      for (float& x : img)
        x += static_cast<float>(p.image_noise * rng.normal());
    }
    colmap::Image im;
    im.id = static_cast<std::uint32_t>(i + 1);
    im.camera_id = 1;
    im.name = view_name(i);
    Eigen::Matrix3d r;
    r.row(0) = v.right.transpose();
    r.row(1) = v.down.transpose();
    r.row(2) = v.forward.transpose();
    im.rotation = Eigen::Quaterniond(r).normalized();
    im.translation = -(r * v.centre);
    write_png(ws / "images" / im.name, img, p.image_width, p.image_height);
    known.images.push_back(std::move(im));
  }
  colmap::write_model_text(known, ws / "known");
}

/// registration "mapper": COLMAP's incremental mapper on the verified matches (intrinsics held
/// fixed), then model_aligner with a least-squares similarity (robust_alignment 0: no RANSAC)
/// taking the model's camera centres onto the rendered ones; the aligned model goes to ws/sparse.
void map_and_align(const Rig& rig, const ScannerParams& p, const fs::path& ws,
                   const std::string& seed, RunContext& ctx, Json& timings) {
  const fs::path mapped = ws / "mapped";
  fs::create_directories(mapped);
  colmap_step(
      "mapper",
      {"--random_seed", seed, "--database_path", (ws / "database.db").string(), "--image_path",
       (ws / "images").string(), "--output_path", mapped.string(), "--Mapper.num_threads",
       std::to_string(p.colmap_threads), "--Mapper.ba_refine_focal_length", "0",
       "--Mapper.ba_refine_principal_point", "0", "--Mapper.ba_refine_extra_params", "0"},
      ws, p, ctx, timings);
  // One folder per model (0, 1, ...): the one with the most images (the first on ties).
  fs::path best;
  std::size_t most = 0;
  for (int k = 0; fs::is_directory(mapped / std::to_string(k)); ++k) {
    const std::size_t n = colmap::read_model(mapped / std::to_string(k)).images.size();
    if (n > most) {
      most = n;
      best = mapped / std::to_string(k);
    }
  }
  if (best.empty())
    throw Error(
        "scan: colmap mapper reconstructed nothing (too few matches: check texture_scale and "
        "the views' overlap)");
  const fs::path ref = ws / "reference_centres.txt";
  {
    std::string text;
    for (std::size_t i = 0; i < rig.views.size(); ++i) {
      const Eigen::Vector3d& c = rig.views[i].centre;
      text += fmt::format("{} {:.17g} {:.17g} {:.17g}\n", view_name(i), c.x(), c.y(), c.z());
    }
    write_file_atomic(ref, text);
  }
  fs::create_directories(ws / "sparse");
  colmap_step("model_aligner",
              {"--random_seed", seed, "--input_path", best.string(), "--output_path",
               (ws / "sparse").string(), "--ref_images_path", ref.string(), "--ref_is_gps", "0",
               "--alignment_type", "custom", "--robust_alignment", "0"},
              ws, p, ctx, timings);
}

/// feature_extractor, scanbench's matching (sift_match.h: COLMAP's exhaustive_matcher is not
/// repeatable), matches_importer (COLMAP's geometric verification only), point_triangulator
/// (known poses and intrinsics fixed). Repeatability, measured with COLMAP 3.8 (docs/scanner.md,
/// Determinism): every step repeats bit for bit at 1 and 2 threads, so the scan does.
MatchListStats run_colmap(const Rig& rig, const ScannerParams& p, const fs::path& ws,
                          RunContext& ctx, Json& timings) {
  const std::string db = (ws / "database.db").string();
  const std::string threads = std::to_string(p.colmap_threads);
  const std::string seed = std::to_string(ctx.stream_seed("scan.colmap") % 2147483647u);
  colmap_step("feature_extractor",
              {"--random_seed", seed, "--database_path", db, "--image_path",
               (ws / "images").string(), "--ImageReader.camera_model", "PINHOLE",
               "--ImageReader.single_camera", "1", "--ImageReader.camera_params",
               fmt::format("{:.17g},{:.17g},{:.17g},{:.17g}", rig.fx, rig.fy, rig.cx, rig.cy),
               // One extraction thread: COLMAP 3.8 numbers the images in the order their
               // features are written, which varies with more threads, and point_triangulator
               // needs the known model's ids to be the database's (it aborts otherwise).
               "--SiftExtraction.use_gpu", "0", "--SiftExtraction.num_threads", "1"},
              ws, p, ctx, timings);
  ctx.check_cancelled("scan");
  const double t0 = wall_seconds();
  const fs::path list = ws / "match_list.txt";
  const MatchListStats stats =
      write_match_list(read_database_descriptors(db), SiftMatchOptions{}, list);
  timings["matching_s"] = wall_seconds() - t0;
  // COLMAP 3.8 verifies the listed pairs in order on one thread of its own, whose random stream
  // (RANSAC's samples) is seeded with --random_seed; SiftMatching.num_threads is unused there and
  // pinned to 1 all the same. SiftMatching's verification options are COLMAP's defaults.
  colmap_step(
      "matches_importer",
      {"--random_seed", seed, "--database_path", db, "--match_list_path", list.string(),
       "--match_type", "raw", "--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads", "1"},
      ws, p, ctx, timings);
  if (p.registration == "mapper") {
    map_and_align(rig, p, ws, seed, ctx, timings);
    return stats;
  }
  fs::create_directories(ws / "sparse");
  colmap_step(
      "point_triangulator",
      {"--random_seed", seed, "--database_path", db, "--image_path", (ws / "images").string(),
       "--input_path", (ws / "known").string(), "--output_path", (ws / "sparse").string(),
       "--Mapper.num_threads", threads, "--Mapper.ba_refine_focal_length", "0",
       "--Mapper.ba_refine_principal_point", "0", "--Mapper.ba_refine_extra_params", "0"},
      ws, p, ctx, timings);
  return stats;
}

}  // namespace

Scan photo_scan(const TriangleMesh& mesh, const ScannerParams& p, RunContext& ctx) {
  mesh.validate("scan");
  if (mesh.count_degenerate_faces() == mesh.num_faces())
    throw InputError("scan: every triangle of the mesh is degenerate");
  // The scan repeats for one COLMAP version (docs/scanner.md, Determinism): it goes in the record.
  const std::string help = colmap_help(ctx);
  const std::string version = help.substr(0, std::min(help.find(" --"), help.find('\n')));
  if (p.kind == "photo_dense") require_cuda(p, help);
  const Rig rig = make_rig(mesh, p);
  Scan s;
  s.workspace = std::make_shared<programs::TempDir>("scan-photo");
  const fs::path ws = s.workspace->path();
  EmbreeDevice device;
  const EmbreeScene scene(device, mesh);
  Json timings = Json::object();
  double t0 = wall_seconds();
  render_views(scene, rig, p, ws, ctx);
  timings["render_s"] = wall_seconds() - t0;
  const MatchListStats matched = run_colmap(rig, p, ws, ctx, timings);

  t0 = wall_seconds();
  colmap::Model model = colmap::read_model(ws / "sparse");
  // Sensors in view order: image id i + 1 is view i (render_views).
  std::sort(model.images.begin(), model.images.end(),
            [](const colmap::Image& a, const colmap::Image& b) { return a.id < b.id; });
  const char* step = p.registration == "mapper" ? "mapper" : "point_triangulator";
  if (model.images.size() != rig.views.size())
    throw Error(fmt::format("scan: colmap {} kept {} of {} images", step, model.images.size(),
                            rig.views.size()));
  if (model.points.empty())
    throw Error(
        fmt::format("scan: colmap {} found no 3-D points (too few features or matches: check "
                    "texture_scale and the views' overlap)",
                    step));
  // A fixed point order (COLMAP writes its hash map's order): by id.
  std::sort(model.points.begin(), model.points.end(),
            [](const colmap::Point& a, const colmap::Point& b) { return a.id < b.id; });
  s.cloud = colmap::model_to_cloud(model, "scan: colmap model");
  s.cloud.positions.colwise() += s.cloud.origin.cast<float>();  // the mesh's frame (origin 0 here)
  s.cloud.sensor_origins.colwise() += s.cloud.origin.cast<float>();
  s.cloud.origin.setZero();
  const Eigen::VectorXf dist = surface_distances(scene, mesh, s.cloud.positions);
  s.cloud.properties["surface_distance"] = dist;
  const float threshold = static_cast<float>(p.outlier_threshold * rig.diag);
  s.cloud.properties["outlier"] = (dist.array() > threshold).cast<float>().matrix();
  timings["read_back_s"] = wall_seconds() - t0;

  const auto outliers = static_cast<std::int64_t>(s.cloud.properties["outlier"].sum());
  Json views = Json::array();
  // Registration error: distance of each model camera centre from the rendered one (0 up to
  // rounding with the known poses; with the mapper, after model_aligner's similarity).
  double error_sum = 0, error_max = 0;
  for (std::size_t i = 0; i < rig.views.size(); ++i) {
    const View& v = rig.views[i];
    const double error = (model.images[i].centre() - v.centre).norm();
    error_sum += error;
    error_max = std::max(error_max, error);
    views.push_back({{"id", i},
                     {"sensor_origin", {v.centre.x(), v.centre.y(), v.centre.z()}},
                     {"forward", {v.forward.x(), v.forward.y(), v.forward.z()}},
                     {"image", model.images[i].name},
                     {"centre_error", error}});
  }
  s.record = {{"params", params_to_json(p)},
              {"seed", ctx.seed()},
              {"mesh", {{"vertices", mesh.num_vertices()}, {"faces", mesh.num_faces()}}},
              {"counts", {{"points", s.cloud.size()}, {"outliers", outliers}}},
              {"camera",
               {{"model", "PINHOLE"},
                {"width", p.image_width},
                {"height", p.image_height},
                {"params", {rig.fx, rig.fy, rig.cx, rig.cy}}}},
              {"outlier_threshold_abs", threshold},
              {"colmap_version", version},
              {"colmap_seed", std::to_string(ctx.stream_seed("scan.colmap") % 2147483647u)},
              {"registration",
               {{"mode", p.registration},
                {"centre_error_mean", error_sum / static_cast<double>(rig.views.size())},
                {"centre_error_max", error_max}}},
              {"matching",
               {{"pairs", matched.pairs},
                {"pairs_listed", matched.pairs_listed},
                {"raw_matches", matched.matches}}},
              {"timings", timings},
              {"scans", views}};
  return s;
}

}  // namespace scanbench::scanner::detail
