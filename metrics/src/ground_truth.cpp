#include "scanbench/metrics/ground_truth.h"

#include <embree3/rtcore.h>
#include <tbb/parallel_for.h>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>

#include "scanbench/core/errors.h"
#include "scanbench/core/kdtree.h"
#include "scanbench/metrics/closest_point.h"
#include "scanbench/metrics/distance_field.h"
#include "scanbench/metrics/surface_sampling.h"
#include "spatial_order.h"

namespace scanbench::metrics {

namespace {

// What bounds a face from below cheaply: a centre c (the centroid), a radius r covering every
// point of the face from c (rounded up), and the unit normal n (0 for slivers whose computed
// normal is unreliable). For a point x of the face, n.(x - c) is 0 up to the normal's rounding
// (|n.(x - c)| <= slack) and |x - c| <= r, so for a query q, with e = q - c, t = n.e and
// w = e - t n: |q - x|^2 >= max(0, |t| - slack)^2 + max(0, |w| - r)^2. For a far query this is
// nearly the exact distance to the face's plane patch, much tighter than |e| - r.
struct FaceBound {
  double cx, cy, cz, nx, ny, nz, r, slack;
};

struct QueryState {
  const std::vector<PreparedTriangle>* triangles;
  const std::vector<FaceBound>* bounds;
  Eigen::Vector3d q;
  double best_d2 = std::numeric_limits<double>::infinity();
  // An upper bound of sqrt(best_d2) (float rounding covered): the Embree search radius.
  float best_r = std::numeric_limits<float>::infinity();
  std::int64_t best_face = -1;
  Eigen::Vector3d best_point = Eigen::Vector3d::Zero();

  void visit(std::int64_t f) {
    // Cheap rejection (FaceBound): a face whose lower bound lies beyond the best distance can
    // neither be the answer nor tie with it. tol covers the rounding of e, t and w.
    const FaceBound& b = (*bounds)[static_cast<std::size_t>(f)];
    const double ex = q.x() - b.cx, ey = q.y() - b.cy, ez = q.z() - b.cz;
    const double t = b.nx * ex + b.ny * ey + b.nz * ez;
    const double wx = ex - t * b.nx, wy = ey - t * b.ny, wz = ez - t * b.nz;
    const double tol = 1e-12 * (std::abs(ex) + std::abs(ey) + std::abs(ez));
    const double along = std::max(0.0, std::abs(t) - b.slack - tol);
    const double across = std::max(0.0, std::sqrt(wx * wx + wy * wy + wz * wz) - b.r - tol);
    const double reach = static_cast<double>(best_r);
    if (along * along + across * across > reach * reach * (1.0 + 1e-9)) return;
    const Eigen::Vector3d p = (*triangles)[static_cast<std::size_t>(f)].closest_point(q);
    const double d2 = (p - q).squaredNorm();
    if (d2 < best_d2 || (d2 == best_d2 && f < best_face)) {
      best_d2 = d2;
      best_face = f;
      best_point = p;
      // float(sqrt) is within half an ulp; the factor lifts it above the true value.
      best_r = static_cast<float>(std::sqrt(best_d2)) * (1.0f + 1e-6f);
    }
  }
};

// The fallback lattice: cells of 1/64 of the diagonal over 1.5 x the bounding box (about 10^5
// nodes). Outside the band a query is at least the band width from the surface, so the nearest
// vertex of its lattice node bounds its distance nearly as tightly as its own nearest vertex
// (measured: within 0.5% on average for the benchmark's far queries) at the cost of one lookup
// instead of a kd-tree search: about 10% less fallback time on the bunny benchmark.
constexpr float kLatticeCell = 1.0f / 64.0f;
constexpr float kLatticeScale = 1.5f;
// Nodes nearer than this many cells to a vertex keep the kd-tree: there the bound from the node
// could be several times the distance (it is off by up to a cell diagonal).
constexpr float kLatticeNearCells = 2.0f;

bool point_query_callback(RTCPointQueryFunctionArguments* args) {
  auto* s = static_cast<QueryState*>(args->userPtr);
  s->visit(static_cast<std::int64_t>(args->primID));
  // Shrink the search sphere to the best distance, rounded up so that ties stay visited.
  if (s->best_r < args->query->radius) {
    args->query->radius = s->best_r;
    return true;
  }
  return false;
}

// Calls f(i, q_i) for every column i of q, in Morton order (spatial_order.h): consecutive
// queries walk the same BVH nodes, about 1.7x faster than input order on the distance
// benchmark. Each TBB block works on a gathered copy of its queries; f may write slot i only,
// so the order changes no result.
template <class F>
void for_each_in_morton_order(const Eigen::Matrix3Xf& q, F&& f) {
  const std::vector<Eigen::Index> order = detail::morton_order(q);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, order.size(), 1024),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      Eigen::Matrix3Xf local(3, static_cast<Eigen::Index>(r.size()));
                      for (std::size_t k = r.begin(); k < r.end(); ++k)
                        local.col(static_cast<Eigen::Index>(k - r.begin())) = q.col(order[k]);
                      for (std::size_t k = r.begin(); k < r.end(); ++k)
                        f(order[k], local.col(static_cast<Eigen::Index>(k - r.begin())));
                    });
}

}  // namespace

struct GroundTruth::Impl {
  TriangleMesh mesh;
  std::vector<PreparedTriangle> triangles;  // double precision, for the point-triangle routine
  Eigen::Matrix3Xf face_normals;
  std::vector<FaceBound> face_bounds;
  BoundingBox bbox;
  float diagonal = 0.0f;
  bool closed = false;
  std::uint64_t seed = 0;
  GroundTruthOptions options;
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  // For contains(): built on first use with RTC_SCENE_FLAG_ROBUST, so that a ray through an edge
  // or a vertex meets the surface (Embree's default traversal may let it slip between the
  // triangles); the closest-point queries keep the faster default scene.
  std::once_flag robust_once;
  RTCScene robust_scene = nullptr;
  std::unique_ptr<KdTree> vertex_tree;

  /// A committed scene of the mesh (one triangle geometry, primID = face index).
  RTCScene build_scene(RTCSceneFlags flags) const {
    RTCScene sc = rtcNewScene(device);
    rtcSetSceneFlags(sc, flags);
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    // Embree allocates (and pads) its own buffers, so the last vertex can be read as 16 bytes.
    auto* vb = static_cast<float*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                3 * sizeof(float), static_cast<size_t>(mesh.num_vertices())));
    auto* ib = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(unsigned), static_cast<size_t>(mesh.num_faces())));
    if (!vb || !ib) {
      rtcReleaseGeometry(geom);
      rtcReleaseScene(sc);
      throw Error("ground truth: Embree buffer allocation failed");
    }
    for (Eigen::Index i = 0; i < mesh.num_vertices(); ++i)
      for (int k = 0; k < 3; ++k)
        vb[3 * i + k] = mesh.vertices(k, i);
    for (Eigen::Index f = 0; f < mesh.num_faces(); ++f)
      for (int k = 0; k < 3; ++k)
        ib[3 * f + k] = static_cast<unsigned>(mesh.faces(k, f));
    rtcCommitGeometry(geom);
    rtcAttachGeometry(sc, geom);
    rtcReleaseGeometry(geom);
    rtcCommitScene(sc);
    if (rtcGetDeviceError(device) != RTC_ERROR_NONE) {
      rtcReleaseScene(sc);
      throw Error("ground truth: Embree scene build failed");
    }
    return sc;
  }

  std::once_flag field_once;
  std::unique_ptr<DistanceField> field;
  // Built with the field: the nearest mesh vertex of every node of a coarse lattice (cell
  // kLatticeCell x diagonal) over the bounding box scaled by kLatticeScale, row-major x, y, z;
  // -1 for nodes within kLatticeNearCells cells of a vertex.
  Eigen::Vector3f lattice_origin = Eigen::Vector3f::Zero();
  float lattice_cell = 0.0f;
  Eigen::Vector3i lattice_dims = Eigen::Vector3i::Zero();
  std::vector<std::int32_t> lattice_vertex;

  // Exact closest point with the Embree search started at `radius`, which must bound the true
  // distance from above (any bound gives the same answer; a tighter one prunes more).
  ClosestPoint query(const Eigen::Vector3f& q, float radius) const;
  // The search radius for a query whose distance to a mesh vertex is `vertex_distance` (an upper
  // bound of the answer); the margin covers float rounding and Embree's box tests.
  float bound(float vertex_distance) const {
    return vertex_distance * (1.0f + 1e-4f) + 1e-6f * diagonal;
  }
  // Exact distance of a query outside the field's band: the same answer as closest_point, with
  // the search radius from the lattice node's vertex (the kd-tree's near the mesh and outside
  // the lattice).
  float fallback_distance(const Eigen::Vector3f& q) const;
  void build_lattice();

  std::mutex samples_mutex;
  std::map<Eigen::Index, std::unique_ptr<PointCloud>> samples;

  ~Impl() {
    if (robust_scene) rtcReleaseScene(robust_scene);
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

GroundTruth::GroundTruth(const TriangleMesh& mesh, std::uint64_t sample_seed,
                         GroundTruthOptions options)
    : impl_(std::make_unique<Impl>()) {
  mesh.validate("ground truth");
  if (!(mesh.area() > 0.0)) throw InputError("ground truth: mesh has zero area");
  if (!(options.field_voxel > 0.0) || !(options.band_voxels >= 2.0f))
    throw ParamError("ground truth: field_voxel must be > 0 and band_voxels >= 2");
  Impl& m = *impl_;
  m.mesh = mesh;
  const Eigen::Matrix3Xd vd = mesh.vertices.cast<double>();
  m.face_normals.resize(3, mesh.num_faces());
  m.face_bounds.resize(static_cast<std::size_t>(mesh.num_faces()));
  m.triangles.resize(static_cast<std::size_t>(mesh.num_faces()));
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f) {
    m.face_normals.col(f) = mesh.face_normal(f);
    const Eigen::Vector3d a = vd.col(mesh.faces(0, f)), b = vd.col(mesh.faces(1, f)),
                          c3 = vd.col(mesh.faces(2, f));
    m.triangles[static_cast<std::size_t>(f)] = PreparedTriangle(a, b, c3);
    const Eigen::Vector3d c = (a + b + c3) / 3.0;
    const double r = std::max({(a - c).norm(), (b - c).norm(), (c3 - c).norm()}) * (1.0 + 1e-12);
    const Eigen::Vector3d e1 = b - a, e2 = c3 - a;
    Eigen::Vector3d n = e1.cross(e2);
    // The computed normal is off by about 1e-16 |e1||e2| / |n| radians: keep it only where that
    // is far below the slack (1e-6 r); slivers fall back to the sphere bound (n = 0).
    n = n.norm() > 1e-6 * e1.norm() * e2.norm() ? Eigen::Vector3d(n.normalized())
                                                : Eigen::Vector3d::Zero();
    m.face_bounds[static_cast<std::size_t>(f)] = {c.x(), c.y(), c.z(), n.x(),
                                                  n.y(), n.z(), r,     1e-6 * r};
  }
  m.bbox = mesh.bbox();
  m.diagonal = m.bbox.diagonal();
  m.closed = mesh.is_closed_and_oriented();
  m.seed = sample_seed;
  m.options = options;
  m.vertex_tree = std::make_unique<KdTree>(m.mesh.vertices);

  m.device = rtcNewDevice(nullptr);
  if (!m.device) throw Error("ground truth: cannot create Embree device");
  m.scene = m.build_scene(RTC_SCENE_FLAG_NONE);
}

GroundTruth::~GroundTruth() = default;

namespace {

/// Crossings of the ray from o along d with the scene, hits at one distance counted once: the
/// triangles around a vertex or an edge the ray passes through give distances a few ulp apart,
/// so the next search starts `merge` beyond a hit (1e-6 of the diagonal and of the distance).
int crossings(RTCScene scene, const Eigen::Vector3f& o, float dz, float merge) {
  int n = 0;
  float tnear = 0.0f;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  for (;;) {
    RTCRayHit rh;
    rh.ray.org_x = o.x();
    rh.ray.org_y = o.y();
    rh.ray.org_z = o.z();
    rh.ray.dir_x = 0.0f;
    rh.ray.dir_y = 0.0f;
    rh.ray.dir_z = dz;
    rh.ray.tnear = tnear;
    rh.ray.tfar = std::numeric_limits<float>::infinity();
    rh.ray.time = 0.0f;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &context, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return n;
    ++n;
    tnear = rh.ray.tfar * (1.0f + 1e-6f) + merge;
  }
}

}  // namespace

std::vector<std::uint8_t> GroundTruth::contains(const Eigen::Matrix3Xf& q) const {
  std::vector<std::uint8_t> inside(static_cast<std::size_t>(q.cols()), 0);
  const float merge = 1e-6f * impl_->diagonal;
  std::call_once(impl_->robust_once,
                 [this] { impl_->robust_scene = impl_->build_scene(RTC_SCENE_FLAG_ROBUST); });
  RTCScene scene = impl_->robust_scene;
  const BoundingBox box = impl_->bbox;
  tbb::parallel_for(
      tbb::blocked_range<Eigen::Index>(0, q.cols(), 1024),
      [&](const tbb::blocked_range<Eigen::Index>& r) {
        for (Eigen::Index i = r.begin(); i < r.end(); ++i) {
          const Eigen::Vector3f p = q.col(i);
          if ((p.array() < box.min.array()).any() || (p.array() > box.max.array()).any()) continue;
          inside[static_cast<std::size_t>(i)] = crossings(scene, p, 1.0f, merge) % 2 == 1 &&
                                                crossings(scene, p, -1.0f, merge) % 2 == 1;
        }
      });
  return inside;
}

const TriangleMesh& GroundTruth::mesh() const {
  return impl_->mesh;
}
float GroundTruth::diagonal() const {
  return impl_->diagonal;
}
BoundingBox GroundTruth::bbox() const {
  return impl_->bbox;
}
bool GroundTruth::closed() const {
  return impl_->closed;
}
std::uint64_t GroundTruth::sample_seed() const {
  return impl_->seed;
}
const GroundTruthOptions& GroundTruth::options() const {
  return impl_->options;
}

ClosestPoint GroundTruth::Impl::query(const Eigen::Vector3f& q, float radius) const {
  QueryState s{&triangles, &face_bounds, q.cast<double>()};
  RTCPointQuery pq;
  pq.x = q.x();
  pq.y = q.y();
  pq.z = q.z();
  pq.time = 0.0f;
  pq.radius = radius;
  RTCPointQueryContext context;
  rtcInitPointQueryContext(&context);
  s.best_r = radius;  // faces beyond the bound are out, as for Embree's box tests
  rtcPointQuery(scene, &pq, &context, point_query_callback, &s);
  if (s.best_face < 0) {
    // Not reached in practice (the bound always holds a face); keep the oracle total anyway.
    s.best_r = std::numeric_limits<float>::infinity();
    for (Eigen::Index f = 0; f < mesh.num_faces(); ++f)
      s.visit(f);
  }
  ClosestPoint r;
  r.point = s.best_point.cast<float>();
  r.distance = static_cast<float>(std::sqrt(s.best_d2));
  r.face = static_cast<std::int32_t>(s.best_face);
  r.normal = face_normals.col(s.best_face);
  return r;
}

ClosestPoint GroundTruth::closest_point(const Eigen::Vector3f& q) const {
  if (!q.allFinite()) throw InputError("ground truth: query point is not finite");
  const Impl& m = *impl_;
  // The nearest vertex lies on the mesh: its distance bounds the answer.
  float vd2 = 0.0f;
  m.vertex_tree->nearest(q, &vd2);
  return m.query(q, m.bound(std::sqrt(vd2)));
}

void GroundTruth::Impl::build_lattice() {
  const BoundingBox box = bbox.scaled(kLatticeScale);
  lattice_cell = kLatticeCell * diagonal;
  lattice_origin = box.min;
  for (int k = 0; k < 3; ++k)
    lattice_dims[k] = static_cast<int>(std::ceil((box.max[k] - box.min[k]) / lattice_cell)) + 1;
  const auto nodes = static_cast<std::size_t>(lattice_dims.cast<std::int64_t>().prod());
  lattice_vertex.assign(nodes, -1);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nodes, 1024),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t n = r.begin(); n < r.end(); ++n) {
                        const auto z = static_cast<int>(n % lattice_dims[2]);
                        const auto y = static_cast<int>(n / lattice_dims[2] % lattice_dims[1]);
                        const auto x = static_cast<int>(n / lattice_dims[2] / lattice_dims[1]);
                        const Eigen::Vector3f p =
                            lattice_origin + lattice_cell * Eigen::Vector3f(x, y, z);
                        float d2 = 0.0f;
                        const Eigen::Index v = vertex_tree->nearest(p, &d2);
                        // Near the mesh the node's vertex is a loose bound: use the kd-tree.
                        const float near = kLatticeNearCells * lattice_cell;
                        lattice_vertex[n] = d2 >= near * near ? static_cast<std::int32_t>(v) : -1;
                      }
                    });
}

float GroundTruth::Impl::fallback_distance(const Eigen::Vector3f& q) const {
  const Eigen::Vector3f c = ((q - lattice_origin) / lattice_cell).array().round();
  if ((c.array() >= 0.0f).all() && (c.array() < lattice_dims.cast<float>().array()).all()) {
    const std::size_t n =
        (static_cast<std::size_t>(c.x()) * lattice_dims[1] + static_cast<std::size_t>(c.y())) *
            lattice_dims[2] +
        static_cast<std::size_t>(c.z());
    if (lattice_vertex[n] >= 0)
      return query(q, bound((q - mesh.vertices.col(lattice_vertex[n])).norm())).distance;
  }
  float vd2 = 0.0f;
  vertex_tree->nearest(q, &vd2);
  return query(q, bound(std::sqrt(vd2))).distance;
}

std::vector<ClosestPoint> GroundTruth::closest_points(const Eigen::Matrix3Xf& q) const {
  std::vector<ClosestPoint> out(static_cast<std::size_t>(q.cols()));
  if (!q.allFinite()) throw InputError("ground truth: a query point is not finite");
  for_each_in_morton_order(q, [&](Eigen::Index i, const auto& qi) {
    out[static_cast<std::size_t>(i)] = closest_point(qi);
  });
  return out;
}

Eigen::VectorXf GroundTruth::distances(const Eigen::Matrix3Xf& q, DistancePath path,
                                       Eigen::Index* fallbacks) const {
  if (!q.allFinite()) throw InputError("ground truth: a query point is not finite");
  Eigen::VectorXf out(q.cols());
  if (path == DistancePath::Exact) {
    for_each_in_morton_order(
        q, [&](Eigen::Index i, const auto& qi) { out[i] = closest_point(qi).distance; });
    if (fallbacks) *fallbacks = 0;
    return out;
  }
  // The field answers the queries inside its band; the rest take the exact path, in the field's
  // spatially sorted order (coherent BVH walks; each result has its own slot).
  std::vector<Eigen::Index> outside;
  field().distances(q, out, outside);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, outside.size(), 32),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t k = r.begin(); k < r.end(); ++k)
                        out[outside[k]] = impl_->fallback_distance(q.col(outside[k]));
                    });
  if (fallbacks) *fallbacks = static_cast<Eigen::Index>(outside.size());
  return out;
}

const DistanceField& GroundTruth::field() const {
  Impl& m = *impl_;
  std::call_once(m.field_once, [&] {
    const float voxel = static_cast<float>(m.options.field_voxel * m.diagonal);
    m.field = std::make_unique<DistanceField>(
        m.mesh, voxel, m.options.band_voxels,
        m.closed ? DistanceField::Kind::Signed : DistanceField::Kind::Unsigned);
    m.build_lattice();
  });
  return *m.field;
}

const PointCloud& GroundTruth::surface_samples(Eigen::Index count) const {
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.samples_mutex);
  auto& slot = m.samples[count];
  if (!slot) slot = std::make_unique<PointCloud>(sample_surface(m.mesh, count, m.seed));
  return *slot;
}

}  // namespace scanbench::metrics
