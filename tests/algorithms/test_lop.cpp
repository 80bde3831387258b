// LOP / WLOP and their shared kernels against brute-force oracles and geometric properties.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <set>
#include <vector>

#include "fixtures.h"
#include "input_checks.h"
#include "lop/projection_kernels.h"
#include "scanbench/algorithms/lop/lop.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/kdtree.h"
#include "scanbench/core/rng.h"
#include "spatial/compact.h"
#include "spatial/mixture_index.h"
#include "spatial/simd_exp.h"

namespace scanbench::algorithms {
namespace {

using fixtures::mean_radial_error;
using fixtures::noisy_sphere;

// Coefficient of variation of nearest-neighbour distances (brute force).
double nn_cv(const Eigen::Matrix3Xf& p) {
  const Eigen::Index n = p.cols();
  std::vector<double> d(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    float best = std::numeric_limits<float>::infinity();
    for (Eigen::Index j = 0; j < n; ++j) {
      if (j != i) best = std::min(best, (p.col(i) - p.col(j)).squaredNorm());
    }
    d[static_cast<std::size_t>(i)] = std::sqrt(static_cast<double>(best));
  }
  double mean = 0.0;
  for (double x : d)
    mean += x;
  mean /= static_cast<double>(n);
  double var = 0.0;
  for (double x : d)
    var += (x - mean) * (x - mean);
  return std::sqrt(var / static_cast<double>(n)) / mean;
}

double theta_d(double r, double h) {
  return std::exp(-16.0 * r * r / (h * h));
}
double alpha_d(double r, double h) {
  const double rc = std::max(r, 0.01 * h);
  return theta_d(rc, h) / rc;
}

TEST(ProjectionKernels, ThetaAndAlpha) {
  const float h = 0.3f;
  EXPECT_FLOAT_EQ(kernels::theta(0.0f, h), 1.0f);
  EXPECT_NEAR(kernels::theta(h, h), std::exp(-16.0), 1e-9);
  EXPECT_NEAR(kernels::theta(h / 4, h), std::exp(-1.0), 1e-6);
  EXPECT_NEAR(kernels::alpha(0.1f, h), theta_d(0.1, h) / 0.1, 1e-4);
  // Clamped below at 0.01 h.
  EXPECT_FLOAT_EQ(kernels::alpha(0.0f, h), kernels::alpha(0.01f * h, h));
  EXPECT_FLOAT_EQ(kernels::alpha(1e-7f, h), kernels::alpha(0.01f * h, h));
}

// The kernels against brute-force sums over every point (no support cut).
class KernelOracle : public ::testing::Test {
 protected:
  void SetUp() override {
    cloud_ = noisy_sphere(1500, 1.0f, 0.03f, 11);
    particles_ = kernels::initial_particles(cloud_.positions, 400, 5, 0.0f);
  }
  PointCloud cloud_;
  Eigen::Matrix3Xf particles_;
  const float h_ = 0.35f;
};

TEST_F(KernelOracle, DensityWeightsMatchBruteForce) {
  const auto& p = cloud_.positions;
  const detail::NeighborGrid grid = kernels::query_grid(p, h_);
  const Eigen::VectorXf v = kernels::density_weights(grid, p, h_, h_);
  ASSERT_EQ(v.size(), p.cols());
  for (Eigen::Index j = 0; j < p.cols(); j += 7) {
    double ref = 1.0;
    for (Eigen::Index k = 0; k < p.cols(); ++k) {
      if (k != j) ref += theta_d((p.col(j) - p.col(k)).cast<double>().norm(), h_);
    }
    EXPECT_NEAR(v[j], ref, 1e-5 * ref) << "point " << j;
  }
}

TEST_F(KernelOracle, L2MeanMatchesBruteForceWeightedMean) {
  const auto& p = cloud_.positions;
  const KdTree tree(p);
  kernels::Scratch s;
  for (Eigen::Index i = 0; i < particles_.cols(); i += 5) {
    const Eigen::Vector3f q = particles_.col(i) * 1.02f;  // off the samples
    Eigen::Vector3d num = Eigen::Vector3d::Zero();
    double den = 0.0;
    for (Eigen::Index j = 0; j < p.cols(); ++j) {
      const double t = theta_d((p.col(j) - q).cast<double>().norm(), h_);
      num += t * p.col(j).cast<double>();
      den += t;
    }
    const Eigen::Vector3f got = kernels::l2_mean(q, p, tree, h_, s);
    EXPECT_LT((got.cast<double>() - num / den).norm(), 2e-6) << "particle " << i;
  }
}

TEST_F(KernelOracle, AttractionMatchesBruteForceWithDensityWeights) {
  const auto& p = cloud_.positions;
  const KdTree tree(p);
  const detail::NeighborGrid grid = kernels::query_grid(p, h_);
  const Eigen::VectorXf inv_v = kernels::density_weights(grid, p, h_, h_).cwiseInverse();
  kernels::Scratch s;
  for (int weighted = 0; weighted < 2; ++weighted) {
    const Eigen::VectorXf none;
    for (Eigen::Index i = 0; i < particles_.cols(); i += 5) {
      const Eigen::Vector3f q = particles_.col(i) * 0.97f;
      Eigen::Vector3d num = Eigen::Vector3d::Zero();
      double den = 0.0;
      for (Eigen::Index j = 0; j < p.cols(); ++j) {
        double a = alpha_d((p.col(j) - q).cast<double>().norm(), h_);
        if (weighted) a *= inv_v[j];
        num += a * p.col(j).cast<double>();
        den += a;
      }
      const Eigen::Vector3f got = kernels::attraction(q, p, tree, weighted ? inv_v : none, h_, s);
      EXPECT_LT((got.cast<double>() - num / den).norm(), 2e-6) << "particle " << i;
    }
  }
}

TEST_F(KernelOracle, RepulsionMatchesBruteForceWithCutoff) {
  const auto& q = particles_;
  const KdTree tree(q);
  const detail::NeighborGrid grid = kernels::query_grid(q, h_);
  const Eigen::VectorXf w = kernels::density_weights(grid, q, h_, h_);
  kernels::Scratch s;
  for (const float cutoff : {h_, 0.5f * h_}) {
    for (Eigen::Index i = 0; i < q.cols(); i += 3) {
      Eigen::Vector3d num = Eigen::Vector3d::Zero();
      double den = 0.0;
      for (Eigen::Index k = 0; k < q.cols(); ++k) {
        const Eigen::Vector3d d = (q.col(i) - q.col(k)).cast<double>();
        if (k == i || d.norm() > cutoff) continue;
        const double b = alpha_d(d.norm(), h_) * w[k];
        num += b * d;
        den += b;
      }
      const Eigen::Vector3d ref = den > 0 ? Eigen::Vector3d(num / den) : Eigen::Vector3d::Zero();
      const Eigen::Vector3f got = kernels::repulsion(i, q, tree, w, h_, cutoff, s);
      EXPECT_LT((got.cast<double>() - ref).norm(), 1e-5) << "particle " << i;
    }
  }
}

// The cell-batched kernels equal the per-particle kernels up to float summation order, on grids
// of both cell sides query_grid() takes (radius / 2 and radius).
TEST_F(KernelOracle, BatchedKernelsEqualPerParticleKernels) {
  const auto& p = cloud_.positions;
  const KdTree tree(p);
  const KdTree qtree(particles_);
  // Cutoff h/2 as in CLOP section 8: the density is cut too.
  const float cutoff = 0.5f * h_;
  for (const float side : {0.5f, 1.0f}) {
    SCOPED_TRACE(side);
    detail::NeighborGrid grid(p, side * h_);
    const Eigen::VectorXf inv_v = kernels::density_weights(grid, p, h_, h_).cwiseInverse();
    detail::NeighborGrid qgrid(particles_, side * cutoff);
    const Eigen::VectorXf w = kernels::density_weights(qgrid, particles_, h_, cutoff);
    for (Eigen::Index i = 0; i < particles_.cols(); ++i) {
      double ref = 1.0;
      for (Eigen::Index k = 0; k < particles_.cols(); ++k) {
        const double d = (particles_.col(i) - particles_.col(k)).cast<double>().norm();
        if (k != i && d <= cutoff) ref += theta_d(d, h_);
      }
      EXPECT_NEAR(w[i], ref, 1e-5 * ref) << "particle " << i;
    }
    const Eigen::Matrix3Xf l2 = kernels::l2_means(particles_, grid, h_);
    grid.set_weights(inv_v);
    const Eigen::Matrix3Xf f1 = kernels::attractions(particles_, grid, h_);
    qgrid.set_weights(w);
    const Eigen::Matrix3Xf f2 = kernels::repulsions(particles_, qgrid, h_, cutoff);
    kernels::Scratch s;
    for (Eigen::Index i = 0; i < particles_.cols(); ++i) {
      const Eigen::Vector3f q = particles_.col(i);
      EXPECT_LT((l2.col(i) - kernels::l2_mean(q, p, tree, h_, s)).norm(), 1e-6f);
      EXPECT_LT((f1.col(i) - kernels::attraction(q, p, tree, inv_v, h_, s)).norm(), 1e-6f);
      EXPECT_LT((f2.col(i) - kernels::repulsion(i, particles_, qtree, w, h_, cutoff, s)).norm(),
                1e-6f);
    }
  }
}

// query_grid() takes cells of radius / 2 from kDenseOccupancy points per occupied cell of side
// radius, else cells of radius; the order of `rank` within a cell is kept either way.
TEST(ProjectionKernels, QueryGridCellsFollowTheOccupancy) {
  const PointCloud c = noisy_sphere(4000, 1.0f, 0.0f, 21);
  const Eigen::Matrix3Xf& pts = c.positions;
  for (const float radius : {0.02f, 0.05f, 0.1f, 0.2f, 0.4f, 0.8f}) {
    SCOPED_TRACE(radius);
    const detail::NeighborGrid coarse(pts, radius);
    const bool dense = static_cast<double>(pts.cols()) >=
                       kernels::kDenseOccupancy * static_cast<double>(coarse.cells());
    std::vector<Eigen::Index> rank(static_cast<std::size_t>(pts.cols()));
    for (std::size_t i = 0; i < rank.size(); ++i)
      rank[i] = static_cast<Eigen::Index>(rank.size() - 1 - i);
    const detail::NeighborGrid g = kernels::query_grid(pts, radius, &rank);
    EXPECT_EQ(g.cell(), dense ? 0.5f * radius : radius);
    const detail::NeighborGrid ref(pts, g.cell(), &rank);
    ASSERT_EQ(g.size(), ref.size());
    for (Eigen::Index k = 0; k < g.size(); ++k)
      ASSERT_EQ(g.index(k), ref.index(k));
  }
  // Both sides occur over these radii (4000 points on the unit sphere: a point or two per cell of
  // side 0.02, over a hundred per cell of side 0.8).
  EXPECT_EQ(kernels::query_grid(pts, 0.02f).cell(), 0.02f);
  EXPECT_EQ(kernels::query_grid(pts, 0.8f).cell(), 0.4f);
}

// Queries off the grid (outside its bounding box, in empty cells) and coinciding points. The
// cells radius/8 make the grid's box too large for the dense cell table (per-column table),
// radius/32 its columns too (binary searches); the others use the dense table.
TEST(NeighborGrid, RangesHoldEveryPointWithinTheRadius) {
  const PointCloud c = noisy_sphere(800, 1.0f, 0.05f, 9);
  Eigen::Matrix3Xf pts = c.positions;
  pts.col(5) = pts.col(4);  // a duplicate
  const float radius = 0.3f;
  for (const float cell : {radius / 2, radius, radius / 3, radius / 8, radius / 32}) {
    const detail::NeighborGrid grid(pts, cell);
    Eigen::Matrix3Xf queries(3, 60);
    for (Eigen::Index i = 0; i < 60; ++i)
      queries.col(i) = pts.col(i * 13) * (0.5f + 0.03f * static_cast<float>(i));
    for (const bool self : {false, true}) {
      const Eigen::Matrix3Xf& qs = self ? pts : queries;
      std::vector<int> count(static_cast<std::size_t>(qs.cols()), 0);
      grid.for_each_query(
          qs, radius, self,
          [&](Eigen::Index i, Eigen::Index pos, const detail::GridRange* r, std::size_t n) {
            std::vector<char> seen(static_cast<std::size_t>(pts.cols()), 0);
            for (std::size_t k = 0; k < n; ++k) {
              for (Eigen::Index t = r[k].begin; t < r[k].end; ++t) {
                ASSERT_FALSE(seen[static_cast<std::size_t>(grid.index(t))]);
                seen[static_cast<std::size_t>(grid.index(t))] = 1;
              }
            }
            if (self) {
              ASSERT_EQ(grid.index(pos), i);
            }
            for (Eigen::Index j = 0; j < pts.cols(); ++j) {
              if ((pts.col(j) - qs.col(i)).norm() <= radius) {
                EXPECT_TRUE(seen[static_cast<std::size_t>(j)]) << "query " << i << " point " << j;
              }
            }
            ++count[static_cast<std::size_t>(i)];
          });
      for (const int k : count)
        EXPECT_EQ(k, 1);
    }
  }
}

// A batch of queries gives each query exactly the ranges it gets alone: in a batch the windows
// of the neighbour columns slide along z from one query cell to the next; alone they are found
// by searches. Every lookup (dense table, per-column table, binary search); the surface of a
// sphere has columns of many consecutive occupied cells at the finer cells.
TEST(NeighborGrid, BatchQueriesGetTheRangesOfSingleQueries) {
  const PointCloud c = noisy_sphere(1500, 1.0f, 0.05f, 17);
  const Eigen::Matrix3Xf& pts = c.positions;
  const float radius = 0.2f;
  using Ranges = std::vector<std::pair<Eigen::Index, Eigen::Index>>;
  const auto collect = [&](const detail::NeighborGrid& grid, const Eigen::Matrix3Xf& qs) {
    std::vector<Ranges> out(static_cast<std::size_t>(qs.cols()));
    grid.for_each_query(
        qs, radius, false,
        [&](Eigen::Index i, Eigen::Index, const detail::GridRange* r, std::size_t n) {
          for (std::size_t k = 0; k < n; ++k)
            out[static_cast<std::size_t>(i)].emplace_back(r[k].begin, r[k].end);
        });
    return out;
  };
  // The points themselves, and points scaled by 0.4 ... 1.6 (inside, off and beyond the grid:
  // query cells outside it in z next to cells inside it).
  Eigen::Matrix3Xf scaled = pts;
  for (Eigen::Index i = 0; i < pts.cols(); ++i)
    scaled.col(i) *= 0.4f + 1.2f * static_cast<float>(i) / static_cast<float>(pts.cols());
  for (const float cell : {radius / 2, radius / 8, radius / 32}) {
    const detail::NeighborGrid grid(pts, cell);
    for (const Eigen::Matrix3Xf* qs : std::array<const Eigen::Matrix3Xf*, 2>{&pts, &scaled}) {
      const std::vector<Ranges> batch = collect(grid, *qs);
      std::size_t nonempty = 0;
      for (Eigen::Index i = 0; i < qs->cols(); ++i) {
        const Eigen::Matrix3Xf one = qs->col(i);
        const std::vector<Ranges> alone = collect(grid, one);
        ASSERT_EQ(batch[static_cast<std::size_t>(i)], alone[0])
            << "cell " << cell << " query " << i;
        nonempty += alone[0].empty() ? 0 : 1;
      }
      if (qs == &pts) {
        EXPECT_EQ(nonempty, static_cast<std::size_t>(pts.cols()));
      }
    }
  }
}

// The radix sort of cell keys equals std::sort of the (key, index) pairs: repeated keys, compact
// keys (few digit passes) and keys using all 64 bits.
// One query at a time, anywhere (outside the box, in empty cells), for the three cell lookups
// (dense table, per-column table, binary search).
TEST(NeighborGrid, RangesNearHoldEveryPointWithinTheRadius) {
  const PointCloud c = noisy_sphere(600, 1.0f, 0.05f, 4);
  const Eigen::Matrix3Xf& pts = c.positions;
  const float radius = 0.25f;
  std::vector<detail::GridRange> ranges;
  for (const float cell : {radius / 2, radius, radius / 8, radius / 32}) {
    const detail::NeighborGrid grid(pts, cell);
    for (int i = 0; i < 80; ++i) {
      const Eigen::Vector3f q =
          pts.col(i * 7) * (0.3f + 0.025f * static_cast<float>(i)) + Eigen::Vector3f(0.01f, 0, 0);
      grid.ranges_near(q, radius, ranges);
      std::vector<char> seen(static_cast<std::size_t>(pts.cols()), 0);
      for (const auto& r : ranges) {
        for (Eigen::Index t = r.begin; t < r.end; ++t) {
          ASSERT_FALSE(seen[static_cast<std::size_t>(grid.index(t))]);
          seen[static_cast<std::size_t>(grid.index(t))] = 1;
        }
      }
      for (Eigen::Index j = 0; j < pts.cols(); ++j) {
        if ((pts.col(j) - q).norm() <= radius) {
          EXPECT_TRUE(seen[static_cast<std::size_t>(j)]) << "query " << i << " point " << j;
        }
      }
    }
  }
}

// compact_within against a brute force in double: every position of the range within the bound
// and none beyond it (points within 1e-5 relative of the bound may fall either side: the float
// distance rounds as the build fuses it), in increasing order after the m already written, for
// ranges of every length modulo 16 and starts off the packet grid, with nothing written past
// the room it asks for.
TEST(NeighborGrid, CompactWithinKeepsThePointsWithinTheBound) {
  const PointCloud c = noisy_sphere(700, 1.0f, 0.05f, 9);
  const detail::NeighborGrid grid(c.positions, 0.2f);
  const float r2 = 0.01f;
  constexpr std::size_t kGuard = 0x5eed;
  std::size_t kept = 0, dropped = 0;
  for (const std::size_t b : {std::size_t{0}, std::size_t{3}, std::size_t{17}, std::size_t{250}})
    for (std::size_t len = 0; len <= 40; ++len) {
      const std::size_t e = std::min<std::size_t>(b + len, static_cast<std::size_t>(grid.size()));
      // Near the range's points: the bound cuts through it.
      const Eigen::Vector3f q = Eigen::Vector3f(grid.x()[b + 2], grid.y()[b + 2], grid.z()[b + 2]) +
                                Eigen::Vector3f(0.02f, -0.01f, 0.03f);
      const std::size_t m0 = len % 5;  // positions already written
      std::vector<std::size_t> out(m0 + (e - b) + detail::kCompactSlack + 8, kGuard);
      const std::size_t m =
          detail::compact_within(grid.x(), grid.y(), grid.z(), b, e, q, r2, out.data(), m0);
      for (std::size_t i = 0; i < m0; ++i)
        EXPECT_EQ(out[i], kGuard);
      for (std::size_t i = m0 + (e - b) + detail::kCompactSlack; i < out.size(); ++i)
        EXPECT_EQ(out[i], kGuard);
      std::vector<std::size_t> want, borderline;
      for (std::size_t t = b; t < e; ++t) {
        const double dx = double(grid.x()[t]) - q.x(), dy = double(grid.y()[t]) - q.y(),
                     dz = double(grid.z()[t]) - q.z();
        const double d2 = dx * dx + dy * dy + dz * dz;
        if (std::abs(d2 - r2) <= 1e-5 * r2)
          borderline.push_back(t);
        else if (d2 < r2)
          want.push_back(t);
      }
      std::vector<std::size_t> got(out.begin() + static_cast<std::ptrdiff_t>(m0),
                                   out.begin() + static_cast<std::ptrdiff_t>(m));
      ASSERT_TRUE(std::is_sorted(got.begin(), got.end()));
      std::vector<std::size_t> got_clear;
      for (const std::size_t t : got)
        if (std::find(borderline.begin(), borderline.end(), t) == borderline.end())
          got_clear.push_back(t);
      EXPECT_EQ(got_clear, want) << "range " << b << " .. " << e;
      kept += want.size();
      dropped += (e - b) - want.size() - borderline.size();
    }
  EXPECT_GT(kept, 100u);  // the bound cuts through the ranges
  EXPECT_GT(dropped, 100u);
}

// The exact-quotient layout with fine cells (mixture.hem level 0): every point is in cell
// floor((p - lo) / width) computed in double, the points of a cell are ordered by (fine cell,
// index), the fine cells partition their cell and their centre and reach bound their points,
// and cells_in_box visits exactly the occupied cells of a box in increasing order. The cloud sits
// far from the origin (coordinates with few fraction bits).
TEST(NeighborGrid, ExactQuotientCellsWithFineCells) {
  Rng rng(23);
  Eigen::Matrix3Xf pts(3, 3000);
  for (Eigen::Index i = 0; i < pts.cols(); ++i)
    for (int d = 0; d < 3; ++d)
      pts(d, i) = 1000.0f + static_cast<float>(rng.uniform());
  pts.col(7) = pts.col(3);  // a duplicate
  const double width = 0.0937;
  const Eigen::Vector3d lo = pts.rowwise().minCoeff().cast<double>();
  for (const int split : {1, 3}) {
    detail::GridLayout layout;
    layout.cell = width;
    layout.rule = detail::GridLayout::Rule::kExactQuotient;
    layout.split = split;
    const detail::NeighborGrid grid(pts, layout);
    ASSERT_EQ(grid.size(), pts.cols());
    std::vector<char> seen(static_cast<std::size_t>(pts.cols()), 0);
    for (std::size_t c = 0; c < grid.cells(); ++c) {
      const auto coords = grid.cell_coords(c);
      const auto [f0, f1] = grid.fine_cells(c);
      ASSERT_LT(f0, f1);
      EXPECT_EQ(grid.fine_range(f0).begin, grid.cell_range(c).begin);
      EXPECT_EQ(grid.fine_range(f1 - 1).end, grid.cell_range(c).end);
      if (c > 0) {
        EXPECT_LT(grid.cell_coords(c - 1), coords);
      }
      for (std::size_t f = f0; f < f1; ++f) {
        const detail::GridRange r = grid.fine_range(f);
        ASSERT_LT(r.begin, r.end);
        if (f > f0) {
          EXPECT_EQ(grid.fine_range(f - 1).end, r.begin);
        }
        std::array<std::int64_t, 3> fine{};
        for (Eigen::Index k = r.begin; k < r.end; ++k) {
          const Eigen::Index i = grid.index(k);
          seen[static_cast<std::size_t>(i)] = 1;
          const Eigen::Vector3f p(grid.x()[k], grid.y()[k], grid.z()[k]);
          ASSERT_EQ(p, Eigen::Vector3f(pts.col(i)));
          if (k > r.begin) {
            EXPECT_LT(grid.index(k - 1), i);
          }
          std::array<std::int64_t, 3> fk{};
          for (int d = 0; d < 3; ++d) {
            const double t = static_cast<double>(p[d]) - lo[d];
            const auto u = static_cast<std::size_t>(d);
            EXPECT_EQ(coords[u], static_cast<std::int64_t>(std::floor(t / width)));
            fk[u] = static_cast<std::int64_t>(std::floor(t / (width / split))) - coords[u] * split;
            EXPECT_GE(t, grid.cell_corner(coords)[d] - lo[d] - 1e-9 * width);
          }
          if (k == r.begin) fine = fk;
          EXPECT_EQ(fk, fine);
          if (split > 1) {
            EXPECT_LE((p - grid.fine_centre(f)).norm(), grid.fine_reach(f));
          }
        }
        if (f > f0) {  // fine cells of a cell in (x, y, z) order
          const Eigen::Index prev = grid.fine_range(f - 1).begin;
          std::array<std::int64_t, 3> fp{};
          for (int d = 0; d < 3; ++d) {
            const double t = static_cast<double>(pts(d, grid.index(prev))) - lo[d];
            fp[static_cast<std::size_t>(d)] =
                static_cast<std::int64_t>(std::floor(t / (width / split))) -
                coords[static_cast<std::size_t>(d)] * split;
          }
          EXPECT_LT(fp, fine);
        }
      }
    }
    EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), pts.cols());
    // cells_in_box against a filter of every cell.
    const detail::NeighborGrid::Coords a{2, 1, 3}, b{5, 9, 4};
    std::vector<std::size_t> got, want;
    grid.cells_in_box(a, b, [&](std::size_t c) { got.push_back(c); });
    for (std::size_t c = 0; c < grid.cells(); ++c) {
      const auto k = grid.cell_coords(c);
      if (k[0] >= a[0] && k[0] <= b[0] && k[1] >= a[1] && k[1] <= b[1] && k[2] >= a[2] &&
          k[2] <= b[2])
        want.push_back(c);
    }
    EXPECT_FALSE(want.empty());
    EXPECT_EQ(got, want);
    // coords_of a point: the coordinates of the cell that holds it.
    for (std::size_t c = 0; c < grid.cells(); ++c)
      for (Eigen::Index k = grid.cell_range(c).begin; k < grid.cell_range(c).end; ++k)
        if (grid.index(k) % 97 == 0) {
          EXPECT_EQ(grid.coords_of(pts.col(grid.index(k))), grid.cell_coords(c));
        }
  }
}

// The grid gather of CLOP's attraction returns exactly the components within their class radius
// (brute force over the same size classes), each once, with their squared distances.
TEST(MixtureGrid, GathersExactlyTheComponentsWithinTheirClassRadius) {
  Rng rng(17);
  GaussianMixture m;
  m.resize(700);
  for (Eigen::Index s = 0; s < m.size(); ++s) {
    m.weights[s] = 1.0f / 700.0f;
    for (int d = 0; d < 3; ++d)
      m.means(d, s) = static_cast<float>(rng.uniform());
    // Sizes over four orders of magnitude: several size classes.
    const double scale = std::pow(10.0, -5.0 + 4.0 * rng.uniform());
    Eigen::Matrix3d a;
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k)
        a(r, k) = rng.normal(0.0, 1.0);
    m.set_covariance(
        s, (scale * (a * a.transpose() + 0.1 * Eigen::Matrix3d::Identity())).cast<float>());
  }
  const double v = 1e-4;
  const auto classes = detail::size_classes(m, v);
  ASSERT_GT(classes.size(), 2u);
  const detail::MixtureGrid grid(m, v, v);
  const std::vector<float> radii = grid.radii(v);
  ASSERT_EQ(radii.size(), classes.size());
  std::vector<detail::GridRange> scratch;
  std::vector<Eigen::Index> ids;
  std::vector<float> d2;
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3f q(static_cast<float>(1.4 * rng.uniform() - 0.2),
                            static_cast<float>(1.4 * rng.uniform() - 0.2),
                            static_cast<float>(1.4 * rng.uniform() - 0.2));
    ids.clear();
    d2.clear();
    grid.gather(q, radii, scratch, ids, d2);
    ASSERT_EQ(d2.size(), ids.size());
    for (std::size_t k = 0; k < ids.size(); ++k)  // bit for bit: CLOP's shells depend on it
      EXPECT_EQ(d2[k], (m.means.col(ids[k]) - q).squaredNorm());
    std::vector<Eigen::Index> want;
    for (std::size_t c = 0; c < classes.size(); ++c) {
      EXPECT_EQ(radii[c], detail::class_radius(classes[c].bound, v));
      for (const Eigen::Index s : classes[c].ids) {
        const Eigen::Vector3f d = m.means.col(s) - q;
        if (d.x() * d.x() + d.y() * d.y() + d.z() * d.z() <= radii[c] * radii[c]) want.push_back(s);
      }
    }
    std::vector<Eigen::Index> got = ids;
    std::sort(got.begin(), got.end());
    std::sort(want.begin(), want.end());
    EXPECT_EQ(got, want) << "query " << i;
  }
}

// The kernels' exp is Eigen's generic pexp_float (Eigen's pexp on SSE, AVX and AVX2) with a
// faster ldexp: bit-identical on the range it is used, at the widest packet of the build. Eigen
// 3.4's AVX-512 pexp<Packet16f> is another Cephes variant (one-step ln 2 reduction), so the
// oracle is pexp_float itself: every ISA path then computes the same exp per lane.
TEST(ProjectionKernels, FastExpIsBitIdenticalToEigenExp) {
  using Packet = Eigen::internal::packet_traits<float>::type;
  constexpr int lanes = Eigen::internal::packet_traits<float>::size;
  float in[lanes], a[lanes], b[lanes];
  int mismatches = 0;
  for (int k = -870000; k <= 880000; k += lanes) {
    for (int l = 0; l < lanes; ++l)
      in[l] = static_cast<float>(k + l) * 1e-4f + 1.37e-5f * static_cast<float>(l);
    const Packet x = Eigen::internal::ploadu<Packet>(in);
    Eigen::internal::pstoreu(a, detail::fast_pexp(x));
    Eigen::internal::pstoreu(b, Eigen::internal::pexp_float(x));
    for (int l = 0; l < lanes; ++l)
      mismatches += std::memcmp(&a[l], &b[l], sizeof(float)) != 0;
  }
  EXPECT_EQ(mismatches, 0);
  Eigen::internal::pstoreu(a, detail::fast_pexp(Eigen::internal::pset1<Packet>(-200.0f)));
  EXPECT_EQ(a[0], 0.0f);
}

// The repulsion kernels' 1 / sqrt (a bit-level guess and two Newton steps, IEEE operations
// only, so no processor's own approximation enters): within 5e-7 relative of the exact value
// over the positive normal floats, at every packet width the build has.
template <class Packet>
double worst_rsqrt_error() {
  constexpr int lanes = Eigen::internal::unpacket_traits<Packet>::size;
  float in[lanes], out[lanes];
  double worst = 0.0;
  for (int k = 0; k < 200000; k += lanes) {
    for (int l = 0; l < lanes; ++l)  // log-spaced over [1e-36, 1e36], odd mantissas
      in[l] = static_cast<float>(std::pow(10.0, -36.0 + 72.0 * (k + l) / 200000.0));
    Eigen::internal::pstoreu(out, detail::fast_prsqrt(Eigen::internal::ploadu<Packet>(in)));
    for (int l = 0; l < lanes; ++l) {
      const double exact = 1.0 / std::sqrt(static_cast<double>(in[l]));
      worst = std::max(worst, std::abs(static_cast<double>(out[l]) - exact) / exact);
    }
  }
  return worst;
}

TEST(ProjectionKernels, FastRsqrtIsWithinTheBoundAtEveryWidth) {
  EXPECT_LT(worst_rsqrt_error<Eigen::internal::Packet4f>(), 5e-7);
#ifdef EIGEN_VECTORIZE_AVX
  EXPECT_LT(worst_rsqrt_error<Eigen::internal::Packet8f>(), 5e-7);
#endif
#ifdef EIGEN_VECTORIZE_AVX512
  EXPECT_LT(worst_rsqrt_error<Eigen::internal::Packet16f>(), 5e-7);
#endif
}

// exp and 1 / sqrt give the same bits per lane at every packet width of the build (simd_exp.h):
// the ISA paths of the kernels then differ only in the order of their sums.
template <class Packet>
void per_lane_values(std::vector<float>& e, std::vector<float>& r) {
  constexpr int lanes = Eigen::internal::unpacket_traits<Packet>::size;
  constexpr int n = 1 << 16;
  e.resize(n);
  r.resize(n);
  float in[lanes];
  for (int k = 0; k < n; k += lanes) {
    for (int l = 0; l < lanes; ++l)
      in[l] = -40.0f * static_cast<float>(k + l) / n + 1e-3f;
    const auto x = Eigen::internal::ploadu<Packet>(in);
    Eigen::internal::pstoreu(e.data() + k, detail::fast_pexp(x));
    Eigen::internal::pstoreu(r.data() + k, detail::fast_prsqrt(Eigen::internal::pmul(x, x)));
  }
}

TEST(ProjectionKernels, ExpAndRsqrtAreTheSameAtEveryWidth) {
  std::vector<float> e4, r4, e, r;
  per_lane_values<Eigen::internal::Packet4f>(e4, r4);
#ifdef EIGEN_VECTORIZE_AVX
  per_lane_values<Eigen::internal::Packet8f>(e, r);
  EXPECT_EQ(std::memcmp(e.data(), e4.data(), e.size() * sizeof(float)), 0);
  EXPECT_EQ(std::memcmp(r.data(), r4.data(), r.size() * sizeof(float)), 0);
#endif
#ifdef EIGEN_VECTORIZE_AVX512
  per_lane_values<Eigen::internal::Packet16f>(e, r);
  EXPECT_EQ(std::memcmp(e.data(), e4.data(), e.size() * sizeof(float)), 0);
  EXPECT_EQ(std::memcmp(r.data(), r4.data(), r.size() * sizeof(float)), 0);
#endif
}

TEST(ProjectionKernels, ParticleCount) {
  EXPECT_EQ(kernels::particle_count(0.5, 1000, "x"), 500);
  EXPECT_EQ(kernels::particle_count(1.0, 1000, "x"), 1000);
  EXPECT_EQ(kernels::particle_count(1e-9, 1000, "x"), 1);
  EXPECT_EQ(kernels::particle_count(250, 1000, "x"), 250);
  EXPECT_EQ(kernels::particle_count(2500, 1000, "x"), 2500);
  EXPECT_THROW(kernels::particle_count(2.5, 1000, "x"), ParamError);
  EXPECT_THROW(kernels::particle_count(0.0, 1000, "x"), ParamError);
  EXPECT_THROW(kernels::particle_count(-3, 1000, "x"), ParamError);
}

TEST(ProjectionKernels, InitialParticlesAreASeededSubset) {
  const PointCloud c = noisy_sphere(500, 1.0f, 0.0f, 3);
  const Eigen::Matrix3Xf a = kernels::initial_particles(c.positions, 200, 42, 0.0f);
  const Eigen::Matrix3Xf b = kernels::initial_particles(c.positions, 200, 42, 0.0f);
  const Eigen::Matrix3Xf other = kernels::initial_particles(c.positions, 200, 43, 0.0f);
  ASSERT_EQ(a.cols(), 200);
  EXPECT_TRUE(a == b);
  EXPECT_FALSE(a == other);
  // Distinct input points, in input order.
  std::vector<Eigen::Index> src;
  for (Eigen::Index i = 0; i < a.cols(); ++i) {
    Eigen::Index found = -1;
    for (Eigen::Index j = 0; j < c.size(); ++j) {
      if (c.positions.col(j) == a.col(i)) found = j;
    }
    ASSERT_GE(found, 0);
    src.push_back(found);
  }
  EXPECT_TRUE(std::is_sorted(src.begin(), src.end()));
  EXPECT_EQ(std::set<Eigen::Index>(src.begin(), src.end()).size(), src.size());

  // Upsampling: every point at least twice, copies jittered.
  const Eigen::Matrix3Xf up = kernels::initial_particles(c.positions, 1234, 7, 0.01f);
  ASSERT_EQ(up.cols(), 1234);
  int exact = 0;
  for (Eigen::Index i = 0; i < up.cols(); ++i) {
    for (Eigen::Index j = 0; j < c.size(); ++j) {
      if (c.positions.col(j) == up.col(i)) ++exact;
    }
  }
  EXPECT_EQ(exact, 500);
  EXPECT_THROW(kernels::initial_particles(Eigen::Matrix3Xf(3, 0), 5, 1, 0.0f), InputError);
}

class NoisySphere : public ::testing::Test {
 protected:
  void SetUp() override {
    cloud_ = noisy_sphere(6000, 1.0f, 0.015f, 2024);
    params_.h = 0.1;
    params_.particles = 0.25;
    params_.iterations = 10;
  }
  // The initial particle subset the operators start from (same seed stream).
  Eigen::Matrix3Xf start(std::uint64_t seed) const {
    const Eigen::Index m = kernels::particle_count(params_.particles, cloud_.size(), "t");
    return kernels::initial_particles(cloud_.positions, m, derive_seed(seed, "particles"), 0.0f);
  }
  PointCloud cloud_;
  LopParams params_;
};

TEST_F(NoisySphere, LopAndWlopMovePointsTowardTheSurface) {
  const Eigen::Matrix3Xf q0 = start(1);
  const double before = mean_radial_error(q0, 1.0);
  EXPECT_GT(before, 0.010);
  for (const bool weighted : {false, true}) {
    RunContext ctx(1);
    const PointCloud out = weighted ? wlop(cloud_, params_, ctx) : lop(cloud_, params_, ctx);
    ASSERT_EQ(out.size(), q0.cols());
    out.validate("test");
    const double after = mean_radial_error(out.positions, 1.0);
    EXPECT_LT(after, 0.8 * before) << (weighted ? "wlop" : "lop");
    EXPECT_TRUE(ctx.phase_seconds().count("attraction"));
    EXPECT_TRUE(ctx.phase_seconds().count("repulsion"));
    EXPECT_EQ(ctx.phase_seconds().count("density"), weighted ? 1u : 0u);
  }
}

// Interleaved repulsion (CLOP paper sec. 8, run for WLOP too in sec. 10.2): the kernels by hand,
// F2 computed in the first and last of three update steps and reused in the second, give WLOP's
// interleaved output bit for bit; with two update steps both compute it, so interleaving changes
// nothing.
TEST_F(NoisySphere, WlopInterleavedRepulsionReusesF2EverySecondStep) {
  LopParams p = params_;
  p.iterations = 4;
  p.interleave = true;
  const float diag = detail::checked_diagonal(cloud_, "t");
  const float h = static_cast<float>(p.h) * diag;
  const Eigen::Matrix3Xf& pts = cloud_.positions;
  detail::NeighborGrid grid = kernels::query_grid(pts, h);
  const Eigen::Index m = kernels::particle_count(p.particles, cloud_.size(), "t");
  Eigen::Matrix3Xf q = kernels::initial_particles(pts, m, derive_seed(3, "particles"), 0.01f * h);
  q = kernels::l2_means(q, grid, h);
  grid.set_weights(kernels::density_weights(grid, pts, h, h).cwiseInverse());
  const float mu = static_cast<float>(p.mu);
  Eigen::Matrix3Xf rep;
  for (int t = 0; t < 3; ++t) {
    Eigen::Matrix3Xf next = kernels::attractions(q, grid, h);
    if (t != 1) {
      detail::NeighborGrid pg = kernels::query_grid(q, h);
      pg.set_weights(kernels::density_weights(pg, q, h, h));
      rep = kernels::repulsions(q, pg, h, h);
    }
    next += mu * rep;
    q.swap(next);
  }
  RunContext ctx(3, 2);
  const PointCloud got = wlop(cloud_, p, ctx);
  EXPECT_TRUE(got.positions == q);
  p.interleave = false;
  RunContext ctx2(3, 2);
  EXPECT_FALSE(wlop(cloud_, p, ctx2).positions == q);

  // Two update steps: the first and the last recompute F2 either way.
  p.iterations = 3;
  RunContext c1(3, 1), c2(3, 1);
  const PointCloud plain = wlop(cloud_, p, c1);
  p.interleave = true;
  EXPECT_TRUE(wlop(cloud_, p, c2).positions == plain.positions);
}

TEST_F(NoisySphere, WlopLowersRegularityCv) {
  const Eigen::Matrix3Xf q0 = start(1);
  RunContext ctx(1);
  const PointCloud out = wlop(cloud_, params_, ctx);
  const double cv0 = nn_cv(q0);
  const double cv1 = nn_cv(out.positions);
  EXPECT_LT(cv1, 0.6 * cv0) << "input subset cv " << cv0 << ", wlop cv " << cv1;
}

TEST_F(NoisySphere, BitIdenticalForOneAndTwoThreads) {
  for (const bool weighted : {false, true}) {
    PointCloud a, b;
    {
      RunContext ctx(9, 1);
      a = weighted ? wlop(cloud_, params_, ctx) : lop(cloud_, params_, ctx);
    }
    {
      RunContext ctx(9, 2);
      b = weighted ? wlop(cloud_, params_, ctx) : lop(cloud_, params_, ctx);
    }
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(0, std::memcmp(a.positions.data(), b.positions.data(),
                             sizeof(float) * static_cast<std::size_t>(a.positions.size())));
  }
}

TEST_F(NoisySphere, UpsamplingGivesMoreParticlesThanPoints) {
  const PointCloud small = noisy_sphere(800, 1.0f, 0.01f, 5);
  LopParams p;
  p.h = 0.08;
  p.particles = 2000;
  p.iterations = 6;
  RunContext ctx(3);
  const PointCloud out = wlop(small, p, ctx);
  ASSERT_EQ(out.size(), 2000);
  out.validate("test");
  EXPECT_LT(mean_radial_error(out.positions, 1.0), 0.02);
}

// The whole operator against a double-precision brute-force transcription of CLOP paper eq. 2-6
// and 25 (every pair within the support radius h, no kd-tree). The support matters: a particle
// with no other particle within h gets F2 = 0, whereas normalising the far tails would move it by
// an arbitrary amount.
Eigen::Matrix3Xd brute_force_wlop(const Eigen::Matrix3Xd& p, Eigen::Matrix3Xd q, double h,
                                  double mu, int iterations, bool weighted) {
  const Eigen::Index n = p.cols(), m = q.cols();
  Eigen::VectorXd v = Eigen::VectorXd::Ones(n);
  if (weighted) {
    for (Eigen::Index j = 0; j < n; ++j)
      for (Eigen::Index k = 0; k < n; ++k)
        if (k != j) v[j] += theta_d((p.col(j) - p.col(k)).norm(), h);
  }
  Eigen::Matrix3Xd next(3, m);
  for (Eigen::Index i = 0; i < m; ++i) {  // eq. 2
    Eigen::Vector3d num = Eigen::Vector3d::Zero();
    double den = 0;
    for (Eigen::Index j = 0; j < n; ++j) {
      const double t = theta_d((p.col(j) - q.col(i)).norm(), h);
      num += t * p.col(j);
      den += t;
    }
    next.col(i) = num / den;
  }
  q = next;
  for (int it = 1; it < iterations; ++it) {
    Eigen::VectorXd w = Eigen::VectorXd::Ones(m);
    if (weighted) {
      for (Eigen::Index i = 0; i < m; ++i)
        for (Eigen::Index k = 0; k < m; ++k)
          if (k != i) w[i] += theta_d((q.col(i) - q.col(k)).norm(), h);
    }
    for (Eigen::Index i = 0; i < m; ++i) {
      Eigen::Vector3d num = Eigen::Vector3d::Zero();
      double den = 0;
      for (Eigen::Index j = 0; j < n; ++j) {
        const double a = alpha_d((p.col(j) - q.col(i)).norm(), h) / v[j];
        num += a * p.col(j);
        den += a;
      }
      Eigen::Vector3d rep = Eigen::Vector3d::Zero();
      double rden = 0;
      for (Eigen::Index k = 0; k < m; ++k) {
        if (k == i || (q.col(i) - q.col(k)).norm() > h) continue;
        const double b = alpha_d((q.col(i) - q.col(k)).norm(), h) * w[k];
        rep += b * (q.col(i) - q.col(k));
        rden += b;
      }
      next.col(i) = num / den;
      if (rden > 0) next.col(i) += mu * rep / rden;
    }
    q = next;
  }
  return q;
}

TEST(Lop, MatchesBruteForceTranscriptionOfThePaper) {
  const PointCloud c = noisy_sphere(400, 1.0f, 0.02f, 8);
  LopParams p;
  p.h = 0.12;
  p.mu = 0.4;
  p.iterations = 5;
  p.particles = 0.3;
  const double h = p.h * static_cast<double>(c.bbox().diagonal());
  for (const int iters : {1, 2, 5}) {
    for (const bool weighted : {false, true}) {
      p.iterations = iters;
      RunContext ctx(4);
      const PointCloud got = weighted ? wlop(c, p, ctx) : lop(c, p, ctx);
      const Eigen::Matrix3Xf q0 = kernels::initial_particles(
          c.positions, kernels::particle_count(p.particles, c.size(), "t"),
          ctx.stream_seed("particles"), 0.0f);
      const Eigen::Matrix3Xd ref = brute_force_wlop(c.positions.cast<double>(), q0.cast<double>(),
                                                    h, p.mu, p.iterations, weighted);
      ASSERT_EQ(got.size(), ref.cols());
      const double err = (got.positions.cast<double>() - ref).colwise().norm().maxCoeff();
      EXPECT_LT(err, 1e-4) << (weighted ? "wlop" : "lop") << " iterations " << iters;
    }
  }
}

TEST(Lop, BadInputThrowsTypedErrors) {
  RunContext ctx(1);
  LopParams p;
  PointCloud empty;
  EXPECT_THROW(lop(empty, p, ctx), InputError);
  PointCloud nan = noisy_sphere(50, 1.0f, 0.0f, 1);
  nan.positions(1, 7) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(wlop(nan, p, ctx), InputError);
  PointCloud same;
  same.positions = Eigen::Matrix3Xf::Ones(3, 10);
  EXPECT_THROW(wlop(same, p, ctx), InputError);
  p.particles = 12.5;
  EXPECT_THROW(wlop(noisy_sphere(50, 1.0f, 0.0f, 1), p, ctx), ParamError);
  // The declared schema rejects out-of-range values by name.
  Json bad = {{"mu", 0.5}};
  EXPECT_THROW(params_from_json<LopParams>(bad, "resample.lop"), ParamError);
  bad = {{"h", 0.0}};
  EXPECT_THROW(params_from_json<LopParams>(bad, "resample.lop"), ParamError);
}

}  // namespace
}  // namespace scanbench::algorithms
