#include "scanbench/core/procedural.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <vector>

#include "scanbench/core/errors.h"

namespace scanbench {

namespace {

// Collects triangles; vertices with exactly equal float coordinates become one vertex, so patches
// that evaluate the same formula on a shared boundary are stitched without tolerances.
class MeshBuilder {
 public:
  int vertex(const Eigen::Vector3d& p) {
    const std::array<float, 3> key{static_cast<float>(p.x()), static_cast<float>(p.y()),
                                   static_cast<float>(p.z())};
    auto [it, inserted] = index_.try_emplace(key, static_cast<int>(points_.size()));
    if (inserted) points_.push_back(key);
    return it->second;
  }
  void triangle(int a, int b, int c) {
    if (a == b || b == c || a == c) return;  // collapsed cell at a pole or apex
    faces_.push_back({a, b, c});
  }
  /// Quad a b c d, counter-clockwise seen from outside.
  void quad(int a, int b, int c, int d) {
    triangle(a, b, c);
    triangle(a, c, d);
  }
  /// Grid patch over (i, j) in [0, nu] x [0, nv]; cells are oriented along d/di x d/dj, or the
  /// opposite when `flip`.
  void patch(int nu, int nv, bool flip, const std::function<Eigen::Vector3d(int, int)>& at) {
    std::vector<int> ids(static_cast<std::size_t>((nu + 1) * (nv + 1)));
    for (int i = 0; i <= nu; ++i)
      for (int j = 0; j <= nv; ++j)
        ids[static_cast<std::size_t>(i * (nv + 1) + j)] = vertex(at(i, j));
    auto id = [&](int i, int j) { return ids[static_cast<std::size_t>(i * (nv + 1) + j)]; };
    for (int i = 0; i < nu; ++i) {
      for (int j = 0; j < nv; ++j) {
        if (flip) {
          quad(id(i, j), id(i, j + 1), id(i + 1, j + 1), id(i + 1, j));
        } else {
          quad(id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
        }
      }
    }
  }
  TriangleMesh build() const {
    TriangleMesh m;
    m.vertices.resize(3, static_cast<Eigen::Index>(points_.size()));
    for (std::size_t v = 0; v < points_.size(); ++v)
      m.vertices.col(static_cast<Eigen::Index>(v)) << points_[v][0], points_[v][1], points_[v][2];
    m.faces.resize(3, static_cast<Eigen::Index>(faces_.size()));
    for (std::size_t f = 0; f < faces_.size(); ++f)
      m.faces.col(static_cast<Eigen::Index>(f)) << faces_[f][0], faces_[f][1], faces_[f][2];
    return m;
  }

 private:
  std::map<std::array<float, 3>, int> index_;
  std::vector<std::array<float, 3>> points_;
  std::vector<std::array<int, 3>> faces_;
};

// a + (b - a) k / n, returning a and b exactly at the ends (shared boundaries must match bitwise).
double lerp_exact(double a, double b, int k, int n) {
  if (k == 0) return a;
  if (k == n) return b;
  return a + (b - a) * static_cast<double>(k) / static_cast<double>(n);
}

// cos/sin of 2 pi j / n with j taken modulo n, so the seam closes exactly.
Eigen::Vector2d unit_circle(int j, int n) {
  const double t = 2.0 * M_PI * static_cast<double>(j % n) / static_cast<double>(n);
  return {std::cos(t), std::sin(t)};
}

void require(bool ok, const char* shape, const std::string& what) {
  if (!ok) throw ParamError(fmt::format("dataset {}: {}", shape, what));
}

// The six faces of the lattice {0..n}^3 boundary, mapped through `map` (integer lattice point ->
// position). Face (axis a, side s) uses the two other axes in cyclic order, whose cross product is
// +e_a, so the minus sides are flipped.
void cube_lattice(MeshBuilder& b, int n, const std::function<Eigen::Vector3d(int, int, int)>& map) {
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      const int u_axis = (axis + 1) % 3;
      const int v_axis = (axis + 2) % 3;
      b.patch(n, n, side == 0, [&](int i, int j) {
        std::array<int, 3> l{};
        l[static_cast<std::size_t>(axis)] = side * n;
        l[static_cast<std::size_t>(u_axis)] = i;
        l[static_cast<std::size_t>(v_axis)] = j;
        return map(l[0], l[1], l[2]);
      });
    }
  }
}

// Samples the segment a -> b with about `per_unit` segments per unit length (at least `min_n`),
// appending every point but a. `a` by value: callers pass out.back(), which the first emplace_back
// may reallocate (AddressSanitizer found the heap-use-after-free of a reference here).
void append_segment(std::vector<Eigen::Vector2d>& out, const Eigen::Vector2d a,
                    const Eigen::Vector2d& b, int per_unit, int min_n) {
  const int n = std::max(min_n, static_cast<int>(std::ceil((b - a).norm() * per_unit)));
  for (int k = 1; k <= n; ++k)
    out.emplace_back(lerp_exact(a.x(), b.x(), k, n), lerp_exact(a.y(), b.y(), k, n));
}

// The closed box [-half, half] (per axis) on the n^3 lattice of cube_lattice: the cube and the plate.
TriangleMesh centred_box(const Eigen::Vector3d& half, int n) {
  MeshBuilder b;
  cube_lattice(b, n, [&](int x, int y, int z) {
    return Eigen::Vector3d(lerp_exact(-half.x(), half.x(), x, n),
                           lerp_exact(-half.y(), half.y(), y, n),
                           lerp_exact(-half.z(), half.z(), z, n));
  });
  return b.build();
}

}  // namespace

TriangleMesh make_sphere(const SphereParams& p) {
  require(p.radius > 0.0 && std::isfinite(p.radius), "sphere", "radius must be positive");
  require(p.resolution >= 1 && p.resolution <= 1024, "sphere", "resolution must be in [1, 1024]");
  const int n = p.resolution;
  std::vector<double> c(static_cast<std::size_t>(n + 1));
  for (int i = 0; i <= n; ++i) {
    // Equal-angle map; the ends are exactly -1 and 1 so opposite faces share their edges.
    c[static_cast<std::size_t>(i)] =
        i == 0 ? -1.0 : (i == n ? 1.0 : std::tan(M_PI / 4.0 * (2.0 * i / n - 1.0)));
  }
  MeshBuilder b;
  cube_lattice(b, n, [&](int x, int y, int z) {
    const Eigen::Vector3d q(c[static_cast<std::size_t>(x)], c[static_cast<std::size_t>(y)],
                            c[static_cast<std::size_t>(z)]);
    return Eigen::Vector3d(p.radius * q.normalized());
  });
  return b.build();
}

TriangleMesh make_torus(const TorusParams& p) {
  require(p.minor_radius > 0.0 && p.major_radius > p.minor_radius, "torus",
          fmt::format("need 0 < minor_radius < major_radius, got {} and {}", p.minor_radius,
                      p.major_radius));
  require(p.major_segments >= 3 && p.minor_segments >= 3, "torus",
          "major_segments and minor_segments must be at least 3");
  MeshBuilder b;
  // d/du x d/dv points away from the tube centre: no flip.
  b.patch(p.major_segments, p.minor_segments, false, [&](int i, int j) {
    const Eigen::Vector2d u = unit_circle(i, p.major_segments);
    const Eigen::Vector2d v = unit_circle(j, p.minor_segments);
    const double ring = p.major_radius + p.minor_radius * v.x();
    return Eigen::Vector3d(ring * u.x(), ring * u.y(), p.minor_radius * v.y());
  });
  return b.build();
}

TriangleMesh make_cube(const CubeParams& p) {
  require(p.size > 0.0 && std::isfinite(p.size), "cube", "size must be positive");
  require(p.resolution >= 1 && p.resolution <= 2048, "cube", "resolution must be in [1, 2048]");
  const double h = 0.5 * p.size;
  return centred_box({h, h, h}, p.resolution);
}

TriangleMesh make_plate(const PlateParams& p) {
  require(p.size > 0.0 && std::isfinite(p.size), "plate", "size must be positive");
  require(p.thickness > 0.0 && std::isfinite(p.thickness) && p.thickness <= p.size, "plate",
          "thickness must be positive and at most the size");
  require(p.resolution >= 1 && p.resolution <= 2048, "plate", "resolution must be in [1, 2048]");
  const double h = 0.5 * p.size;
  return centred_box({h, h, 0.5 * p.thickness}, p.resolution);
}

TriangleMesh make_fandisk_block(const FandiskBlockParams& p) {
  require(p.depth > 0.0 && std::isfinite(p.depth), "fandisk_block", "depth must be positive");
  require(p.fillet_radius >= 0.05 && p.fillet_radius <= 0.6, "fandisk_block",
          "fillet_radius must be in [0.05, 0.6]");
  require(p.resolution >= 2 && p.resolution <= 2000, "fandisk_block",
          "resolution must be in [2, 2000]");
  const int res = p.resolution;
  const double rho = p.fillet_radius;

  // Top profile from the right wall's top (x = 1) to the left wall's top (x = -1); x strictly
  // decreases along it, so the region under it is cut into columns for the end caps.
  std::vector<Eigen::Vector2d> top;
  top.emplace_back(1.0, 0.9 - rho);
  const int arc_n = std::max(8, static_cast<int>(std::ceil(0.5 * M_PI * rho * res)));
  for (int k = 1; k <= arc_n; ++k) {
    const double t = 0.5 * M_PI * k / arc_n;
    // Ends set exactly so the fillet meets the wall and the top without a gap.
    const double x = k == arc_n ? 1.0 - rho : (1.0 - rho) + rho * std::cos(t);
    const double z = k == arc_n ? 0.9 : (0.9 - rho) + rho * std::sin(t);
    top.emplace_back(x, z);
  }
  append_segment(top, top.back(), {0.1, 0.9}, res, 1);
  append_segment(top, top.back(), {-0.3, 1.2}, res, 1);
  append_segment(top, top.back(), {-1.0, 1.2}, res, 1);

  const int nu = static_cast<int>(top.size()) - 1;
  const int ny = std::max(1, static_cast<int>(std::ceil(p.depth * res)));
  const int nz = std::max(1, static_cast<int>(std::ceil(1.2 * res)));
  const double hd = 0.5 * p.depth;
  auto y_at = [&](int j) { return lerp_exact(-hd, hd, j, ny); };
  auto x_at = [&](int i) { return top[static_cast<std::size_t>(i)].x(); };
  auto z_top = [&](int i) { return top[static_cast<std::size_t>(i)].y(); };

  MeshBuilder b;
  // Orientation: (-x) x (+y) = -z, so the top (and every profile piece) is flipped outwards.
  b.patch(nu, ny, true, [&](int i, int j) { return Eigen::Vector3d(x_at(i), y_at(j), z_top(i)); });
  b.patch(nu, ny, false, [&](int i, int j) { return Eigen::Vector3d(x_at(i), y_at(j), 0.0); });
  // Walls: (+z) x (+y) = -x: the right wall (x = 1) is flipped, the left one is not.
  b.patch(nz, ny, true, [&](int k, int j) {
    return Eigen::Vector3d(x_at(0), y_at(j), lerp_exact(0.0, z_top(0), k, nz));
  });
  b.patch(nz, ny, false, [&](int k, int j) {
    return Eigen::Vector3d(x_at(nu), y_at(j), lerp_exact(0.0, z_top(nu), k, nz));
  });
  // Caps: columns under every profile sample; (-x) x (+z) = +y, so the y = -depth/2 cap flips.
  for (int side = 0; side < 2; ++side) {
    const double y = side == 0 ? y_at(0) : y_at(ny);
    b.patch(nu, nz, side == 0, [&](int i, int k) {
      return Eigen::Vector3d(x_at(i), y, lerp_exact(0.0, z_top(i), k, nz));
    });
  }
  return b.build();
}

double ripple_height(const RippleParams& p, double r) {
  const double lambda = p.radius / p.ripples;
  const double u = r / lambda;
  const double s = u - std::floor(u) - 0.5;
  const double amplitude = p.amplitude * (1.0 - p.taper * r / p.radius);
  return amplitude * 4.0 * s * s;
}

TriangleMesh make_ripple(const RippleParams& p) {
  require(p.radius > 0.0 && std::isfinite(p.radius), "ripple", "radius must be positive");
  require(p.amplitude > 0.0 && std::isfinite(p.amplitude), "ripple", "amplitude must be positive");
  require(p.taper >= 0.0 && p.taper < 1.0, "ripple", "taper must be in [0, 1)");
  require(p.base > 0.0 && std::isfinite(p.base), "ripple", "base must be positive");
  require(p.ripples >= 1 && p.rings_per_ripple >= 2 && p.sectors >= 3, "ripple",
          "need ripples >= 1, rings_per_ripple >= 2, sectors >= 3");
  const int nr = p.ripples * p.rings_per_ripple;
  const int ns = p.sectors;
  const double zb = -p.base;
  const double rim = ripple_height(p, p.radius);
  auto ring = [&](int i) { return lerp_exact(0.0, p.radius, i, nr); };
  // Wall rows: as many as the rim height needs at the radial ring spacing.
  const int nw = std::max(1, static_cast<int>(std::ceil((rim - zb) / (p.radius / nr))));

  MeshBuilder b;
  // Top: radial x tangential = +z (outwards); ring 0 collapses to the apex.
  b.patch(nr, ns, false, [&](int i, int j) {
    const Eigen::Vector2d c = unit_circle(j, ns);
    const double r = ring(i);
    return Eigen::Vector3d(r * c.x(), r * c.y(), i == nr ? rim : ripple_height(p, r));
  });
  // Side wall from the rim down: (-z) x tangential = +radial (outwards).
  b.patch(nw, ns, false, [&](int k, int j) {
    const Eigen::Vector2d c = unit_circle(j, ns);
    return Eigen::Vector3d(p.radius * c.x(), p.radius * c.y(), lerp_exact(rim, zb, k, nw));
  });
  // Bottom: +z from the same parametrisation, so flipped.
  b.patch(nr, ns, true, [&](int i, int j) {
    const Eigen::Vector2d c = unit_circle(j, ns);
    const double r = ring(i);
    return Eigen::Vector3d(r * c.x(), r * c.y(), zb);
  });
  return b.build();
}

TriangleMesh weld_coincident_vertices(const TriangleMesh& mesh) {
  std::map<std::array<float, 3>, int> index;
  std::vector<int> remap(static_cast<std::size_t>(mesh.num_vertices()));
  std::vector<Eigen::Index> kept;
  for (Eigen::Index v = 0; v < mesh.num_vertices(); ++v) {
    const std::array<float, 3> key{mesh.vertices(0, v), mesh.vertices(1, v), mesh.vertices(2, v)};
    auto [it, inserted] = index.try_emplace(key, static_cast<int>(kept.size()));
    if (inserted) kept.push_back(v);
    remap[static_cast<std::size_t>(v)] = it->second;
  }
  TriangleMesh out;
  out.vertices.resize(3, static_cast<Eigen::Index>(kept.size()));
  for (std::size_t k = 0; k < kept.size(); ++k)
    out.vertices.col(static_cast<Eigen::Index>(k)) = mesh.vertices.col(kept[k]);
  std::vector<Eigen::Vector3i> faces;
  faces.reserve(static_cast<std::size_t>(mesh.num_faces()));
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f) {
    Eigen::Vector3i t;
    for (int k = 0; k < 3; ++k) {
      const int v = mesh.faces(k, f);
      if (v < 0 || v >= mesh.num_vertices()) {
        throw InputError(
            fmt::format("weld: face {} refers to vertex {} of {}", f, v, mesh.num_vertices()));
      }
      t[k] = remap[static_cast<std::size_t>(v)];
    }
    faces.push_back(t);
  }
  out.faces.resize(3, static_cast<Eigen::Index>(faces.size()));
  for (std::size_t f = 0; f < faces.size(); ++f)
    out.faces.col(static_cast<Eigen::Index>(f)) = faces[f];
  return out;
}

}  // namespace scanbench
