// PLY mapping of meshes, point clouds and Gaussian mixtures (the codec itself is ply.cpp).
#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <optional>
#include <set>

#include "float_precision.h"
#include "io_readers.h"
#include "ply.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"

namespace scanbench {

namespace {

const ply::Element& require_element(const ply::File& f, std::string_view element,
                                    const std::string& name) {
  const ply::Element* e = f.find(element);
  if (e == nullptr) throw IoError(fmt::format("{}: no element '{}'", name, element));
  return *e;
}

const ply::Property& require_scalar(const ply::Element& e, std::string_view prop,
                                    const std::string& name) {
  const ply::Property* p = e.find(prop);
  if (p == nullptr) {
    throw IoError(fmt::format("{}: element {} has no property '{}'", name, e.name, prop));
  }
  if (p->is_list) {
    throw IoError(fmt::format("{}: element {}, property {}: expected a scalar, got a list", name,
                              e.name, prop));
  }
  return *p;
}

// The three scalar properties `names`; every value must be finite as a float.
std::array<const ply::Property*, 3> finite_xyz(const ply::Element& e,
                                               const std::array<const char*, 3>& names,
                                               const std::string& name) {
  std::array<const ply::Property*, 3> ps{};
  for (std::size_t k = 0; k < 3; ++k) {
    const ply::Property& p = require_scalar(e, names[k], name);
    for (std::size_t r = 0; r < e.count; ++r) {
      if (!std::isfinite(static_cast<float>(p.values[r]))) {
        throw IoError(fmt::format("{}: element {}, row {}, property {}: non-finite value {}", name,
                                  e.name, r, p.name, p.values[r]));
      }
    }
    ps[k] = &p;
  }
  return ps;
}

// Fills `out` (3 x rows) from three scalar properties that are not positions (normals).
void read_xyz(const ply::Element& e, const std::array<const char*, 3>& names, Eigen::Matrix3Xf& out,
              const std::string& name) {
  const auto ps = finite_xyz(e, names, name);
  out.resize(3, static_cast<Eigen::Index>(e.count));
  for (int k = 0; k < 3; ++k)
    for (std::size_t r = 0; r < e.count; ++r)
      out(k, static_cast<Eigen::Index>(r)) =
          static_cast<float>(ps[static_cast<std::size_t>(k)]->values[r]);
}

// Positions x, y, z of element `e` in the local frame (float_precision.h); returns the origin.
Eigen::Vector3d read_positions(const ply::Element& e, Eigen::Matrix3Xf& out,
                               const std::string& name,
                               const std::optional<Eigen::Vector3d>& stated) {
  const auto ps = finite_xyz(e, {"x", "y", "z"}, name);
  return io_detail::localize(
      static_cast<Eigen::Index>(e.count),
      [&](int k, Eigen::Index i) {
        return ps[static_cast<std::size_t>(k)]->values[static_cast<std::size_t>(i)];
      },
      out, name, fmt::format("element {}, row", e.name).c_str(), stated);
}

// Present as a complete group (true), absent (false), or partial (error).
bool group_present(const ply::Element& e, std::initializer_list<const char*> names,
                   const std::string& name) {
  std::size_t n = 0;
  for (const char* s : names)
    n += e.find(s) != nullptr ? 1 : 0;
  if (n != 0 && n != names.size()) {
    std::string list;
    for (const char* s : names)
      list += (list.empty() ? "" : ", ") + std::string(s);
    throw IoError(
        fmt::format("{}: element {} has only some of the properties {}", name, e.name, list));
  }
  return n != 0;
}

ply::Property float_prop(std::string name, std::vector<double> values) {
  ply::Property p;
  p.name = std::move(name);
  p.type = ply::Type::Float32;
  p.values = std::move(values);
  return p;
}

template <class Row>
std::vector<double> column(Eigen::Index n, Row row) {
  std::vector<double> v(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i)
    v[static_cast<std::size_t>(i)] = static_cast<double>(row(i));
  return v;
}

void append_xyz(ply::Element& e, const Eigen::Matrix3Xf& m, std::array<const char*, 3> names) {
  for (int k = 0; k < 3; ++k) {
    e.properties.push_back(float_prop(names[static_cast<std::size_t>(k)],
                                      column(m.cols(), [&](Eigen::Index i) { return m(k, i); })));
  }
}

// Positions x, y, z in world coordinates: float32 as stored when the origin is zero (the bytes of
// before local origins), else double origin + local (float32 could not hold them) and the origin
// as a comment (`comment scanbench_origin X Y Z`), which a re-read uses as its local origin.
void append_positions(ply::File& f, ply::Element& e, const Eigen::Matrix3Xf& m,
                      const Eigen::Vector3d& origin, bool add_comment = true) {
  if (origin.isZero(0.0)) {
    append_xyz(e, m, {"x", "y", "z"});
    return;
  }
  if (add_comment) f.comments.push_back(io_detail::origin_comment(origin));
  static constexpr std::array<const char*, 3> kNames{"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    ply::Property p;
    p.name = kNames[static_cast<std::size_t>(k)];
    p.type = ply::Type::Float64;
    p.values =
        column(m.cols(), [&](Eigen::Index i) { return origin[k] + static_cast<double>(m(k, i)); });
    e.properties.push_back(std::move(p));
  }
}

ply::Format to_ply(PlyFormat f) {
  return f == PlyFormat::Ascii ? ply::Format::Ascii : ply::Format::BinaryLittleEndian;
}

void require_ply_extension(const std::filesystem::path& path, const char* what) {
  if (io_detail::lower_extension(path) != ".ply") {
    throw IoError(fmt::format("{}: unsupported {} format '{}' (expected .ply)", path.string(), what,
                              path.extension().string()));
  }
}

}  // namespace

namespace io_detail {

std::optional<Eigen::Vector3d> stated_origin(const std::vector<std::string>& comments,
                                             const std::string& name) {
  static constexpr std::string_view kKey = "scanbench_origin";
  for (const std::string& c : comments) {
    if (c.compare(0, kKey.size(), kKey) != 0) continue;
    Eigen::Vector3d o;
    const char* s = c.c_str() + kKey.size();
    for (int k = 0; k < 3; ++k) {
      char* end = nullptr;
      o[k] = std::strtod(s, &end);
      if (end == s || !std::isfinite(o[k])) {
        throw IoError(fmt::format("{}: comment '{}': expected scanbench_origin X Y Z (finite)",
                                  name, c.substr(0, 80)));
      }
      s = end;
    }
    while (*s == ' ' || *s == '\t' || *s == '\r')
      ++s;
    if (*s != 0) {
      throw IoError(fmt::format("{}: comment '{}': expected scanbench_origin X Y Z (finite)", name,
                                c.substr(0, 80)));
    }
    return o;
  }
  return std::nullopt;
}

std::string origin_comment(const Eigen::Vector3d& o) {
  return fmt::format("scanbench_origin {:.17g} {:.17g} {:.17g}", o.x(), o.y(), o.z());
}

void check_mesh(const TriangleMesh& mesh, const std::string& name) {
  if (mesh.num_faces() == 0) throw IoError(fmt::format("{}: mesh has no faces", name));
  for (Eigen::Index v = 0; v < mesh.num_vertices(); ++v) {
    if (!mesh.vertices.col(v).allFinite()) {
      throw IoError(fmt::format("{}: vertex {} has a non-finite coordinate", name, v));
    }
  }
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f) {
    for (int k = 0; k < 3; ++k) {
      if (mesh.faces(k, f) < 0 || mesh.faces(k, f) >= mesh.num_vertices()) {
        throw IoError(fmt::format("{}: face {} refers to vertex {} of {}", name, f,
                                  mesh.faces(k, f), mesh.num_vertices()));
      }
    }
  }
}

TriangleMesh mesh_from_ply(const ply::File& file, const std::string& name) {
  const ply::Element& ve = require_element(file, "vertex", name);
  TriangleMesh mesh;
  mesh.origin = read_positions(ve, mesh.vertices, name, stated_origin(file.comments, name));
  const ply::Element& fe = require_element(file, "face", name);
  const ply::Property* idx = fe.find("vertex_indices");
  if (idx == nullptr) idx = fe.find("vertex_index");
  if (idx == nullptr || !idx->is_list) {
    throw IoError(fmt::format("{}: element face has no list property vertex_indices", name));
  }
  std::vector<int> tri;
  const double nv = static_cast<double>(ve.count);
  for (std::size_t r = 0; r < fe.count; ++r) {
    const std::size_t b = idx->offsets[r];
    const std::size_t n = idx->offsets[r + 1] - b;
    if (n < 3) {
      throw IoError(fmt::format("{}: element face, row {}: polygon with {} vertices", name, r, n));
    }
    for (std::size_t k = 0; k < n; ++k) {
      const double v = idx->values[b + k];
      if (!(v >= 0 && v < nv) || v != std::trunc(v)) {
        throw IoError(fmt::format("{}: element face, row {}: vertex index {} out of range [0, {})",
                                  name, r, v, ve.count));
      }
    }
    for (std::size_t k = 1; k + 1 < n; ++k) {  // fan
      tri.push_back(static_cast<int>(idx->values[b]));
      tri.push_back(static_cast<int>(idx->values[b + k]));
      tri.push_back(static_cast<int>(idx->values[b + k + 1]));
    }
  }
  mesh.faces =
      Eigen::Map<const Eigen::Matrix3Xi>(tri.data(), 3, static_cast<Eigen::Index>(tri.size() / 3));
  check_mesh(mesh, name);
  return mesh;
}

PointCloud cloud_from_ply(const ply::File& file, const std::string& name) {
  const ply::Element& ve = require_element(file, "vertex", name);
  PointCloud cloud;
  cloud.origin = read_positions(ve, cloud.positions, name, stated_origin(file.comments, name));
  const auto n = static_cast<Eigen::Index>(ve.count);
  if (group_present(ve, {"nx", "ny", "nz"}, name)) {
    read_xyz(ve, {"nx", "ny", "nz"}, cloud.normals, name);
  }
  static const std::set<std::string> known{"x", "y", "z", "nx", "ny", "nz", "weight", "scan_id"};
  for (const ply::Property& p : ve.properties) {
    if (p.is_list) {
      throw IoError(
          fmt::format("{}: element vertex: list property '{}' is not supported", name, p.name));
    }
    if (p.name == "weight") {
      cloud.weights.resize(n);
      for (Eigen::Index i = 0; i < n; ++i)
        cloud.weights[i] = static_cast<float>(p.values[static_cast<std::size_t>(i)]);
    } else if (p.name == "scan_id") {
      cloud.scan_ids.resize(n);
      for (Eigen::Index i = 0; i < n; ++i) {
        const double v = p.values[static_cast<std::size_t>(i)];
        if (!(v >= 0 && v <= std::numeric_limits<int>::max()) || v != std::trunc(v)) {
          throw IoError(
              fmt::format("{}: element vertex, row {}: scan_id {} is not an index", name, i, v));
        }
        cloud.scan_ids[i] = static_cast<int>(v);
      }
    } else if (known.count(p.name) == 0) {
      Eigen::VectorXf& values = cloud.properties[p.name];
      values.resize(n);
      for (Eigen::Index i = 0; i < n; ++i)
        values[i] = static_cast<float>(p.values[static_cast<std::size_t>(i)]);
    }
  }
  if (const ply::Element* se = file.find("sensor")) {
    // In the points' frame; an origin-free file keeps the check of before on the sensors.
    const Eigen::Vector3d o = read_positions(
        *se, cloud.sensor_origins, name,
        cloud.origin.isZero(0.0) ? std::nullopt : std::optional<Eigen::Vector3d>(cloud.origin));
    if (o != cloud.origin) {
      throw IoError(fmt::format(
          "{}: element sensor: positions need a local origin the points do not have", name));
    }
  }
  try {
    cloud.validate(name);
  } catch (const InputError& e) {
    throw IoError(e.what());
  }
  return cloud;
}

GaussianMixture mixture_from_ply(const ply::File& file, const std::string& name) {
  const ply::Element& ce = require_element(file, "component", name);
  const auto k = static_cast<Eigen::Index>(ce.count);
  GaussianMixture m;
  m.resize(k);
  m.origin = read_positions(ce, m.means, name, stated_origin(file.comments, name));
  static constexpr std::array<const char*, 6> cov{"covxx", "covxy", "covxz",
                                                  "covyy", "covyz", "covzz"};
  for (std::size_t c = 0; c < cov.size(); ++c) {
    const ply::Property& p = require_scalar(ce, cov[c], name);
    for (Eigen::Index i = 0; i < k; ++i)
      m.covariances(static_cast<Eigen::Index>(c), i) =
          static_cast<float>(p.values[static_cast<std::size_t>(i)]);
  }
  const ply::Property& w = require_scalar(ce, "weight", name);
  for (Eigen::Index i = 0; i < k; ++i)
    m.weights[i] = static_cast<float>(w.values[static_cast<std::size_t>(i)]);
  if (group_present(ce, {"nx", "ny", "nz", "normal_spread"}, name)) {
    read_xyz(ce, {"nx", "ny", "nz"}, m.normal_axes, name);
    const ply::Property& s = require_scalar(ce, "normal_spread", name);
    m.normal_spreads.resize(k);
    for (Eigen::Index i = 0; i < k; ++i)
      m.normal_spreads[i] = static_cast<float>(s.values[static_cast<std::size_t>(i)]);
  }
  try {
    m.validate(name);
  } catch (const InputError& e) {
    throw IoError(e.what());
  }
  return m;
}

void write_mesh_ply(const TriangleMesh& mesh, const std::filesystem::path& path) {
  mesh.validate(path.string());
  ply::File f;
  f.format = ply::Format::BinaryLittleEndian;
  f.comments.push_back("scanbench mesh");
  ply::Element ve;
  ve.name = "vertex";
  ve.count = static_cast<std::size_t>(mesh.num_vertices());
  append_positions(f, ve, mesh.vertices, mesh.origin);
  ply::Element fe;
  fe.name = "face";
  fe.count = static_cast<std::size_t>(mesh.num_faces());
  ply::Property idx;
  idx.name = "vertex_indices";
  idx.is_list = true;
  idx.count_type = ply::Type::UInt8;
  idx.type = ply::Type::Int32;
  idx.values.reserve(3 * fe.count);
  idx.offsets.reserve(fe.count + 1);
  idx.offsets.push_back(0);
  for (Eigen::Index t = 0; t < mesh.num_faces(); ++t) {
    for (int k = 0; k < 3; ++k)
      idx.values.push_back(mesh.faces(k, t));
    idx.offsets.push_back(idx.values.size());
  }
  fe.properties.push_back(std::move(idx));
  f.elements.push_back(std::move(ve));
  f.elements.push_back(std::move(fe));
  ply::write(f, path);
}

}  // namespace io_detail

PointCloud read_point_cloud(const std::filesystem::path& path) {
  const std::string ext = io_detail::lower_extension(path);
  if (io_detail::is_xyz_extension(ext))
    return io_detail::cloud_from_xyz(io_detail::slurp(path), path.string());
  if (ext == ".off") {
    return io_detail::cloud_from_off(io_detail::parse_off(io_detail::slurp(path), path.string()),
                                     path.string());
  }
  if (ext != ".ply") {
    throw IoError(fmt::format(
        "{}: unsupported point cloud format '{}' (expected .ply, .xyz, .pwn, point-only .off)",
        path.string(), path.extension().string()));
  }
  return io_detail::cloud_from_ply(ply::read(path), path.string());
}

void write_point_cloud(const PointCloud& cloud, const std::filesystem::path& path,
                       PlyFormat format) {
  require_ply_extension(path, "point cloud");
  cloud.validate(path.string());
  static const std::set<std::string> reserved{"x", "y", "z", "nx", "ny", "nz", "weight", "scan_id"};
  ply::File f;
  f.format = to_ply(format);
  f.comments.push_back("scanbench point cloud");
  ply::Element ve;
  ve.name = "vertex";
  ve.count = static_cast<std::size_t>(cloud.size());
  append_positions(f, ve, cloud.positions, cloud.origin);
  if (cloud.has_normals()) append_xyz(ve, cloud.normals, {"nx", "ny", "nz"});
  if (cloud.has_weights()) {
    ve.properties.push_back(float_prop(
        "weight", column(cloud.size(), [&](Eigen::Index i) { return cloud.weights[i]; })));
  }
  if (cloud.has_scan_ids()) {
    ply::Property p;
    p.name = "scan_id";
    p.type = ply::Type::Int32;
    p.values = column(cloud.size(), [&](Eigen::Index i) { return cloud.scan_ids[i]; });
    ve.properties.push_back(std::move(p));
  }
  for (const auto& property : cloud.properties) {
    const std::string& pname = property.first;
    const Eigen::VectorXf& values = property.second;  // not a binding: lambdas capture it
    if (reserved.count(pname) != 0) {
      throw IoError(fmt::format("{}: property name '{}' is reserved", path.string(), pname));
    }
    ve.properties.push_back(
        float_prop(pname, column(cloud.size(), [&](Eigen::Index i) { return values[i]; })));
  }
  f.elements.push_back(std::move(ve));
  if (cloud.sensor_origins.cols() > 0) {
    ply::Element se;
    se.name = "sensor";
    se.count = static_cast<std::size_t>(cloud.sensor_origins.cols());
    append_positions(f, se, cloud.sensor_origins, cloud.origin, false);
    f.elements.push_back(std::move(se));
  }
  ply::write(f, path);
}

namespace io_detail {

CovarianceMesh covariance_mesh_from_ply(const ply::File& file, const std::string& name) {
  const ply::Element& ve = require_element(file, "vertex", name);
  const auto nv = static_cast<Eigen::Index>(ve.count);
  CovarianceMesh m;
  m.resize(nv);
  static constexpr std::array<const char*, 9> props{"x",     "y",     "z",     "covxx", "covxy",
                                                    "covxz", "covyy", "covyz", "covzz"};
  for (std::size_t c = 0; c < props.size(); ++c) {
    const ply::Property& p = require_scalar(ve, props[c], name);
    for (Eigen::Index i = 0; i < nv; ++i) {
      const double v = p.values[static_cast<std::size_t>(i)];
      if (!std::isfinite(v)) {
        throw IoError(fmt::format("{}: element vertex, row {}, property {}: non-finite value {}",
                                  name, i, p.name, v));
      }
      if (c < 3) {
        m.means(static_cast<Eigen::Index>(c), i) = v;
      } else {
        m.covariances(static_cast<Eigen::Index>(c - 3), i) = v;
      }
    }
  }
  // Means are double, but their mean mesh (and every consumer of positions) is float: the same
  // local origin as the other readers.
  {
    Eigen::Matrix3Xf local;
    m.origin = io_detail::localize(
        nv, [&](int k, Eigen::Index i) { return m.means(k, i); }, local, name,
        "element vertex, row", stated_origin(file.comments, name));
    if (!m.origin.isZero(0.0)) m.means.colwise() -= m.origin;
  }
  if (const ply::Element* fe = file.find("face")) {
    const ply::Property* idx = fe->find("vertex_indices");
    if (idx == nullptr) idx = fe->find("vertex_index");
    if (idx == nullptr || !idx->is_list) {
      throw IoError(fmt::format("{}: element face has no list property vertex_indices", name));
    }
    std::vector<int> poly;
    for (std::size_t r = 0; r < fe->count; ++r) {
      poly.clear();
      for (std::size_t k = idx->offsets[r]; k < idx->offsets[r + 1]; ++k) {
        const double v = idx->values[k];
        if (!(v >= 0 && v < static_cast<double>(nv)) || v != std::trunc(v)) {
          throw IoError(fmt::format(
              "{}: element face, row {}: vertex index {} out of range [0, {})", name, r, v, nv));
        }
        poly.push_back(static_cast<int>(v));
      }
      m.faces.add(poly);
    }
  }
  try {
    m.validate(name);
  } catch (const InputError& e) {
    throw IoError(e.what());
  }
  return m;
}

}  // namespace io_detail

CovarianceMesh read_covariance_mesh(const std::filesystem::path& path) {
  require_ply_extension(path, "covariance mesh");
  return io_detail::covariance_mesh_from_ply(ply::read(path), path.string());
}

void write_covariance_mesh(const CovarianceMesh& mesh, const std::filesystem::path& path,
                           PlyFormat format) {
  require_ply_extension(path, "covariance mesh");
  mesh.validate(path.string());
  ply::File f;
  f.format = to_ply(format);
  f.comments.push_back("scanbench covariance mesh");
  if (!mesh.origin.isZero(0.0)) f.comments.push_back(io_detail::origin_comment(mesh.origin));
  ply::Element ve;
  ve.name = "vertex";
  ve.count = static_cast<std::size_t>(mesh.num_vertices());
  static constexpr std::array<const char*, 9> props{"x",     "y",     "z",     "covxx", "covxy",
                                                    "covxz", "covyy", "covyz", "covzz"};
  for (std::size_t c = 0; c < props.size(); ++c) {
    ply::Property p;
    p.name = props[c];
    p.type = ply::Type::Float64;  // the dual map inverts covariances: keep every bit
    p.values = column(mesh.num_vertices(), [&](Eigen::Index i) {
      return c < 3 ? mesh.origin[static_cast<Eigen::Index>(c)] +
                         mesh.means(static_cast<Eigen::Index>(c), i)
                   : mesh.covariances(static_cast<Eigen::Index>(c - 3), i);
    });
    ve.properties.push_back(std::move(p));
  }
  ply::Element fe;
  fe.name = "face";
  fe.count = static_cast<std::size_t>(mesh.num_faces());
  ply::Property idx;
  idx.name = "vertex_indices";
  idx.is_list = true;
  idx.count_type = ply::Type::UInt8;
  idx.type = ply::Type::Int32;
  idx.values.assign(mesh.faces.indices.begin(), mesh.faces.indices.end());
  idx.offsets.assign(mesh.faces.offsets.begin(), mesh.faces.offsets.end());
  fe.properties.push_back(std::move(idx));
  f.elements.push_back(std::move(ve));
  f.elements.push_back(std::move(fe));
  ply::write(f, path);
}

StageData read_stage_file(const std::filesystem::path& path) {
  StageData d;
  const std::string ext = io_detail::lower_extension(path);
  if (io_detail::is_xyz_extension(ext)) {
    d.points = io_detail::cloud_from_xyz(io_detail::slurp(path), path.string());
    return d;
  }
  if (ext == ".off") {
    const io_detail::OffData off = io_detail::parse_off(io_detail::slurp(path), path.string());
    if (off.faces == 0) {
      d.points = io_detail::cloud_from_off(off, path.string());
    } else {
      d.mesh = io_detail::mesh_from_off(off, path.string());
    }
    return d;
  }
  if (ext != ".ply") {
    d.mesh = read_mesh(path);
    return d;
  }
  const ply::File f = ply::read(path);
  const std::string name = path.string();
  const ply::Element* face = f.find("face");
  const ply::Element* vertex = f.find("vertex");
  if (f.find("component") != nullptr) {
    d.mixture = io_detail::mixture_from_ply(f, name);
  } else if (vertex != nullptr && vertex->find("covxx") != nullptr) {
    d.covariance_mesh = io_detail::covariance_mesh_from_ply(f, name);
  } else if (face != nullptr && face->count > 0) {
    d.mesh = io_detail::mesh_from_ply(f, name);
  } else {
    d.points = io_detail::cloud_from_ply(f, name);
  }
  return d;
}

void write_stage_kind(const StageData& data, DataKind kind, const std::filesystem::path& path) {
  switch (kind) {
    case DataKind::Points:
      write_point_cloud(data.points, path);
      return;
    case DataKind::Mixture:
      write_mixture(data.require_mixture(path.string()), path);
      return;
    case DataKind::Mesh:
      write_mesh(data.require_mesh(path.string()), path);
      return;
    case DataKind::CovarianceMesh:
      write_covariance_mesh(data.require_covariance_mesh(path.string()), path);
      return;
  }
}

void write_point_cloud_rgb(const PointCloud& cloud, const std::filesystem::path& path,
                           std::uint8_t gray) {
  require_ply_extension(path, "point cloud");
  cloud.validate(path.string());
  ply::File f;
  f.comments.push_back("scanbench point cloud");
  ply::Element ve;
  ve.name = "vertex";
  ve.count = static_cast<std::size_t>(cloud.size());
  append_xyz(ve, cloud.positions, {"x", "y", "z"});  // local frame: external tools read float32
  if (cloud.has_normals()) append_xyz(ve, cloud.normals, {"nx", "ny", "nz"});
  for (const char* c : {"red", "green", "blue"}) {
    ply::Property p;
    p.name = c;
    p.type = ply::Type::UInt8;
    p.values.assign(ve.count, static_cast<double>(gray));
    ve.properties.push_back(std::move(p));
  }
  f.elements.push_back(std::move(ve));
  ply::write(f, path);
}

GaussianMixture read_mixture(const std::filesystem::path& path) {
  require_ply_extension(path, "mixture");
  return io_detail::mixture_from_ply(ply::read(path), path.string());
}

void write_mixture(const GaussianMixture& mixture, const std::filesystem::path& path,
                   PlyFormat format) {
  require_ply_extension(path, "mixture");
  mixture.validate(path.string());
  ply::File f;
  f.format = to_ply(format);
  f.comments.push_back("scanbench gaussian mixture");
  ply::Element ce;
  ce.name = "component";
  ce.count = static_cast<std::size_t>(mixture.size());
  append_positions(f, ce, mixture.means, mixture.origin);
  static constexpr std::array<const char*, 6> cov{"covxx", "covxy", "covxz",
                                                  "covyy", "covyz", "covzz"};
  for (int c = 0; c < 6; ++c) {
    ce.properties.push_back(float_prop(
        cov[static_cast<std::size_t>(c)],
        column(mixture.size(), [&](Eigen::Index i) { return mixture.covariances(c, i); })));
  }
  ce.properties.push_back(float_prop(
      "weight", column(mixture.size(), [&](Eigen::Index i) { return mixture.weights[i]; })));
  if (mixture.has_normal_axes()) {
    append_xyz(ce, mixture.normal_axes, {"nx", "ny", "nz"});
    ce.properties.push_back(float_prop("normal_spread", column(mixture.size(), [&](Eigen::Index i) {
                                         return mixture.normal_spreads[i];
                                       })));
  }
  f.elements.push_back(std::move(ce));
  ply::write(f, path);
}

}  // namespace scanbench
