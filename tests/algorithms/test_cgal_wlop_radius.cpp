// peer.cgal_wlop's kernel conversion: scanbench's h (theta = exp(-16 r^2/h^2)) reaches CGAL as
// neighbor_radius R = h/2 (CGAL's exp(-4 r^2/R^2) is then the same kernel), and CGAL sums only
// the points within R. Two tight clusters at distance d: at d = 0.7 h (beyond h/2) a particle
// of one cluster feels nothing of the other, at d = 0.4 h (within h/2) it is pulled toward it by
// about theta(d) = exp(-16 (0.4)^2) = 0.077 of the way. Passing R = h would pull the particles
// at d = 0.7 h by exp(-4 * 0.49) = 0.14 of the way; R = h/4 would not reach d = 0.4 h.
#include <gtest/gtest.h>

#include <cmath>

#include "scanbench/algorithms/peers/cgal_peers.h"
#include "scanbench/core/rng.h"

namespace scanbench::algorithms {
namespace {

// Clusters of 200 points (spread 1e-4) at x = 0 and x = d, and a far one that sets the diagonal
// to about 10.
PointCloud two_clusters(double d) {
  Rng rng(17);
  PointCloud c;
  c.positions.resize(3, 600);
  const Eigen::Vector3f centres[3] = {
      {0.0f, 0.0f, 0.0f}, {static_cast<float>(d), 0.0f, 0.0f}, {0.0f, 10.0f, 0.0f}};
  for (int i = 0; i < 600; ++i) {
    const Eigen::Vector3f jitter(static_cast<float>(rng.normal(0.0, 1e-4)),
                                 static_cast<float>(rng.normal(0.0, 1e-4)),
                                 static_cast<float>(rng.normal(0.0, 1e-4)));
    c.positions.col(i) = centres[i / 200] + jitter;
  }
  return c;
}

// Largest x-distance of a particle of the first two clusters from its own cluster's centre,
// as a fraction of d.
double largest_pull(const PointCloud& out, double d) {
  double worst = 0.0;
  for (Eigen::Index i = 0; i < out.size(); ++i) {
    const Eigen::Vector3f q = out.positions.col(i);
    if (q.y() > 5.0f) continue;  // the far cluster
    const double x = q.x();
    worst = std::max(worst, std::min(std::abs(x), std::abs(x - d)) / d);
  }
  return worst;
}

TEST(CgalWlopRadius, NeighbourRadiusIsHalfOfH) {
  const double d = 0.5;
  for (const double ratio : {0.7, 0.4}) {  // d / h
    const PointCloud in = two_clusters(d);
    const double diag = in.bbox().diagonal();
    CgalWlopParams p;
    p.h = d / ratio / diag;
    p.iterations = 1;
    p.particles = 0.5;
    RunContext ctx(5);
    const double pull = largest_pull(cgal_wlop(in, p, ctx), d);
    if (ratio > 0.5) {
      EXPECT_LT(pull, 0.01) << "d = " << ratio << " h: beyond R = h/2, no attraction";
    } else {
      EXPECT_GT(pull, 0.03) << "d = " << ratio << " h: within R = h/2, attracted";
      EXPECT_LT(pull, 0.15) << "d = " << ratio << " h";
    }
  }
}

}  // namespace
}  // namespace scanbench::algorithms
