// triangulate.bhattacharyya, candidates = "delaunay": CGAL's advancing-front surface
// reconstruction (Cohen-Steiner and Da 2004) over the mixture's means, its facet priority replaced
// by the GPS grade of sec. 6.2 (eq. 19-22). CGAL is confined to this translation unit (the
// scanbench_algorithms_cgal object library); the mode is described in
// bhattacharyya_triangulation.h.
#include <CGAL/Advancing_front_surface_reconstruction.h>
#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_data_structure_3.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <set>
#include <utility>

#include "gps/bhattacharyya_internal.h"

namespace scanbench::algorithms::bhattacharyya {

namespace {

constexpr const char* kStage = "triangulate.bhattacharyya";

// Same kernel as the CGAL reconstruction peers (cgal_reconstruction.cpp) and the vertex/cell
// bases CGAL's free function advancing_front_surface_reconstruction() uses.
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Vb = CGAL::Advancing_front_surface_reconstruction_vertex_base_3<Kernel>;
using Cb = CGAL::Advancing_front_surface_reconstruction_cell_base_3<Kernel>;
using Tds = CGAL::Triangulation_data_structure_3<Vb, Cb>;
using Delaunay = CGAL::Delaunay_triangulation_3<Kernel, Tds>;

// Dihedral angle at the edge (a, b) between the triangles (a, b, c) and (a, b, d): pi when flat,
// 0 when folded onto each other (orientation-free, as beta in GPS eq. 21).
double dihedral(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                const Eigen::Vector3d& d) {
  const Eigen::Vector3d u = (b - a).normalized();
  const Eigen::Vector3d x = (c - a) - (c - a).dot(u) * u;
  const Eigen::Vector3d y = (d - a) - (d - a).dot(u) * u;
  return std::atan2(x.cross(y).norm(), x.dot(y));
}

// The facet priority CGAL's advancing front asks for: the facet of the smallest value is taken
// first, infinity() means "not a candidate" (CGAL 5.5, Advancing_front_surface_reconstruction.h:
// "If a facet should not appear in the output, infinity() must be returned"; compute_value() and
// init() keep the minimum). The value is 1 / P (GPS eq. 22), P = P_prob * beta / pi with
// P_prob = BC_ij BC_jk BC_ik (eq. 20, BC by eq. 19) and beta the smallest dihedral angle with the
// surface facets sharing an edge with the candidate (eq. 21; pi when there is none, so the seed
// CGAL picks, the smallest value over all Delaunay facets before any is on the surface, is the
// triangle of highest P_prob, as GPS sec. 6.2 seeds). Infinity when a BC is at most bc_min or
// beta at most beta_min (sec. 6.2), or when an angle of the triangle exceeds max_angle_deg.
// The last matters here: CGAL gives up a front edge whose best candidate has an angle at the edge
// above arccos(-0.86) (its DELTA test in compute_value(), "border facet"), and with the BC grade
// the best candidate is often such a sliver along the rings of a torus (154 boundary edges and 7
// components on the 24 x 10 torus mixture without this bound, 0 and 1 with it).
struct GpsPriority {
  const std::vector<Gaussian>* g = nullptr;
  double log_bc_min = 0;
  double beta_min = 0;
  double cos_max_angle = -1;
  RunContext* ctx = nullptr;
  std::shared_ptr<std::size_t> calls;  // shared by CGAL's copies, for the cancellation check

  template <class Adv, class CellHandle>
  double operator()(const Adv& adv, CellHandle& c, const int& index) const {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    if ((++*calls & 0xffffu) == 0) ctx->check_cancelled(kStage);
    const auto& tr = adv.triangulation_3();
    const std::size_t n = g->size();
    std::array<int, 3> local{};
    std::array<std::size_t, 3> id{};
    for (int k = 0; k < 3; ++k) {
      local[static_cast<std::size_t>(k)] = (index + 1 + k) & 3;
      const auto v = c->vertex(local[static_cast<std::size_t>(k)]);
      if (tr.is_infinite(v) || v->id() >= n) return kInf;  // id n: the apex added for flat input
      id[static_cast<std::size_t>(k)] = v->id();
    }
    const Gaussian& gi = (*g)[id[0]];
    const Gaussian& gj = (*g)[id[1]];
    const Gaussian& gk = (*g)[id[2]];
    const double lij = log_bc(gi, gj), ljk = log_bc(gj, gk), lik = log_bc(gi, gk);
    if (!(lij > log_bc_min && ljk > log_bc_min && lik > log_bc_min)) return kInf;
    if (!angles_within(gi.mu, gj.mu, gk.mu, cos_max_angle)) return kInf;
    double beta = std::numbers::pi;
    for (int e = 0; e < 3; ++e) {
      const auto va = c->vertex(local[static_cast<std::size_t>(e)]);
      const auto vb = c->vertex(local[static_cast<std::size_t>((e + 1) % 3)]);
      const std::size_t opposite = id[static_cast<std::size_t>((e + 2) % 3)];
      const auto start = tr.incident_facets(typename Adv::Edge(
          c, local[static_cast<std::size_t>(e)], local[static_cast<std::size_t>((e + 1) % 3)]));
      auto fc = start;
      do {
        const auto f = *fc;
        if (tr.is_infinite(f)) continue;
        const auto m = tr.mirror_facet(f);
        if (!f.first->is_selected_facet(f.second) && !m.first->is_selected_facet(m.second))
          continue;
        std::size_t w = n;
        for (int k = 1; k < 4; ++k) {
          const auto vw = f.first->vertex((f.second + k) & 3);
          if (vw != va && vw != vb) w = vw->id();
        }
        if (w >= n || w == opposite) continue;  // the candidate itself (or the flat-input apex)
        beta = std::min(beta, dihedral((*g)[id[static_cast<std::size_t>(e)]].mu,
                                       (*g)[id[static_cast<std::size_t>((e + 1) % 3)]].mu,
                                       (*g)[opposite].mu, (*g)[w].mu));
      } while (++fc != start);
    }
    if (!(beta > beta_min)) return kInf;
    const double p_prob = std::exp(lij + ljk + lik);  // eq. 20
    // Ties broken by the vertex ids, not by CGAL: its front is a std::set of (value, pointer)
    // pairs, so equal values would be ordered by heap addresses (run-dependent).
    std::array<std::size_t, 3> key = id;
    std::sort(key.begin(), key.end());
    std::uint64_t h = 0x9e3779b97f4a7c15ull;
    for (std::size_t v : key)
      h = (h ^ static_cast<std::uint64_t>(v)) * 0x100000001b3ull;
    const double jitter = 1.0 + 1e-12 * static_cast<double>(h >> 11) * 0x1.0p-53;
    return std::numbers::pi / (p_prob * beta) * jitter;  // 1 / P, eq. 21-22
  }
};

// A front that ends as a loop of three edges is closed by its triangle, as in Cohen-Steiner and
// Da's advancing front (a front of three edges has one candidate left, the loop itself). CGAL's
// implementation leaves such loops open when their triangle is not among its candidates (measured:
// all 15 holes of the mixture of a clean 8-view scan of the sphere were three-edge loops). Its
// three Gaussians already overlap pairwise above bc_min (each edge was accepted by eq. 19), so
// eq. 20-22 give it P > 0. Each face is oriented like its neighbours (opposite to their boundary
// edges); a vertex with two boundary loops (pinched) is left as it is.
void close_three_edge_fronts(std::vector<std::array<int, 3>>& faces) {
  std::map<std::pair<int, int>, int> directed;  // (a, b) -> faces with that oriented edge
  for (const auto& t : faces)
    for (int k = 0; k < 3; ++k)
      ++directed[{t[static_cast<std::size_t>(k)], t[(k + 1) % 3]}];
  std::map<int, int> next;   // boundary edge a -> b, as oriented in its face
  std::map<int, int> count;  // boundary edges leaving each vertex
  for (const auto& [e, c] : directed) {
    if (c != 1 || directed.count({e.second, e.first}) != 0) continue;
    next[e.first] = e.second;
    ++count[e.first];
  }
  std::set<std::array<int, 3>> existing;  // vertex triples, sorted: a lone triangle's own boundary
  for (auto t : faces) {                  // is a three-edge loop, and is not closed twice
    std::sort(t.begin(), t.end());
    existing.insert(t);
  }
  std::vector<std::array<int, 3>> added;
  for (const auto& [a, b] : next) {
    if (count[a] != 1 || count[b] != 1 || next.count(b) == 0) continue;
    const int c = next[b];
    if (count[c] != 1 || next.count(c) == 0 || next[c] != a || c == a || c == b) continue;
    if (a != std::min({a, b, c})) continue;  // each loop once
    std::array<int, 3> key{a, b, c};
    std::sort(key.begin(), key.end());
    if (existing.count(key) != 0) continue;
    added.push_back({a, c, b});  // reversed: its edges are the loop's opposites
  }
  faces.insert(faces.end(), added.begin(), added.end());
}

}  // namespace

std::vector<std::array<int, 3>> delaunay_front(const std::vector<Gaussian>& g, double bc_min,
                                               double beta_min_rad, double cos_max_angle,
                                               RunContext& ctx, long* components) {
  std::vector<std::pair<Point, std::size_t>> points;
  points.reserve(g.size());
  for (std::size_t i = 0; i < g.size(); ++i)
    points.emplace_back(Point(g[i].mu.x(), g[i].mu.y(), g[i].mu.z()), i);
  std::vector<std::array<int, 3>> faces;
  *components = 0;
  auto timer = ctx.phase("front");
  Delaunay dt(points.begin(), points.end());
  if (dt.dimension() < 2) return faces;  // collinear means: no triangle (the caller says so)
  if (dt.dimension() == 2) {
    // Coplanar means: one apex off the plane makes the triangulation 3D, as CGAL's own
    // constructor would, but with an id the priority recognises (never a candidate), so the
    // in-plane facets are the plane's Delaunay triangles.
    // The plane's normal from the first mean and two others spanning it with it.
    const Eigen::Vector3d& p = g[0].mu;
    Eigen::Vector3d lo = p, hi = p, u = Eigen::Vector3d::Zero(), nrm = Eigen::Vector3d::Zero();
    for (const Gaussian& x : g) {
      lo = lo.cwiseMin(x.mu);
      hi = hi.cwiseMax(x.mu);
      if (u.isZero()) {
        u = x.mu - p;
      } else if (nrm.norm() <= 1e-9 * u.squaredNorm()) {
        nrm = u.cross(x.mu - p);
      }
    }
    const double len = std::max((hi - lo).norm(), 1e-300);
    const Eigen::Vector3d q = p + nrm.normalized() * (10.0 * len);
    const auto apex = dt.insert(Point(q.x(), q.y(), q.z()));
    apex->id() = g.size();
  }
  GpsPriority priority;
  priority.g = &g;
  priority.log_bc_min = std::log(bc_min);
  priority.beta_min = beta_min_rad;
  priority.cos_max_angle = cos_max_angle;
  priority.ctx = &ctx;
  priority.calls = std::make_shared<std::size_t>(0);
  CGAL::Advancing_front_surface_reconstruction<Delaunay, GpsPriority> afsr(dt, priority);
  // beta = pi: every candidate lies in CGAL's "beta-wedge", where CGAL orders the front by the
  // priority alone (compute_value(): -(1 + 1/priority) = -(1 + P)), i.e. by the GPS grade of
  // eq. 22; a smaller wedge would order the candidates outside it by flatness instead, which the
  // paper does not do. radius_ratio_bound then never applies (it only bounds candidates outside
  // the wedge); CGAL's default 5 is passed.
  afsr.run(5.0, std::numbers::pi);
  // CGAL counts its last, unsuccessful seed search as a component too.
  *components = std::max(0, afsr.number_of_connected_components() - 1);
  const auto& tds = afsr.triangulation_data_structure_2();
  for (auto f = tds.faces_begin(); f != tds.faces_end(); ++f) {
    if (!f->is_on_surface()) continue;
    std::array<int, 3> t{};
    bool finite = true;
    for (int k = 0; k < 3; ++k) {
      const std::size_t v = f->vertex(k)->vertex_3()->id();
      finite = finite && v < g.size();
      t[static_cast<std::size_t>(k)] = static_cast<int>(v);
    }
    if (!finite) continue;
    // Canonical order (smallest index first, orientation kept; faces sorted): CGAL's face order
    // follows its allocation order, not the input.
    std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    faces.push_back(t);
  }
  close_three_edge_fronts(faces);
  std::sort(faces.begin(), faces.end());
  return faces;
}

}  // namespace scanbench::algorithms::bhattacharyya
