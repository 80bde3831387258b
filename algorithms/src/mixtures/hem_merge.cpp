// mixture.hem, the merge levels (CLOP paper Algorithm 1 lines 11-18): parents, children under
// the KL constraint (eq. 11), responsibilities (eq. 8-9) and the merged components (eq. 10,
// 29-30).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

#include "mixtures/hem_internal.h"
#include "scanbench/core/kdtree.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/simd_dispatch.h"
#include "spatial/compact.h"
#include "spatial/neighbor_grid.h"

// Eigen's packet types (__m128, __m256, __m512) carry vector attributes that GCC reports as
// ignored when they are template arguments (the kernels are templates over the packet type of
// the active ISA, scanbench/core/simd_dispatch.h); the attributes do not matter there.
#pragma GCC diagnostic ignored "-Wignored-attributes"

namespace scanbench::algorithms {

namespace hem_detail {

bool chosen_as_parent(std::uint64_t level_seed, Eigen::Index i, double probability) {
  Rng rng(derive_seed(level_seed, static_cast<std::uint64_t>(i)));
  return rng.uniform() < probability;
}

}  // namespace hem_detail

namespace {

using Eigen::Index;
using Eigen::Matrix3d;
using Eigen::Vector3d;
using Eigen::Vector3f;
using Hits = std::vector<std::pair<Index, float>>;

using hem_detail::chosen_as_parent;
using hem_detail::Component;
using hem_detail::Components;
using hem_detail::set_conditioned;

constexpr double kLog2Pi = 1.8378770664093453;

struct Child {
  Index i;
  // log(w_s L_is) as collected; exp(log(w_s L_is) - max over the parents s' holding i of
  // log(w_s' L_is')) once MergeLevel::normalisers has run.
  double term;
};

// The candidate children of one parent and, per candidate i, eq. 11's D_KL(i || s) and eq. 9's
// log L_is = w_i |P| (log N(mu_i; mu_s, Sigma_s) - tr(Sigma_s^-1 Sigma_i) / 2).
struct KlBatch {
  std::vector<Index> ids;
  std::vector<double> kl, log_l;
  // Structure of arrays of the gathered candidates: mu_i - mu_s (3), Sigma_i's upper triangle
  // (xx, xy, xz, yy, yz, zz), log |Sigma_i|, w_i |P|; padded to whole packets.
  std::vector<double> f[11];
};

// Fills batch.kl and batch.log_l for batch.ids in double packets of the active ISA. Every lane
// is one candidate evaluated by the same operations in the same order, so each value is the
// same on every ISA and at any thread count (no sum runs across lanes).
template <class PacketD>
void kl_terms(const Components& comps, const Component& ps, double n_points, KlBatch& batch) {
  namespace ei = Eigen::internal;
  constexpr std::size_t kLanes = ei::unpacket_traits<PacketD>::size;
  const std::size_t m = batch.ids.size();
  const std::size_t padded = (m + kLanes - 1) / kLanes * kLanes;
  for (auto& f : batch.f)
    if (f.size() < padded) f.resize(padded);
  batch.kl.resize(padded);
  batch.log_l.resize(padded);
  for (std::size_t t = 0; t < padded; ++t) {
    if (t < m) {
      const Component& ci = comps[static_cast<std::size_t>(batch.ids[t])];
      batch.f[0][t] = ci.mu.x() - ps.mu.x();
      batch.f[1][t] = ci.mu.y() - ps.mu.y();
      batch.f[2][t] = ci.mu.z() - ps.mu.z();
      batch.f[3][t] = ci.cov(0, 0);
      batch.f[4][t] = ci.cov(0, 1);
      batch.f[5][t] = ci.cov(0, 2);
      batch.f[6][t] = ci.cov(1, 1);
      batch.f[7][t] = ci.cov(1, 2);
      batch.f[8][t] = ci.cov(2, 2);
      batch.f[9][t] = ci.logdet;
      batch.f[10][t] = ci.w * n_points;
    } else {  // padding: finite values, results ignored
      for (int e = 0; e < 11; ++e)
        batch.f[e][t] = 0.0;
    }
  }
  // Sigma_s is stored symmetric (set_conditioned, store_conditioned), and so is its inverse.
  const Matrix3d inv = ps.cov.inverse();
  const PacketD i00 = ei::pset1<PacketD>(inv(0, 0)), i01 = ei::pset1<PacketD>(inv(0, 1)),
                i02 = ei::pset1<PacketD>(inv(0, 2)), i11 = ei::pset1<PacketD>(inv(1, 1)),
                i12 = ei::pset1<PacketD>(inv(1, 2)), i22 = ei::pset1<PacketD>(inv(2, 2));
  const PacketD two = ei::pset1<PacketD>(2.0), half = ei::pset1<PacketD>(0.5);
  const PacketD three_minus_lds = ei::pset1<PacketD>(3.0 - ps.logdet);
  const PacketD log_norm = ei::pset1<PacketD>(-0.5 * (3.0 * kLog2Pi + ps.logdet));
  for (std::size_t t = 0; t < padded; t += kLanes) {
    auto ld = [&](int e) { return ei::ploadu<PacketD>(batch.f[e].data() + t); };
    const PacketD dx = ld(0), dy = ld(1), dz = ld(2);
    // d^T Sigma_s^-1 d
    const PacketD tx = ei::padd(ei::padd(ei::pmul(i00, dx), ei::pmul(i01, dy)), ei::pmul(i02, dz));
    const PacketD ty = ei::padd(ei::padd(ei::pmul(i01, dx), ei::pmul(i11, dy)), ei::pmul(i12, dz));
    const PacketD tz = ei::padd(ei::padd(ei::pmul(i02, dx), ei::pmul(i12, dy)), ei::pmul(i22, dz));
    const PacketD maha = ei::padd(ei::padd(ei::pmul(dx, tx), ei::pmul(dy, ty)), ei::pmul(dz, tz));
    // tr(Sigma_s^-1 Sigma_i) of two symmetric matrices: diagonal products + 2 x off-diagonal.
    const PacketD diag =
        ei::padd(ei::padd(ei::pmul(i00, ld(3)), ei::pmul(i11, ld(6))), ei::pmul(i22, ld(8)));
    const PacketD off =
        ei::padd(ei::padd(ei::pmul(i01, ld(4)), ei::pmul(i02, ld(5))), ei::pmul(i12, ld(7)));
    const PacketD tr = ei::padd(diag, ei::pmul(two, off));
    // eq. 11: D_KL = (d_M^2 + tr - 3 - log(|Sigma_i| / |Sigma_s|)) / 2
    const PacketD kl =
        ei::pmul(half, ei::psub(ei::padd(maha, tr), ei::padd(three_minus_lds, ld(9))));
    // eq. 9: log L_is = w_i |P| (log g(mu_i; mu_s, Sigma_s) - tr / 2)
    const PacketD log_g = ei::psub(log_norm, ei::pmul(half, maha));
    const PacketD log_l = ei::pmul(ld(10), ei::psub(log_g, ei::pmul(half, tr)));
    ei::pstoreu(batch.kl.data() + t, kl);
    ei::pstoreu(batch.log_l.data() + t, log_l);
  }
}

// One HEM level (cluster_level): the parents, the candidate search over the non-parents' means,
// the children of every parent with their log(w_s L_is), the log-sum-exp normalisers of the
// responsibilities, and the merged components.
class MergeLevel {
 public:
  MergeLevel(const Components& comps, const HemParams& p, double n_points, double abs_floor)
      : comps_(comps), p_(p), n_points_(n_points), abs_floor_(abs_floor) {}

  Components run(std::uint64_t level_seed) {
    choose_parents(level_seed);
    if (parents_.empty()) return comps_;
    np_ = static_cast<Index>(parents_.size());
    build_search();
    collect_children();
    normalisers();
    // The search is done: its grid and tree go before the merged components are allocated.
    grid_.reset();
    tree_storage_.reset();
    centers_.resize(3, 0);
    const Index n = static_cast<Index>(comps_.size());
    const double neg_inf = -std::numeric_limits<double>::infinity();
    const auto orphans = static_cast<std::size_t>(std::count(cmax_.begin(), cmax_.end(), neg_inf));
    // Sized once: growing by push_back would hold the old and a doubled block at once (the
    // first level's merge is CLOP's peak of memory).
    Components next;
    next.reserve(parents_.size() + orphans);
    next.resize(parents_.size());
    tbb::parallel_for(tbb::blocked_range<Index>(0, np_, 64),
                      [&](const tbb::blocked_range<Index>& r) {
                        std::vector<Matrix3d> covs;
                        covs.reserve(r.size());
                        for (Index k = r.begin(); k < r.end(); ++k)
                          covs.push_back(merge_children(k, next[static_cast<std::size_t>(k)]));
                        set_conditioned(next.data() + r.begin(), covs, abs_floor_);
                      });
    for (Index i = 0; i < n; ++i)  // orphans, carried unchanged
      if (cmax_[static_cast<std::size_t>(i)] == neg_inf)
        next.push_back(comps_[static_cast<std::size_t>(i)]);
    return next;
  }

 private:
  // Children of parent k: block b = k / kBlock holds the sets of its parents back to back;
  // offsets[k] .. offsets[k + 1] index into it. Fixed blocks: thread-independent.
  static constexpr Index kBlock = 64;
  // A parent whose search radius spans more than kMaxCells grid cells asks the kd-tree. Its
  // first query builds the tree over every candidate, serially: at 10M points a handful of wide
  // parents (isolated points) made the first level build it, hence up to (2 x 16 + 1)^2 columns
  // of the grid first (docs/performance.md).
  static constexpr float kMaxCells = 16.0f;

  // The parents (chosen_as_parent) and the others, each in index order.
  void choose_parents(std::uint64_t level_seed) {
    const Index n = static_cast<Index>(comps_.size());
    std::vector<char> is_parent(comps_.size(), 0);
    tbb::parallel_for(tbb::blocked_range<Index>(0, n, 4096),
                      [&](const tbb::blocked_range<Index>& r) {
                        for (Index i = r.begin(); i < r.end(); ++i)
                          is_parent[static_cast<std::size_t>(i)] =
                              chosen_as_parent(level_seed, i, p_.parent_probability) ? 1 : 0;
                      });
    for (Index i = 0; i < n; ++i)
      (is_parent[static_cast<std::size_t>(i)] ? parents_ : others_).push_back(i);
  }

  // Candidate children of a parent: itself, and the non-parents (other parents are never
  // children) within alpha * sigma_max(s) of mu_s.
  void build_search() {
    const Components& comps = comps_;
    const Index np = np_;
    centers_.resize(3, static_cast<Index>(others_.size()));
    tbb::parallel_for(tbb::blocked_range<Index>(0, centers_.cols(), 4096),
                      [&](const tbb::blocked_range<Index>& r) {
                        for (Index k = r.begin(); k < r.end(); ++k)
                          centers_.col(k) =
                              comps[static_cast<std::size_t>(others_[static_cast<std::size_t>(k)])]
                                  .mu.cast<float>();
                      });
    // D_KL >= d_M^2 / 2, so every admissible child of parent s is within alpha * sigma_max(s) of
    // mu_s; the float search gets a hair of slack, the exact test (eq. 11) decides.
    radius_.resize(static_cast<std::size_t>(np));
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, np, 4096), [&](const tbb::blocked_range<Index>& r) {
          for (Index k = r.begin(); k < r.end(); ++k) {
            const Component& ps =
                comps[static_cast<std::size_t>(parents_[static_cast<std::size_t>(k)])];
            radius_[static_cast<std::size_t>(k)] = static_cast<float>(
                p_.alpha * std::sqrt(ps.lmax) * 1.001 + 1e-6 * ps.mu.cwiseAbs().maxCoeff());
          }
        });
    // The candidates come from a uniform grid of the non-parents' means (cells of the 90th
    // percentile of the search radii: at most 3 x 3 contiguous column ranges for 90% of the
    // parents, no tree walk); a parent whose radius spans more than kMaxCells cells asks a
    // kd-tree (built on first use). Either way the candidates within the radius are visited in
    // index order, so the result does not depend on the search.
    float cell = 1.0f;
    if (np > 0) {
      std::vector<float> sorted_radius = radius_;
      const Index at = np * 9 / 10;
      std::nth_element(sorted_radius.begin(), sorted_radius.begin() + at, sorted_radius.end());
      cell = sorted_radius[static_cast<std::size_t>(at)];
    }
    // At most 2^20 cells per axis (the grid's keys stay far from overflow).
    if (centers_.cols() > 0)
      cell = std::max(cell,
                      (centers_.rowwise().maxCoeff() - centers_.rowwise().minCoeff()).maxCoeff() /
                          static_cast<float>(1 << 20));
    if (!(cell > 0.0f) || !std::isfinite(cell)) cell = 1.0f;
    cell_ = cell;
    grid_.emplace(centers_, cell);
  }

  const KdTree& tree() const {
    std::call_once(tree_once_, [&] { tree_storage_.emplace(centers_); });
    return *tree_storage_;
  }

  // Per-thread scratch of the children search.
  struct Scratch {
    Hits nb;
    std::vector<detail::GridRange> ranges;
    std::vector<Index> near;  // positions in `others`
    KlBatch batch;
  };

  // The children of parent k (eq. 11; a parent always keeps itself) appended to `set`, each
  // with log(w_s L_is).
  template <class PacketD>
  void children_of(Index k, Scratch& sc, std::vector<Child>& set) {
    const detail::NeighborGrid& grid = *grid_;
    const double kl_max = 0.5 * p_.alpha * p_.alpha;
    std::vector<Index>& near = sc.near;
    KlBatch& batch = sc.batch;
    const Index s = parents_[static_cast<std::size_t>(k)];
    const Component& ps = comps_[static_cast<std::size_t>(s)];
    const float rad = radius_[static_cast<std::size_t>(k)];
    const Vector3f mu = ps.mu.cast<float>();
    near.clear();
    if (rad <= kMaxCells * cell_) {
      grid.ranges_near(mu, rad, sc.ranges);
      std::size_t bound = detail::kCompactSlack;
      for (const detail::GridRange& gr : sc.ranges)
        bound += static_cast<std::size_t>(gr.end - gr.begin);
      near.resize(bound);
      std::size_t m = 0;
      for (const detail::GridRange& gr : sc.ranges)
        m = detail::compact_within(grid.x(), grid.y(), grid.z(), static_cast<std::size_t>(gr.begin),
                                   static_cast<std::size_t>(gr.end), mu, rad * rad, near.data(), m);
      near.resize(m);
      for (Index& at : near)  // sorted positions -> positions in `others`
        at = grid.index(at);
    } else {
      tree().radius(mu, rad, sc.nb);
      for (const auto& hit : sc.nb)
        near.push_back(hit.first);
    }
    std::sort(near.begin(), near.end());
    offsets_[static_cast<std::size_t>(k)] = set.size();
    // Candidates in index order, the parent itself among them.
    batch.ids.clear();
    bool self_done = false;
    for (const Index at : near) {
      const Index i = others_[static_cast<std::size_t>(at)];
      if (!self_done && s < i) {
        batch.ids.push_back(s);
        self_done = true;
      }
      batch.ids.push_back(i);
    }
    if (!self_done) batch.ids.push_back(s);
    kl_terms<PacketD>(comps_, ps, n_points_, batch);
    const double log_ws = std::log(ps.w);
    for (std::size_t t = 0; t < batch.ids.size(); ++t) {
      const Index i = batch.ids[t];
      // eq. 11 (a parent always keeps itself)
      if (!(batch.kl[t] < kl_max) && i != s) continue;
      set.push_back({i, log_ws + batch.log_l[t]});
    }
  }

  void collect_children() {
    const Index np = np_;
    const Index nblocks = (np + kBlock - 1) / kBlock;
    block_sets_.assign(static_cast<std::size_t>(nblocks), {});
    offsets_.assign(static_cast<std::size_t>(np) + 1, 0);
    simd::with_packet([&](auto tag) {
      using PacketD = typename simd::DoublePacket<typename decltype(tag)::type>::type;
      tbb::parallel_for(tbb::blocked_range<Index>(0, nblocks, 1),
                        [&](const tbb::blocked_range<Index>& r) {
                          Scratch sc;
                          for (Index b = r.begin(); b < r.end(); ++b) {
                            auto& set = block_sets_[static_cast<std::size_t>(b)];
                            for (Index k = b * kBlock; k < std::min(np, (b + 1) * kBlock); ++k)
                              children_of<PacketD>(k, sc, set);
                            set.shrink_to_fit();  // no doubling slack kept per block
                          }
                        });
    });
  }

  // The children of parent k.
  std::pair<const Child*, const Child*> set_range(Index k) const {
    const auto b = static_cast<std::size_t>(k / kBlock);
    const std::size_t end = k + 1 < std::min(np_, (static_cast<Index>(b) + 1) * kBlock)
                                ? offsets_[static_cast<std::size_t>(k) + 1]
                                : block_sets_[b].size();
    return std::pair<const Child*, const Child*>(
        block_sets_[b].data() + offsets_[static_cast<std::size_t>(k)], block_sets_[b].data() + end);
  }

  // The responsibilities' log-sum-exp per child i over the parents s' that hold it: cmax_[i] =
  // max log(w_s' L_is'), csum_[i] = sum exp(log(w_s' L_is') - cmax_[i]) in parent order
  // (deterministic). Each child's term becomes exp(log(w_s L_is) - cmax_[i]), so r_is is
  // term / csum_[i] (eq. 8). The exponentials run in parallel; the max and the sums, in order.
  void normalisers() {
    const double neg_inf = -std::numeric_limits<double>::infinity();
    cmax_.assign(comps_.size(), neg_inf);
    for (const auto& set : block_sets_)
      for (const Child& c : set)
        cmax_[static_cast<std::size_t>(c.i)] =
            std::max(cmax_[static_cast<std::size_t>(c.i)], c.term);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, block_sets_.size(), 4),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t b = r.begin(); b < r.end(); ++b)
                          for (Child& c : block_sets_[b])
                            c.term = std::exp(c.term - cmax_[static_cast<std::size_t>(c.i)]);
                      });
    csum_.assign(comps_.size(), 0.0);
    for (const auto& set : block_sets_)
      for (const Child& c : set)
        csum_[static_cast<std::size_t>(c.i)] += c.term;
  }

  // Parent k merged with its children (eq. 10, 29, 30) into `out`, but for its covariance: the
  // merged covariance of eq. 10 is returned (set_conditioned stores it).
  Matrix3d merge_children(Index k, Component& out) const {
    const Components& comps = comps_;
    const Component& ps = comps[static_cast<std::size_t>(parents_[static_cast<std::size_t>(k)])];
    double ws = 0.0;
    Vector3d sum_mu = Vector3d::Zero();
    Matrix3d sum_cov = Matrix3d::Zero();
    Vector3d resultant = Vector3d::Zero();
    double sum_spread = 0.0;
    const auto [first, last] = set_range(k);
    for (const Child* c = first; c != last; ++c) {
      const auto ui = static_cast<std::size_t>(c->i);
      const double ris = c->term / csum_[ui];  // eq. 8
      const Component& ci = comps[ui];
      const double a = ris * ci.w;       // r_is w_i (proportional to r_is w_i |P| of eq. 29-30)
      const Vector3d d = ci.mu - ps.mu;  // centred at the old parent mean for precision
      ws += a;
      sum_mu += a * d;
      sum_cov += a * (ci.cov + d * d.transpose());
      const Vector3d axis = ci.axis.dot(ps.axis) < 0.0 ? Vector3d(-ci.axis) : ci.axis;
      resultant += a * axis;
      sum_spread += a * ci.spread;
    }
    const Vector3d shift = sum_mu / ws;
    out.w = ws;              // eq. 10
    out.mu = ps.mu + shift;  // eq. 10
    const double len = resultant.norm();
    const double rho = std::min(len / ws, 1.0);
    if (len > 0.0) {
      out.axis = resultant / len;                          // eq. 29
      out.spread = sum_spread / ws - 2.0 * std::log(rho);  // eq. 30
    } else {
      out.axis = ps.axis;  // opposite axes cancelled exactly: maximal spread
      out.spread = sum_spread / ws + 2.0 * std::log(1e8);
    }
    return sum_cov / ws - shift * shift.transpose();  // eq. 10
  }

  const Components& comps_;
  const HemParams& p_;
  const double n_points_, abs_floor_;
  std::vector<Index> parents_;
  std::vector<Index> others_;  // the components that are not parents, in index order
  Index np_ = 0;
  Eigen::Matrix3Xf centers_;   // the others' means
  std::vector<float> radius_;  // per parent: the search radius of its children
  float cell_ = 1.0f;
  std::optional<detail::NeighborGrid> grid_;
  mutable std::once_flag tree_once_;
  mutable std::optional<KdTree> tree_storage_;
  std::vector<std::vector<Child>> block_sets_;
  std::vector<std::size_t> offsets_;
  std::vector<double> cmax_, csum_;
};

}  // namespace

namespace hem_detail {

Components cluster_level(const Components& comps, const HemParams& p, std::uint64_t level_seed,
                         double n_points, double abs_floor) {
  return MergeLevel(comps, p, n_points, abs_floor).run(level_seed);
}

}  // namespace hem_detail

}  // namespace scanbench::algorithms
