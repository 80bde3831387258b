#include "scanbench/algorithms/gps/bhattacharyya_triangulation.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <queue>
#include <unordered_map>
#include <vector>

#include "gps/bhattacharyya_internal.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/kdtree.h"

namespace scanbench::algorithms {

// log BC of eq. 19 given both log-determinants.
double bhattacharyya::log_bc(const Gaussian& a, const Gaussian& b) {
  const Eigen::Matrix3d s = 0.5 * (a.sigma + b.sigma);
  const Eigen::LLT<Eigen::Matrix3d> llt(s);
  const Eigen::Vector3d d = a.mu - b.mu;
  const Eigen::Vector3d y = llt.matrixL().solve(d);
  const Eigen::Vector3d l = llt.matrixL().toDenseMatrix().diagonal();
  const double log_det_s = 2.0 * (std::log(l[0]) + std::log(l[1]) + std::log(l[2]));
  return -0.5 * log_det_s + 0.25 * (a.log_det + b.log_det) - 0.125 * y.squaredNorm();
}

bool bhattacharyya::angles_within(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                  const Eigen::Vector3d& c, double cos_max_angle) {
  const Eigen::Vector3d* q[3] = {&a, &b, &c};
  for (std::size_t m = 0; m < 3; ++m) {
    const Eigen::Vector3d u = *q[(m + 1) % 3] - *q[m], w = *q[(m + 2) % 3] - *q[m];
    if (!(u.dot(w) >= cos_max_angle * u.norm() * w.norm())) return false;
  }
  return true;
}

namespace {

using bhattacharyya::Gaussian;
using bhattacharyya::log_bc;

constexpr const char* kStage = "triangulate.bhattacharyya";

Gaussian make_gaussian(const Eigen::Vector3d& mu, const Eigen::Matrix3d& sigma, Eigen::Index i) {
  Gaussian g;
  g.mu = mu;
  g.sigma = sigma;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(sigma, Eigen::EigenvaluesOnly);
  const Eigen::Vector3d ev = es.eigenvalues();
  if (!sigma.allFinite() || !(ev[0] > 0.0) || ev[0] <= 1e-15 * ev[2]) {
    throw InputError(fmt::format(
        "{}: mixture component {}: covariance is not symmetric positive definite (eigenvalues "
        "{:g}, {:g}, {:g})",
        kStage, i, ev[0], ev[1], ev[2]));
  }
  g.log_det = std::log(ev[0]) + std::log(ev[1]) + std::log(ev[2]);
  g.lambda_max = ev[2];
  return g;
}

std::uint64_t edge_key(int a, int b) {
  const auto lo = static_cast<std::uint64_t>(std::min(a, b));
  const auto hi = static_cast<std::uint64_t>(std::max(a, b));
  return (lo << 32) | hi;
}

struct Neighbor {
  int j;
  double bc;
};

// The growing mesh: faces, per-edge faces (at most two), per-vertex state.
class Front {
 public:
  // `adj` holds only the pairs with BC above bc_min (eq. 19), so every candidate edge passes it.
  Front(const std::vector<Gaussian>& g, const std::vector<std::vector<Neighbor>>& adj,
        double beta_min, double cos_max_angle)
      : g_(g),
        adj_(adj),
        beta_min_(beta_min),
        cos_max_angle_(cos_max_angle),
        used_(g.size(), 0),
        boundary_(g.size(), 0),
        dead_(g.size()),
        vertex_faces_(g.size()) {
    edges_.reserve(4 * g.size());
  }

  struct Candidate {
    double p = -1;
    int k = -1;
  };
  struct Entry {
    double p;
    int a, b, face, k;
    bool operator<(const Entry& o) const {  // max-heap: higher p first, then smaller indices
      if (p != o.p) return p < o.p;
      if (a != o.a) return a > o.a;
      if (b != o.b) return b > o.b;
      return k > o.k;
    }
  };

  bool used(int v) const { return used_[static_cast<std::size_t>(v)] != 0; }

  double bc(int i, int j) const {
    const auto& n = adj_[static_cast<std::size_t>(i)];
    auto it =
        std::lower_bound(n.begin(), n.end(), j, [](const Neighbor& x, int v) { return x.j < v; });
    return (it != n.end() && it->j == j) ? it->bc : 0.0;
  }

  // Adds face (x, y, z) and queues its new boundary edges.
  void add_face(int x, int y, int z) {
    const int f = static_cast<int>(faces_.size());
    faces_.push_back({x, y, z});
    const Eigen::Vector3d n =
        (g_[static_cast<std::size_t>(y)].mu - g_[static_cast<std::size_t>(x)].mu)
            .cross(g_[static_cast<std::size_t>(z)].mu - g_[static_cast<std::size_t>(x)].mu);
    normals_.push_back(n.normalized());
    const std::array<int, 3> v{x, y, z};
    for (int e = 0; e < 3; ++e) {
      const int a = v[static_cast<std::size_t>(e)], b = v[static_cast<std::size_t>((e + 1) % 3)];
      auto [it, fresh] = edges_.try_emplace(edge_key(a, b), std::array<int, 2>{f, -1});
      if (fresh) {
        ++boundary_[static_cast<std::size_t>(a)];
        ++boundary_[static_cast<std::size_t>(b)];
      } else {
        it->second[1] = f;
        --boundary_[static_cast<std::size_t>(a)];
        --boundary_[static_cast<std::size_t>(b)];
      }
    }
    for (int u : v) {
      used_[static_cast<std::size_t>(u)] = 1;
      vertex_faces_[static_cast<std::size_t>(u)].push_back(f);
    }
    for (int e = 0; e < 3; ++e) {
      const int a = v[static_cast<std::size_t>(e)], b = v[static_cast<std::size_t>((e + 1) % 3)];
      if (edges_.at(edge_key(a, b))[1] < 0) queue_edge(a, b, f);
    }
    // Edges that found no candidate before may find one now that these vertices changed.
    for (int u : v) {
      std::vector<std::array<int, 3>> dead;
      dead.swap(dead_[static_cast<std::size_t>(u)]);
      for (const auto& d : dead)
        if (is_boundary(d[0], d[1], d[2])) queue_edge(d[0], d[1], d[2]);
    }
  }

  // Grows the front until no edge has a valid candidate. When it stalls, one "glue" triangle may
  // reach a front vertex through no front edge (where two fronts meet, e.g. around a torus handle);
  // the best such triangle over every stalled edge is added, then growing resumes, so the pinch it
  // creates at that vertex is closed by the ordinary steps that follow.
  void grow(RunContext& ctx) {
    for (;;) {
      grow_ordinary(ctx);
      if (!glue()) return;
    }
  }

  void grow_ordinary(RunContext& ctx) {
    std::size_t steps = 0;
    while (!queue_.empty()) {
      if ((++steps & 1023u) == 0) ctx.check_cancelled(kStage);
      const Entry e = queue_.top();
      queue_.pop();
      if (!is_boundary(e.a, e.b, e.face)) continue;
      const Candidate c = best(e.a, e.b, e.face);
      if (c.k < 0) {
        dead_[static_cast<std::size_t>(e.a)].push_back({e.a, e.b, e.face});
        dead_[static_cast<std::size_t>(e.b)].push_back({e.a, e.b, e.face});
        continue;
      }
      if (c.k != e.k || c.p != e.p) {
        queue_.push({c.p, e.a, e.b, e.face, c.k});
        continue;
      }
      add_face(e.b, e.a, e.k);
    }
  }

  // Adds the best glue triangle over the stalled edges; false when there is none.
  bool glue() {
    std::vector<std::array<int, 3>> stalled;
    for (const auto& d : dead_)
      for (const auto& e : d)
        if (is_boundary(e[0], e[1], e[2])) stalled.push_back(e);
    std::sort(stalled.begin(), stalled.end());
    stalled.erase(std::unique(stalled.begin(), stalled.end()), stalled.end());
    allow_pinch_ = true;
    Entry best_entry{-1, 0, 0, -1, -1};
    for (const auto& e : stalled) {
      const Candidate c = best(e[0], e[1], e[2]);
      const Entry en{c.p, e[0], e[1], e[2], c.k};
      if (c.k >= 0 && (best_entry.k < 0 || best_entry < en)) best_entry = en;
    }
    allow_pinch_ = false;
    if (best_entry.k < 0) return false;
    ++glued_;
    add_face(best_entry.b, best_entry.a, best_entry.k);
    return true;
  }

  Eigen::Index glued() const { return glued_; }
  /// Vertices with more than two front edges (two fans meeting at one vertex).
  Eigen::Index pinched() const {
    Eigen::Index n = 0;
    for (int b : boundary_)
      n += b > 2 ? 1 : 0;
    return n;
  }

  const std::vector<std::array<int, 3>>& faces() const { return faces_; }
  std::vector<std::array<int, 3>>& faces() { return faces_; }
  const std::unordered_map<std::uint64_t, std::array<int, 2>>& edges() const { return edges_; }

 private:
  bool is_boundary(int a, int b, int face) const {
    auto it = edges_.find(edge_key(a, b));
    return it != edges_.end() && it->second[1] < 0 && it->second[0] == face;
  }

  // Face f holds the directed edge a -> b.
  bool has_directed(int f, int a, int b) const {
    const auto& t = faces_[static_cast<std::size_t>(f)];
    for (int e = 0; e < 3; ++e)
      if (t[static_cast<std::size_t>(e)] == a && t[static_cast<std::size_t>((e + 1) % 3)] == b)
        return true;
    return false;
  }

  // Dihedral angle between the candidate (normal n) and face f: pi when flat, 0 when folded back.
  double dihedral(const Eigen::Vector3d& n, int f) const {
    const double c = std::clamp(n.dot(normals_[static_cast<std::size_t>(f)]), -1.0, 1.0);
    return std::numbers::pi - std::acos(c);
  }

  // The best candidate k for the new face (b, a, k) across the front edge a -> b of `face`.
  Candidate best(int a, int b, int face) const {
    const auto& t = faces_[static_cast<std::size_t>(face)];
    const int c = t[0] != a && t[0] != b ? t[0] : (t[1] != a && t[1] != b ? t[1] : t[2]);
    const double bc_ab = bc(a, b);
    const auto& na = adj_[static_cast<std::size_t>(a)];
    const auto& nb = adj_[static_cast<std::size_t>(b)];
    const Eigen::Vector3d& pa = g_[static_cast<std::size_t>(a)].mu;
    const Eigen::Vector3d& pb = g_[static_cast<std::size_t>(b)].mu;
    Candidate out;
    std::size_t ia = 0, ib = 0;
    while (ia < na.size() && ib < nb.size()) {
      if (na[ia].j < nb[ib].j) {
        ++ia;
        continue;
      }
      if (nb[ib].j < na[ia].j) {
        ++ib;
        continue;
      }
      const int k = na[ia].j;
      const double bc_ak = na[ia].bc, bc_bk = nb[ib].bc;
      ++ia;
      ++ib;
      if (k == c) continue;
      // The new face (b, a, k) has the directed edges b->a, a->k and k->b.
      const auto eak = edges_.find(edge_key(a, k));
      const auto ekb = edges_.find(edge_key(k, b));
      const bool has_ak = eak != edges_.end(), has_kb = ekb != edges_.end();
      if (has_ak && (eak->second[1] >= 0 || !has_directed(eak->second[0], k, a))) continue;
      if (has_kb && (ekb->second[1] >= 0 || !has_directed(ekb->second[0], b, k))) continue;
      const bool pinch = used(k) && !has_ak && !has_kb;
      // Would pinch k: only as a glue step, and only at a front vertex (never an interior one).
      if (pinch && (!allow_pinch_ || boundary_[static_cast<std::size_t>(k)] == 0)) continue;
      const Eigen::Vector3d n = (pa - pb).cross(g_[static_cast<std::size_t>(k)].mu - pb);
      const double len = n.norm();
      if (!(len > 0.0)) continue;
      const Eigen::Vector3d nn = n / len;
      double beta = dihedral(nn, face);
      if (has_ak) beta = std::min(beta, dihedral(nn, eak->second[0]));
      if (has_kb) beta = std::min(beta, dihedral(nn, ekb->second[0]));
      if (!(beta > beta_min_)) continue;
      if (!bhattacharyya::angles_within(pa, pb, g_[static_cast<std::size_t>(k)].mu, cos_max_angle_))
        continue;
      if (pinch) {
        // A glue face must face the same way as the faces it joins at k (one orientation), or
        // the gap could never be zipped closed.
        bool agrees = true;
        for (int f : vertex_faces_[static_cast<std::size_t>(k)])
          agrees = agrees && nn.dot(normals_[static_cast<std::size_t>(f)]) > 0.0;
        if (!agrees) continue;
      }
      const double p = bc_ab * bc_ak * bc_bk * beta / std::numbers::pi;  // eq. 20-22
      if (p > out.p || (p == out.p && k < out.k)) out = {p, k};
    }
    return out;
  }

  void queue_edge(int a, int b, int face) {
    const Candidate c = best(a, b, face);
    if (c.k >= 0) {
      queue_.push({c.p, a, b, face, c.k});
    } else {
      dead_[static_cast<std::size_t>(a)].push_back({a, b, face});
      dead_[static_cast<std::size_t>(b)].push_back({a, b, face});
    }
  }

  const std::vector<Gaussian>& g_;
  const std::vector<std::vector<Neighbor>>& adj_;
  double beta_min_;
  double cos_max_angle_;
  std::vector<std::array<int, 3>> faces_;
  std::vector<Eigen::Vector3d> normals_;
  std::unordered_map<std::uint64_t, std::array<int, 2>> edges_;
  std::vector<char> used_;
  std::vector<int> boundary_;
  std::vector<std::vector<std::array<int, 3>>> dead_;
  std::vector<std::vector<int>> vertex_faces_;
  std::priority_queue<Entry> queue_;
  bool allow_pinch_ = false;
  Eigen::Index glued_ = 0;
};

using EdgeFaces = std::unordered_map<std::uint64_t, std::array<int, 2>>;

EdgeFaces edge_faces(const std::vector<std::array<int, 3>>& faces) {
  EdgeFaces edges;
  edges.reserve(2 * faces.size());
  for (std::size_t f = 0; f < faces.size(); ++f)
    for (int e = 0; e < 3; ++e) {
      auto [it, fresh] =
          edges.try_emplace(edge_key(faces[f][static_cast<std::size_t>(e)],
                                     faces[f][static_cast<std::size_t>((e + 1) % 3)]),
                            std::array<int, 2>{static_cast<int>(f), -1});
      if (!fresh) it->second[1] = static_cast<int>(f);
    }
  return edges;
}

// Removes the faces of every fan but the largest (ties: the one holding the lowest face index) at
// each vertex where fans still meet (a glue step not yet zipped when growing stopped), until no
// such vertex is left: the result is a manifold (sec. 6.2), with holes where the fans were.
// Returns the number of vertices resolved.
Eigen::Index unpinch(std::vector<std::array<int, 3>>& faces, std::size_t n) {
  Eigen::Index resolved = 0;
  for (;;) {
    const EdgeFaces edges = edge_faces(faces);
    std::vector<std::vector<int>> at(n);
    for (std::size_t f = 0; f < faces.size(); ++f)
      for (int v : faces[f])
        at[static_cast<std::size_t>(v)].push_back(static_cast<int>(f));
    std::vector<char> drop(faces.size(), 0);
    bool any = false;
    for (std::size_t v = 0; v < n; ++v) {
      const auto& fv = at[v];
      if (fv.size() < 2) continue;
      // Fans: faces at v connected through edges at v.
      std::vector<int> fan(fv.size(), -1);
      int nfan = 0;
      for (std::size_t s = 0; s < fv.size(); ++s) {
        if (fan[s] >= 0) continue;
        std::vector<std::size_t> stack{s};
        fan[s] = nfan;
        while (!stack.empty()) {
          const std::size_t i = stack.back();
          stack.pop_back();
          for (int u : faces[static_cast<std::size_t>(fv[i])]) {
            if (u == static_cast<int>(v)) continue;
            for (int o : edges.at(edge_key(static_cast<int>(v), u))) {
              if (o < 0) continue;
              const auto it = std::find(fv.begin(), fv.end(), o);
              const auto j = static_cast<std::size_t>(it - fv.begin());
              if (fan[j] < 0) {
                fan[j] = nfan;
                stack.push_back(j);
              }
            }
          }
        }
        ++nfan;
      }
      if (nfan < 2) continue;
      std::vector<int> size(static_cast<std::size_t>(nfan), 0);
      for (int c : fan)
        ++size[static_cast<std::size_t>(c)];
      // fv is in face order, so the first fan reaching the largest size holds the lowest index.
      int keep = 0;
      for (int c = 1; c < nfan; ++c)
        if (size[static_cast<std::size_t>(c)] > size[static_cast<std::size_t>(keep)]) keep = c;
      for (std::size_t i = 0; i < fv.size(); ++i)
        if (fan[i] != keep) drop[static_cast<std::size_t>(fv[i])] = 1;
      ++resolved;
      any = true;
    }
    if (!any) return resolved;
    std::vector<std::array<int, 3>> kept;
    for (std::size_t f = 0; f < faces.size(); ++f)
      if (!drop[f]) kept.push_back(faces[f]);
    faces.swap(kept);
  }
}

// Components of the face graph; those with negative signed volume are flipped outward.
void orient_components(std::vector<std::array<int, 3>>& faces,
                       const std::unordered_map<std::uint64_t, std::array<int, 2>>& edges,
                       const std::vector<Gaussian>& g) {
  const std::size_t nf = faces.size();
  std::vector<int> comp(nf, -1);
  int ncomp = 0;
  std::vector<int> stack;
  for (std::size_t s = 0; s < nf; ++s) {
    if (comp[s] >= 0) continue;
    comp[s] = ncomp;
    stack.assign(1, static_cast<int>(s));
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      const auto& t = faces[static_cast<std::size_t>(f)];
      for (int e = 0; e < 3; ++e) {
        const auto& ef = edges.at(
            edge_key(t[static_cast<std::size_t>(e)], t[static_cast<std::size_t>((e + 1) % 3)]));
        for (int o : ef) {
          if (o >= 0 && comp[static_cast<std::size_t>(o)] < 0) {
            comp[static_cast<std::size_t>(o)] = ncomp;
            stack.push_back(o);
          }
        }
      }
    }
    ++ncomp;
  }
  // Signed volume of each component about the centroid of its faces' centroids: for a closed
  // component the enclosed volume (any origin), for an open one (holes) the volume of the cone
  // from that centroid, so a sphere with holes faces outward too. Every component gets one
  // orientation from its geometry alone (CGAL's advancing front returns either).
  const auto nc = static_cast<std::size_t>(ncomp);
  std::vector<Eigen::Vector3d> centre(nc, Eigen::Vector3d::Zero());
  std::vector<double> count(nc, 0.0);
  for (std::size_t f = 0; f < nf; ++f) {
    const auto& t = faces[f];
    const auto c = static_cast<std::size_t>(comp[f]);
    for (int v : t)
      centre[c] += g[static_cast<std::size_t>(v)].mu / 3.0;
    count[c] += 1.0;
  }
  for (std::size_t c = 0; c < nc; ++c)
    centre[c] /= count[c];
  std::vector<double> volume(nc, 0.0);
  for (std::size_t f = 0; f < nf; ++f) {
    const auto& t = faces[f];
    const auto c = static_cast<std::size_t>(comp[f]);
    const Eigen::Vector3d a = g[static_cast<std::size_t>(t[0])].mu - centre[c];
    const Eigen::Vector3d b = g[static_cast<std::size_t>(t[1])].mu - centre[c];
    const Eigen::Vector3d d = g[static_cast<std::size_t>(t[2])].mu - centre[c];
    volume[c] += a.dot(b.cross(d)) / 6.0;
  }
  for (std::size_t f = 0; f < nf; ++f)
    if (volume[static_cast<std::size_t>(comp[f])] < 0.0) std::swap(faces[f][1], faces[f][2]);
}

}  // namespace

double bhattacharyya_coefficient(const Eigen::Vector3d& mu_i, const Eigen::Matrix3d& sigma_i,
                                 const Eigen::Vector3d& mu_j, const Eigen::Matrix3d& sigma_j) {
  return std::exp(log_bc(make_gaussian(mu_i, sigma_i, 0), make_gaussian(mu_j, sigma_j, 1)));
}

namespace {

// The "free" candidates: greedy front growing over every triangle of overlapping Gaussians (see
// the header). Returns the faces; the counts go to the references.
std::vector<std::array<int, 3>> free_front(const GaussianMixture& mixture,
                                           const std::vector<Gaussian>& g,
                                           const BhattacharyyaParams& p, RunContext& ctx,
                                           Eigen::Index& pairs, Eigen::Index& seeds,
                                           Eigen::Index& glued, Eigen::Index& pinched) {
  const Eigen::Index n = mixture.size();
  // The BC graph. BC_ij > bc_min needs the Mahalanobis term d^T S^-1 d < 8 ln(1/bc_min) (the
  // determinant factor of eq. 19 is at most 1), and |d|^2 <= lambda_max(S) d^T S^-1 d <=
  // max(lambda_i, lambda_j) 8 ln(1/bc_min): the search from the wider Gaussian of a pair finds it.
  std::vector<std::vector<Neighbor>> adj(static_cast<std::size_t>(n));
  {
    auto timer = ctx.phase("graph");
    const double reach2 = 8.0 * std::log(1.0 / p.bc_min);
    const double log_bc_min = std::log(p.bc_min);
    const KdTree tree(mixture.means);
    std::vector<std::vector<Neighbor>> found(static_cast<std::size_t>(n));
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, 64), [&](const auto& r) {
      std::vector<std::pair<Eigen::Index, float>> near;
      for (Eigen::Index i = r.begin(); i != r.end(); ++i) {
        const Gaussian& gi = g[static_cast<std::size_t>(i)];
        // Float search radius grown by a relative 1e-5 so rounding cannot drop a pair.
        const auto radius = static_cast<float>(std::sqrt(reach2 * gi.lambda_max) * (1.0 + 1e-5));
        tree.radius(mixture.means.col(i), radius, near, false);
        auto& out = found[static_cast<std::size_t>(i)];
        for (const auto& [j, d2] : near) {
          if (j == i) continue;
          const Gaussian& gj = g[static_cast<std::size_t>(j)];
          // Each pair once: from the wider Gaussian (ties: the lower index).
          if (gj.lambda_max > gi.lambda_max || (gj.lambda_max == gi.lambda_max && j < i)) continue;
          const double lb = log_bc(gi, gj);
          if (lb > log_bc_min) out.push_back({static_cast<int>(j), std::exp(lb)});
        }
      }
    });
    for (Eigen::Index i = 0; i < n; ++i) {
      for (const Neighbor& nb : found[static_cast<std::size_t>(i)]) {
        adj[static_cast<std::size_t>(i)].push_back(nb);
        adj[static_cast<std::size_t>(nb.j)].push_back({static_cast<int>(i), nb.bc});
        ++pairs;
      }
    }
    const auto cap = static_cast<std::size_t>(p.max_neighbors);
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, 256), [&](const auto& r) {
      for (Eigen::Index i = r.begin(); i != r.end(); ++i) {
        auto& a = adj[static_cast<std::size_t>(i)];
        if (a.size() > cap) {
          std::sort(a.begin(), a.end(), [](const Neighbor& x, const Neighbor& y) {
            return x.bc != y.bc ? x.bc > y.bc : x.j < y.j;
          });
          a.resize(cap);
        }
        std::sort(a.begin(), a.end(),
                  [](const Neighbor& x, const Neighbor& y) { return x.j < y.j; });
      }
    });
  }

  const double cos_max_angle = std::cos(p.max_angle_deg * std::numbers::pi / 180.0);
  Front front(g, adj, p.beta_min_deg * std::numbers::pi / 180.0, cos_max_angle);
  {
    auto timer = ctx.phase("front");
    // Seeds: per Gaussian i, its best triangle (i, j, k) of unused Gaussians by P_prob (eq. 20),
    // in a lazy max-heap; a stale entry is re-evaluated when it surfaces.
    struct Seed {
      double p;
      int i, j, k;
      bool operator<(const Seed& o) const {
        if (p != o.p) return p < o.p;
        return i > o.i;
      }
    };
    auto best_seed = [&](int i) {
      Seed s{-1, i, -1, -1};
      if (front.used(i)) return s;
      const auto& ni = adj[static_cast<std::size_t>(i)];
      for (std::size_t a = 0; a < ni.size(); ++a) {
        const int j = ni[a].j;
        if (front.used(j)) continue;
        for (std::size_t b = a + 1; b < ni.size(); ++b) {
          const int k = ni[b].j;
          if (front.used(k)) continue;
          const double bc_jk = front.bc(j, k);
          if (bc_jk <= 0.0) continue;
          const double pp = ni[a].bc * ni[b].bc * bc_jk;
          if (pp <= s.p) continue;
          const Eigen::Vector3d nrm =
              (g[static_cast<std::size_t>(j)].mu - g[static_cast<std::size_t>(i)].mu)
                  .cross(g[static_cast<std::size_t>(k)].mu - g[static_cast<std::size_t>(i)].mu);
          if (!(nrm.norm() > 0.0)) continue;
          if (!bhattacharyya::angles_within(g[static_cast<std::size_t>(i)].mu,
                                            g[static_cast<std::size_t>(j)].mu,
                                            g[static_cast<std::size_t>(k)].mu, cos_max_angle))
            continue;
          s = {pp, i, j, k};
        }
      }
      return s;
    };
    std::priority_queue<Seed> heap;
    {
      std::vector<Seed> all(static_cast<std::size_t>(n));
      tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, 64), [&](const auto& r) {
        for (Eigen::Index i = r.begin(); i != r.end(); ++i)
          all[static_cast<std::size_t>(i)] = best_seed(static_cast<int>(i));
      });
      for (const Seed& s : all)
        if (s.j >= 0) heap.push(s);
    }
    while (!heap.empty() && (p.max_seeds == 0 || seeds < p.max_seeds)) {
      const Seed s = heap.top();
      heap.pop();
      if (front.used(s.i) || front.used(s.j) || front.used(s.k)) {
        const Seed fresh = best_seed(s.i);
        if (fresh.j >= 0) heap.push(fresh);
        continue;
      }
      ++seeds;
      front.add_face(s.i, s.j, s.k);
      front.grow(ctx);
    }
  }
  glued = front.glued();
  pinched = front.pinched();
  return front.faces();
}

}  // namespace

CovarianceMesh triangulate_bhattacharyya(const GaussianMixture& mixture,
                                         const BhattacharyyaParams& p, RunContext& ctx,
                                         TriangulationStats* stats) {
  // The declared ranges, checked here too for callers that bypass the parameter layer.
  if (!(p.bc_min > 0.0 && p.bc_min <= 1.0))
    throw ParamError(fmt::format("{}: bc_min = {:g} is outside (0, 1]", kStage, p.bc_min));
  if (!(p.beta_min_deg >= 0.0 && p.beta_min_deg < 180.0))
    throw ParamError(
        fmt::format("{}: beta_min_deg = {:g} is outside [0, 180)", kStage, p.beta_min_deg));
  if (!(p.max_angle_deg > 60.0 && p.max_angle_deg <= 180.0))
    throw ParamError(
        fmt::format("{}: max_angle_deg = {:g} is outside (60, 180]", kStage, p.max_angle_deg));
  if (p.candidates != "free" && p.candidates != "delaunay")
    throw ParamError(fmt::format("{}: candidates = \"{}\" is neither \"free\" nor \"delaunay\"",
                                 kStage, p.candidates));
  mixture.validate(kStage);
  const Eigen::Index n = mixture.size();
  if (n < 3) {
    throw InputError(
        fmt::format("{}: the mixture has {} components (at least 3 needed)", kStage, n));
  }
  std::vector<Gaussian> g(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i)
    g[static_cast<std::size_t>(i)] =
        make_gaussian(mixture.means.col(i).cast<double>(), mixture.covariance(i).cast<double>(), i);

  Eigen::Index pairs = 0, seeds = 0, glued = 0, pinched = 0;
  std::vector<std::array<int, 3>> faces;
  if (p.candidates == "delaunay") {
    long components = 0;
    faces = bhattacharyya::delaunay_front(g, p.bc_min, p.beta_min_deg * std::numbers::pi / 180.0,
                                          std::cos(p.max_angle_deg * std::numbers::pi / 180.0), ctx,
                                          &components);
    seeds = faces.empty() ? 0 : components;
  } else {
    faces = free_front(mixture, g, p, ctx, pairs, seeds, glued, pinched);
  }
  if (seeds == 0) {
    throw InputError(fmt::format(
        "{}: no valid seed triangle: no three Gaussians overlap pairwise with Bhattacharyya "
        "coefficients above bc_min = {:g} (lower bc_min, or check the mixture's scale)",
        kStage, p.bc_min));
  }

  const Eigen::Index unpinched = unpinch(faces, static_cast<std::size_t>(n));
  const EdgeFaces final_edges = edge_faces(faces);
  orient_components(faces, final_edges, g);
  if (p.candidates == "delaunay") {
    // CGAL returns either orientation per component: the canonical order again after orienting.
    for (auto& t : faces)
      std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    std::sort(faces.begin(), faces.end());
  }

  // Compact: only Gaussians in a triangle, in index order.
  std::vector<int> remap(static_cast<std::size_t>(n), -1);
  for (const auto& t : faces)
    for (int v : t)
      remap[static_cast<std::size_t>(v)] = 0;
  int nv = 0;
  for (auto& r : remap)
    if (r == 0) r = nv++;
  CovarianceMesh out;
  out.resize(nv);
  for (Eigen::Index i = 0; i < n; ++i) {
    const int r = remap[static_cast<std::size_t>(i)];
    if (r < 0) continue;
    out.means.col(r) = g[static_cast<std::size_t>(i)].mu;
    out.set_covariance(r, g[static_cast<std::size_t>(i)].sigma);
  }
  for (const auto& t : faces) {
    const int f[3] = {remap[static_cast<std::size_t>(t[0])], remap[static_cast<std::size_t>(t[1])],
                      remap[static_cast<std::size_t>(t[2])]};
    out.faces.add(f);
  }
  if (stats != nullptr) {
    stats->pairs = pairs;
    stats->seeds = seeds;
    stats->unused = n - nv;
    stats->glued = glued;
    stats->pinched_vertices = pinched;
    stats->unpinched_vertices = unpinched;
    stats->boundary_edges = 0;
    for (const auto& [k, e] : final_edges)
      if (e[1] < 0) ++stats->boundary_edges;
  }
  return out;
}

StageData triangulate_bhattacharyya_step(const StageData& in, const BhattacharyyaParams& p,
                                         RunContext& ctx) {
  StageData out;
  out.covariance_mesh = triangulate_bhattacharyya(in.require_mixture(kStage), p, ctx);
  return out;
}

}  // namespace scanbench::algorithms
