// COLMAP sparse models (.bin/.txt), fused.ply.vis, and their mapping to a scan (colmap.h).
#include "scanbench/core/colmap.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <type_traits>

#include "colmap_readers.h"
#include "float_precision.h"
#include "io_readers.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "text_lines.h"

namespace scanbench::colmap {

namespace {

namespace fs = std::filesystem;

struct ModelKind {
  const char* name;
  int params;
};
// COLMAP's camera models by model_id (src/base/camera_models.h of COLMAP 3.8).
constexpr std::array<ModelKind, 11> kModels{{{"SIMPLE_PINHOLE", 3},
                                             {"PINHOLE", 4},
                                             {"SIMPLE_RADIAL", 4},
                                             {"RADIAL", 5},
                                             {"OPENCV", 8},
                                             {"OPENCV_FISHEYE", 8},
                                             {"FULL_OPENCV", 12},
                                             {"FOV", 5},
                                             {"SIMPLE_RADIAL_FISHEYE", 4},
                                             {"RADIAL_FISHEYE", 5},
                                             {"THIN_PRISM_FISHEYE", 12}}};

// Bounds-checked little-endian reads of a binary model file (COLMAP writes native x86 order).
class Cursor {
 public:
  Cursor(std::string_view data, const std::string& name) : data_(data), name_(name) {}
  template <class T>
  T get(const std::string& record) {
    if (data_.size() - pos_ < sizeof(T)) fail(record, "unexpected end of file");
    T v;
    std::memcpy(&v, data_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::string cstring(const std::string& record) {
    const std::size_t end = data_.find('\0', pos_);
    if (end == std::string_view::npos) fail(record, "unexpected end of file in the image name");
    std::string s(data_.substr(pos_, end - pos_));
    pos_ = end + 1;
    return s;
  }
  /// A count of records of at least `min_bytes` each; refuses counts the rest of the file cannot
  /// hold (a corrupt count must not allocate).
  std::uint64_t count(const std::string& record, std::size_t min_bytes) {
    const auto n = get<std::uint64_t>(record);
    if (n > (data_.size() - pos_) / min_bytes) {
      fail(record, fmt::format("declares {} entries, the {} bytes left hold at most {}", n,
                               data_.size() - pos_, (data_.size() - pos_) / min_bytes));
    }
    return n;
  }
  std::size_t left() const { return data_.size() - pos_; }
  void expect_end() {
    if (pos_ != data_.size())
      fail("end", fmt::format("{} bytes of trailing data", data_.size() - pos_));
  }
  [[noreturn]] void fail(const std::string& record, const std::string& what) const {
    throw IoError(fmt::format("{}: {}: {}", name_, record, what));
  }

 private:
  std::string_view data_;
  const std::string& name_;
  std::size_t pos_ = 0;
};

void check_finite(double v, const std::string& name, const std::string& record, const char* what) {
  if (!std::isfinite(v)) throw IoError(fmt::format("{}: {}: {} is not finite", name, record, what));
}

Eigen::Quaterniond checked_rotation(double w, double x, double y, double z, const std::string& name,
                                    const std::string& record) {
  for (double v : {w, x, y, z})
    check_finite(v, name, record, "qvec");
  const double n = std::sqrt(w * w + x * x + y * y + z * z);
  if (!(n > 0.5 && n < 2.0)) {
    throw IoError(fmt::format("{}: {}: qvec has norm {} (not a rotation)", name, record, n));
  }
  return Eigen::Quaterniond(w / n, x / n, y / n, z / n);
}

// Raw lines (COLMAP's images.txt pairs an image line with the following line of observations,
// which is empty for an image without any: text_lines.h's Lines would skip it).
class RawLines {
 public:
  explicit RawLines(std::string_view text) : text_(text) {}
  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    const std::size_t end = std::min(text_.find('\n', pos_), text_.size());
    line = text_.substr(pos_, end - pos_);
    pos_ = end + 1;
    ++number_;
    while (!line.empty() && io_detail::space(line.back()))
      line.remove_suffix(1);
    while (!line.empty() && io_detail::space(line.front()))
      line.remove_prefix(1);
    return true;
  }
  std::size_t number() const { return number_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t number_ = 0;
};

// Numbers of one text line, strictly parsed.
template <class T>
T token(io_detail::Tokens& t, const std::string& name, std::size_t line, const char* what) {
  std::string_view tok;
  T v{};
  if (!t.next(tok)) throw IoError(fmt::format("{}: line {}: missing {}", name, line, what));
  if (!io_detail::parse_number(tok, v)) {
    throw IoError(
        fmt::format("{}: line {}: {} '{}' is not a number", name, line, what, tok.substr(0, 40)));
  }
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(v))
      throw IoError(fmt::format("{}: line {}: {} is not finite", name, line, what));
  }
  return v;
}

void check_camera(const Camera& c, const std::string& name, const std::string& record) {
  const int want = camera_model_params(c.model);
  if (want < 0)
    throw IoError(fmt::format("{}: {}: unknown camera model '{}'", name, record, c.model));
  if (c.params.size() != static_cast<std::size_t>(want)) {
    throw IoError(fmt::format("{}: {}: {} has {} parameters, got {}", name, record, c.model, want,
                              c.params.size()));
  }
  if (c.width == 0 || c.height == 0 || c.width > (1u << 20) || c.height > (1u << 20)) {
    throw IoError(
        fmt::format("{}: {}: image size {} x {} out of range", name, record, c.width, c.height));
  }
  for (double p : c.params)
    check_finite(p, name, record, "a camera parameter");
}

/// The records of a binary model file: the count (each record takes at least `record_bytes`),
/// each record read by `read(cursor, index, record)`, nothing left after the last.
template <class T, class F>
std::vector<T> bin_records(std::string_view data, const std::string& name,
                           std::uint64_t record_bytes, F&& read) {
  Cursor c(data, name);
  const std::uint64_t n = c.count("header", record_bytes);
  std::vector<T> out(n);
  for (std::uint64_t i = 0; i < n; ++i)
    read(c, i, out[i]);
  c.expect_end();
  return out;
}

/// The records of a text model file, one a line (comments and blank lines skipped), each parsed
/// by `parse(tokens, line number)`.
template <class T, class F>
std::vector<T> text_records(std::string_view text, F&& parse) {
  io_detail::Lines lines(text);
  std::string_view line;
  std::vector<T> out;
  while (lines.next(line)) {
    io_detail::Tokens t(line);
    out.push_back(parse(t, lines.number()));
  }
  return out;
}

std::string slurp_model_file(const fs::path& dir, const std::string& file) {
  const fs::path p = dir / file;
  if (!fs::exists(p))
    throw IoError(fmt::format("{}: missing (a COLMAP model needs it)", p.string()));
  return io_detail::slurp(p);
}

}  // namespace

Eigen::Vector3d Image::centre() const {
  return -(rotation.toRotationMatrix().transpose() * translation);
}

int camera_model_params(const std::string& model) {
  for (const ModelKind& k : kModels)
    if (model == k.name) return k.params;
  return -1;
}

namespace detail {

std::vector<Camera> parse_cameras_bin(std::string_view data, const std::string& name) {
  return bin_records<Camera>(data, name, 24, [&](Cursor& c, std::uint64_t i, Camera& cam) {
    const std::string rec = fmt::format("camera {}", i);
    cam.id = c.get<std::uint32_t>(rec);
    const auto model_id = c.get<std::int32_t>(rec);
    if (model_id < 0 || model_id >= static_cast<int>(kModels.size()))
      c.fail(rec, fmt::format("unknown camera model id {}", model_id));
    cam.model = kModels[static_cast<std::size_t>(model_id)].name;
    cam.width = c.get<std::uint64_t>(rec);
    cam.height = c.get<std::uint64_t>(rec);
    cam.params.resize(static_cast<std::size_t>(kModels[static_cast<std::size_t>(model_id)].params));
    for (double& p : cam.params)
      p = c.get<double>(rec);
    check_camera(cam, name, rec);
  });
}

std::vector<Camera> parse_cameras_txt(std::string_view text, const std::string& name) {
  return text_records<Camera>(text, [&](io_detail::Tokens& t, std::size_t ln) {
    Camera cam;
    cam.id = token<std::uint32_t>(t, name, ln, "CAMERA_ID");
    std::string_view tok;
    if (!t.next(tok)) throw IoError(fmt::format("{}: line {}: missing MODEL", name, ln));
    cam.model = std::string(tok);
    cam.width = token<std::uint64_t>(t, name, ln, "WIDTH");
    cam.height = token<std::uint64_t>(t, name, ln, "HEIGHT");
    double p = 0.0;
    while (t.next(tok)) {
      if (!io_detail::parse_number(tok, p))
        throw IoError(fmt::format("{}: line {}: parameter '{}' is not a number", name, ln,
                                  tok.substr(0, 40)));
      cam.params.push_back(p);
    }
    check_camera(cam, name, fmt::format("line {}", ln));
    return cam;
  });
}

std::vector<Image> parse_images_bin(std::string_view data, const std::string& name) {
  return bin_records<Image>(
      data, name, 4 + 7 * 8 + 4 + 1 + 8, [&](Cursor& c, std::uint64_t i, Image& im) {
        const std::string rec = fmt::format("image {}", i);
        im.id = c.get<std::uint32_t>(rec);
        std::array<double, 7> pose{};
        for (double& v : pose)
          v = c.get<double>(rec);
        im.rotation = checked_rotation(pose[0], pose[1], pose[2], pose[3], name, rec);
        im.translation = Eigen::Vector3d(pose[4], pose[5], pose[6]);
        for (double v : {pose[4], pose[5], pose[6]})
          check_finite(v, name, rec, "tvec");
        im.camera_id = c.get<std::uint32_t>(rec);
        im.name = c.cstring(rec);
        const std::uint64_t m = c.count(rec, 24);
        im.xy.resize(m);
        im.point3d_ids.resize(m);
        for (std::uint64_t k = 0; k < m; ++k) {
          im.xy[k].x() = c.get<double>(rec);
          im.xy[k].y() = c.get<double>(rec);
          im.point3d_ids[k] = c.get<std::int64_t>(rec);
        }
      });
}

std::vector<Image> parse_images_txt(std::string_view text, const std::string& name) {
  RawLines lines(text);
  std::string_view line;
  std::vector<Image> images;
  while (lines.next(line)) {
    if (line.empty() || line.front() == '#') continue;
    io_detail::Tokens t(line);
    const std::size_t ln = lines.number();
    Image im;
    im.id = token<std::uint32_t>(t, name, ln, "IMAGE_ID");
    std::array<double, 7> pose{};
    static constexpr std::array<const char*, 7> kNames{"QW", "QX", "QY", "QZ", "TX", "TY", "TZ"};
    for (std::size_t k = 0; k < 7; ++k)
      pose[k] = token<double>(t, name, ln, kNames[k]);
    im.rotation =
        checked_rotation(pose[0], pose[1], pose[2], pose[3], name, fmt::format("line {}", ln));
    im.translation = Eigen::Vector3d(pose[4], pose[5], pose[6]);
    im.camera_id = token<std::uint32_t>(t, name, ln, "CAMERA_ID");
    std::string_view tok;
    if (!t.next(tok)) throw IoError(fmt::format("{}: line {}: missing NAME", name, ln));
    im.name = std::string(tok);
    if (t.next(tok)) throw IoError(fmt::format("{}: line {}: extra values after NAME", name, ln));
    if (!lines.next(line)) {
      throw IoError(fmt::format("{}: line {}: image {} has no line of POINTS2D", name, ln, im.id));
    }
    io_detail::Tokens obs(line);
    const std::size_t ol = lines.number();
    while (obs.next(tok)) {
      double x = 0.0;
      if (!io_detail::parse_number(tok, x) || !std::isfinite(x))
        throw IoError(
            fmt::format("{}: line {}: X '{}' is not a finite number", name, ol, tok.substr(0, 40)));
      const auto y = token<double>(obs, name, ol, "Y");
      const auto id = token<std::int64_t>(obs, name, ol, "POINT3D_ID");
      im.xy.emplace_back(x, y);
      im.point3d_ids.push_back(id);
    }
    images.push_back(std::move(im));
  }
  return images;
}

std::vector<Point> parse_points_bin(std::string_view data, const std::string& name) {
  return bin_records<Point>(data, name, 8 + 24 + 3 + 8 + 8,
                            [&](Cursor& c, std::uint64_t i, Point& p) {
                              p.id = c.get<std::uint64_t>(fmt::format("point {}", i));
                              const std::string rec = fmt::format("point {} (id {})", i, p.id);
                              for (int k = 0; k < 3; ++k) {
                                p.xyz[k] = c.get<double>(rec);
                                check_finite(p.xyz[k], name, rec, "xyz");
                              }
                              for (std::uint8_t& v : p.rgb)
                                v = c.get<std::uint8_t>(rec);
                              p.error = c.get<double>(rec);
                              check_finite(p.error, name, rec, "error");
                              const std::uint64_t m = c.count(rec, 8);
                              p.track.resize(m);
                              for (auto& [image, idx] : p.track) {
                                image = c.get<std::uint32_t>(rec);
                                idx = c.get<std::uint32_t>(rec);
                              }
                            });
}

std::vector<Point> parse_points_txt(std::string_view text, const std::string& name) {
  return text_records<Point>(text, [&](io_detail::Tokens& t, std::size_t ln) {
    Point p;
    p.id = token<std::uint64_t>(t, name, ln, "POINT3D_ID");
    for (int k = 0; k < 3; ++k)
      p.xyz[k] = token<double>(t, name, ln, "X/Y/Z");
    for (std::uint8_t& v : p.rgb) {
      const auto c = token<int>(t, name, ln, "R/G/B");
      if (c < 0 || c > 255) throw IoError(fmt::format("{}: line {}: colour {}", name, ln, c));
      v = static_cast<std::uint8_t>(c);
    }
    p.error = token<double>(t, name, ln, "ERROR");
    std::string_view tok;
    while (t.next(tok)) {
      std::uint32_t image = 0;
      if (!io_detail::parse_number(tok, image))
        throw IoError(
            fmt::format("{}: line {}: TRACK image '{}' is not an id", name, ln, tok.substr(0, 40)));
      p.track.emplace_back(image, token<std::uint32_t>(t, name, ln, "TRACK point2D index"));
    }
    return p;
  });
}

std::vector<std::vector<std::uint32_t>> parse_vis(std::string_view data, const std::string& name) {
  Cursor c(data, name);
  const std::uint64_t n = c.count("header", 4);
  std::vector<std::vector<std::uint32_t>> vis(n);
  for (std::uint64_t i = 0; i < n; ++i) {
    const std::string rec = fmt::format("point {}", i);
    const auto m = c.get<std::uint32_t>(rec);
    if (m > c.left() / 4) c.fail(rec, fmt::format("{} images, the file is shorter", m));
    vis[i].resize(m);
    for (std::uint32_t& v : vis[i])
      v = c.get<std::uint32_t>(rec);
  }
  c.expect_end();
  return vis;
}

void check_model(const Model& model, const std::array<std::string, 3>& names) {
  std::set<std::uint32_t> cams;
  for (std::size_t i = 0; i < model.cameras.size(); ++i) {
    if (!cams.insert(model.cameras[i].id).second)
      throw IoError(
          fmt::format("{}: camera {}: duplicate camera id {}", names[0], i, model.cameras[i].id));
  }
  std::map<std::uint32_t, std::size_t> images;
  for (std::size_t i = 0; i < model.images.size(); ++i) {
    const Image& im = model.images[i];
    if (!images.emplace(im.id, i).second)
      throw IoError(fmt::format("{}: image {}: duplicate image id {}", names[1], i, im.id));
    if (cams.count(im.camera_id) == 0)
      throw IoError(fmt::format("{}: image {} (id {}): camera {} is not in {}", names[1], i, im.id,
                                im.camera_id, names[0]));
  }
  std::set<std::uint64_t> ids;
  for (std::size_t i = 0; i < model.points.size(); ++i) {
    const Point& p = model.points[i];
    if (!ids.insert(p.id).second)
      throw IoError(fmt::format("{}: point {}: duplicate point id {}", names[2], i, p.id));
    if (p.track.empty())
      throw IoError(fmt::format("{}: point {} (id {}): empty track", names[2], i, p.id));
    for (const auto& [image, idx] : p.track) {
      const auto it = images.find(image);
      if (it == images.end())
        throw IoError(fmt::format("{}: point {} (id {}): track image {} is not in {}", names[2], i,
                                  p.id, image, names[1]));
      const Image& im = model.images[it->second];
      if (!im.point3d_ids.empty() && idx >= im.point3d_ids.size())
        throw IoError(fmt::format("{}: point {} (id {}): image {} has no point2D {}", names[2], i,
                                  p.id, image, idx));
    }
  }
}

}  // namespace detail

Model read_model(const fs::path& dir) {
  if (!fs::is_directory(dir))
    throw IoError(fmt::format("{}: not a COLMAP model folder", dir.string()));
  const bool bin = fs::exists(dir / "cameras.bin");
  const std::string ext = bin ? ".bin" : ".txt";
  const std::array<std::string, 3> names{(dir / ("cameras" + ext)).string(),
                                         (dir / ("images" + ext)).string(),
                                         (dir / ("points3D" + ext)).string()};
  Model m;
  const std::string cams = slurp_model_file(dir, "cameras" + ext);
  const std::string images = slurp_model_file(dir, "images" + ext);
  const std::string points = slurp_model_file(dir, "points3D" + ext);
  m.cameras =
      bin ? detail::parse_cameras_bin(cams, names[0]) : detail::parse_cameras_txt(cams, names[0]);
  m.images =
      bin ? detail::parse_images_bin(images, names[1]) : detail::parse_images_txt(images, names[1]);
  m.points =
      bin ? detail::parse_points_bin(points, names[2]) : detail::parse_points_txt(points, names[2]);
  detail::check_model(m, names);
  return m;
}

void write_model_text(const Model& model, const fs::path& dir) {
  fs::create_directories(dir);
  auto open = [&](const char* file) {
    std::ofstream out(dir / file);
    if (!out) throw IoError(fmt::format("{}: cannot open for writing", (dir / file).string()));
    return out;
  };
  std::ofstream cams = open("cameras.txt");
  cams << "# Camera list with one line of data per camera:\n"
          "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n";
  for (const Camera& c : model.cameras) {
    cams << fmt::format("{} {} {} {}", c.id, c.model, c.width, c.height);
    for (double p : c.params)
      cams << fmt::format(" {:.17g}", p);
    cams << '\n';
  }
  std::ofstream images = open("images.txt");
  images << "# Image list with two lines of data per image:\n"
            "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
            "#   POINTS2D[] as (X, Y, POINT3D_ID)\n";
  for (const Image& im : model.images) {
    const Eigen::Quaterniond& q = im.rotation;
    const Eigen::Vector3d& t = im.translation;
    images << fmt::format("{} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {} {}\n",
                          im.id, q.w(), q.x(), q.y(), q.z(), t.x(), t.y(), t.z(), im.camera_id,
                          im.name);
    for (std::size_t k = 0; k < im.xy.size(); ++k)
      images << fmt::format("{}{:.17g} {:.17g} {}", k ? " " : "", im.xy[k].x(), im.xy[k].y(),
                            im.point3d_ids[k]);
    images << '\n';
  }
  std::ofstream points = open("points3D.txt");
  points << "# 3D point list with one line of data per point:\n"
            "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n";
  for (const Point& p : model.points) {
    points << fmt::format("{} {:.17g} {:.17g} {:.17g} {} {} {} {:.17g}", p.id, p.xyz.x(), p.xyz.y(),
                          p.xyz.z(), p.rgb[0], p.rgb[1], p.rgb[2], p.error);
    for (const auto& [image, idx] : p.track)
      points << fmt::format(" {} {}", image, idx);
    points << '\n';
  }
  if (!cams || !images || !points)
    throw IoError(fmt::format("{}: writing the COLMAP model failed", dir.string()));
}

namespace {

// Sensors (camera centres, in image file order, relative to `origin`) and the sensor index of
// every image id.
std::map<std::uint32_t, int> add_sensors(const Model& model, PointCloud& cloud) {
  std::map<std::uint32_t, int> index;
  cloud.sensor_origins.resize(3, static_cast<Eigen::Index>(model.images.size()));
  for (std::size_t i = 0; i < model.images.size(); ++i) {
    index[model.images[i].id] = static_cast<int>(i);
    cloud.sensor_origins.col(static_cast<Eigen::Index>(i)) =
        (model.images[i].centre() - cloud.origin).cast<float>();
  }
  return index;
}

}  // namespace

PointCloud model_to_cloud(const Model& model, const std::string& name) {
  if (model.points.empty()) throw IoError(fmt::format("{}: the model has no 3-D points", name));
  const auto n = static_cast<Eigen::Index>(model.points.size());
  PointCloud cloud;
  cloud.origin = io_detail::localize(
      n, [&](int k, Eigen::Index i) { return model.points[static_cast<std::size_t>(i)].xyz[k]; },
      cloud.positions, name, "point");
  const std::map<std::uint32_t, int> sensor = add_sensors(model, cloud);
  cloud.scan_ids.resize(n);
  Eigen::VectorXf& track = cloud.properties["track_length"];
  Eigen::VectorXf& error = cloud.properties["reprojection_error"];
  track.resize(n);
  error.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Point& p = model.points[static_cast<std::size_t>(i)];
    std::uint32_t first = std::numeric_limits<std::uint32_t>::max();
    for (const auto& obs : p.track)
      first = std::min(first, obs.first);
    cloud.scan_ids[i] = sensor.at(first);
    track[i] = static_cast<float>(p.track.size());
    error[i] = static_cast<float>(p.error);
  }
  cloud.validate(name);
  return cloud;
}

PointCloud read_fused(const fs::path& fused, const Model& model) {
  PointCloud cloud = read_point_cloud(fused);
  const fs::path vis_path = fused.string() + ".vis";
  if (!fs::exists(vis_path))
    throw IoError(fmt::format("{}: missing (the visibility of {})", vis_path.string(),
                              fused.filename().string()));
  const auto vis = detail::parse_vis(io_detail::slurp(vis_path), vis_path.string());
  if (vis.size() != static_cast<std::size_t>(cloud.size()))
    throw IoError(fmt::format("{}: {} points, {} has {}", vis_path.string(), vis.size(),
                              fused.filename().string(), cloud.size()));
  add_sensors(model, cloud);
  cloud.scan_ids.resize(cloud.size());
  Eigen::VectorXf& track = cloud.properties["track_length"];
  track.resize(cloud.size());
  for (std::size_t i = 0; i < vis.size(); ++i) {
    if (vis[i].empty())
      throw IoError(fmt::format("{}: point {}: seen by no image", vis_path.string(), i));
    const std::uint32_t first = *std::min_element(vis[i].begin(), vis[i].end());
    if (first >= model.images.size() ||
        *std::max_element(vis[i].begin(), vis[i].end()) >= model.images.size())
      throw IoError(fmt::format("{}: point {}: image index out of range ({} images)",
                                vis_path.string(), i, model.images.size()));
    cloud.scan_ids[static_cast<Eigen::Index>(i)] = static_cast<int>(first);
    track[static_cast<Eigen::Index>(i)] = static_cast<float>(vis[i].size());
  }
  cloud.validate(fused.string());
  return cloud;
}

PointCloud import_dir(const fs::path& dir) {
  if (fs::exists(dir / "fused.ply"))
    return read_fused(dir / "fused.ply", read_model(dir / "sparse"));
  return model_to_cloud(read_model(dir), dir.string());
}

}  // namespace scanbench::colmap
