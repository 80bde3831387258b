#pragma once
// Procedural ground-truth shapes that need no files. Every shape is a closed, consistently
// oriented triangle mesh (TriangleMesh::is_closed_and_oriented() holds, signed_volume() > 0):
// patches are sampled on shared boundary samples and welded by exact coordinate equality, so the
// sharp edges of the cube, the fandisk-like block and the ripple are genuine creases: one vertex
// shared by faces with distinct normals, not duplicated vertices.
//
// Dimensions are in model units (every metric of scanbench is then reported as a fraction of the
// shape's bounding-box diagonal). Every parameter struct declares its parameters once (params.h);
// out-of-range values are rejected by params_from_json with a ParamError. The make_* functions
// check their arguments again and throw ParamError for values outside the declared ranges.
#include "scanbench/core/params.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench {

/// Sphere of radius `radius` centred at the origin, as a "cube sphere": the six faces of the cube
/// [-1, 1]^3, each an n x n grid with the equal-angle map c = tan(pi/4 * (2 i / n - 1)), projected
/// radially onto the sphere. 12 n^2 triangles; the edge length varies by less than a factor 1.5.
struct SphereParams {
  double radius = 1.0;
  int resolution = 32;
  static void declare(ParamDeclarer<SphereParams>& d) {
    d.real("radius", &SphereParams::radius, Range::above(0.0), "model", "sphere radius");
    d.integer("resolution", &SphereParams::resolution, Range::closed(1, 1024), "",
              "grid cells per cube-face side (12 n^2 triangles)");
  }
};
TriangleMesh make_sphere(const SphereParams& p);

/// Ring torus about the z axis: ((R + r cos v) cos u, (R + r cos v) sin u, r sin v) for
/// u, v in [0, 2 pi), R = major_radius > r = minor_radius > 0, sampled on a uniform
/// major_segments x minor_segments grid (2 * major * minor triangles).
struct TorusParams {
  double major_radius = 1.0;
  double minor_radius = 0.35;
  int major_segments = 96;
  int minor_segments = 48;
  static void declare(ParamDeclarer<TorusParams>& d) {
    d.real("major_radius", &TorusParams::major_radius, Range::above(0.0), "model",
           "distance from the z axis to the tube centre R");
    d.real("minor_radius", &TorusParams::minor_radius, Range::above(0.0), "model",
           "tube radius r (must be smaller than major_radius)");
    d.integer("major_segments", &TorusParams::major_segments, Range::closed(3, 8192), "",
              "segments around the z axis");
    d.integer("minor_segments", &TorusParams::minor_segments, Range::closed(3, 8192), "",
              "segments around the tube");
  }
};
TriangleMesh make_torus(const TorusParams& p);

/// Axis-aligned cube [-size/2, size/2]^3 with 12 sharp edges and 8 corners; each face is an
/// n x n grid of squares split into two triangles (12 n^2 triangles).
struct CubeParams {
  double size = 1.0;
  int resolution = 16;
  static void declare(ParamDeclarer<CubeParams>& d) {
    d.real("size", &CubeParams::size, Range::above(0.0), "model", "edge length");
    d.integer("resolution", &CubeParams::resolution, Range::closed(1, 2048), "",
              "grid cells per cube edge");
  }
};
TriangleMesh make_cube(const CubeParams& p);

/// A square plate: the box [-size/2, size/2]^2 x [-thickness/2, thickness/2], closed. Thinner than
/// the noise of a scan it stands for a plane (GPF Fig. 4 and Fig. 18, first row), with a solid's
/// ground truth (its two faces are one surface to within the thickness).
struct PlateParams {
  double size = 1.0;
  double thickness = 0.01;
  int resolution = 16;
  static void declare(ParamDeclarer<PlateParams>& d) {
    d.real("size", &PlateParams::size, Range::above(0.0), "model", "edge length of the square");
    d.real("thickness", &PlateParams::thickness, Range::above(0.0), "model",
           "thickness (at most the size)");
    d.integer("resolution", &PlateParams::resolution, Range::closed(1, 2048), "",
              "grid cells per edge (the thickness too)");
  }
};
TriangleMesh make_plate(const PlateParams& p);

/// A fandisk-like block: the profile below extruded along y over [-depth/2, depth/2], with flat
/// end caps. The profile is the region {(x, z): -1 <= x <= 1, 0 <= z <= top(x)} where the top
/// runs, from right to left:
///   - a vertical wall x = 1 from z = 0 up to z = 0.9 - rho,
///   - a quarter-circle fillet of radius rho = fillet_radius centred at (1 - rho, 0.9 - rho), which
///     blends the wall into the top tangentially (the smooth blend: G1, no crease),
///   - a flat top z = 0.9 from x = 1 - rho to x = 0.1,
///   - a ramp up to (-0.3, 1.2) (a concave crease at x = 0.1, a convex one at x = -0.3),
///   - a flat top z = 1.2 to x = -1 and the vertical wall x = -1 down to z = 0.
/// Every other edge (the bottom, the end caps, the top-left edge) is a sharp 90-degree crease.
/// The profile is sampled with about `resolution` segments per model unit along every piece
/// (at least 8 segments on the fillet), and so are the extrusion and the cap columns.
struct FandiskBlockParams {
  double depth = 1.0;
  double fillet_radius = 0.3;
  int resolution = 40;
  static void declare(ParamDeclarer<FandiskBlockParams>& d) {
    d.real("depth", &FandiskBlockParams::depth, Range::above(0.0), "model",
           "extrusion length along y");
    d.real("fillet_radius", &FandiskBlockParams::fillet_radius, Range::closed(0.05, 0.6), "model",
           "radius of the cylindrical fillet between the right wall and the top");
    d.integer("resolution", &FandiskBlockParams::resolution, Range::closed(2, 2000), "",
              "segments per model unit");
  }
};
TriangleMesh make_fandisk_block(const FandiskBlockParams& p);

/// The radially symmetric ripple of the CLOP paper (Preiner et al. 2014, Fig. 12(a)): a height
/// field with sharp ridges of various angles, curved trenches and a conic apex. The paper gives no
/// formula; scanbench defines it as
///   f(r) = A(r) * (2 s(r))^2,  s(r) = r/lambda - floor(r/lambda) - 1/2,  lambda = radius /
///   ripples, A(r) = amplitude * (1 - taper * r / radius),
/// over the disk r <= radius. So f has sharp circular ridges at r = k lambda (k = 0 is the conic
/// apex, k = ripples the outer rim), where the slope jumps from +4A/lambda to -4A/lambda (the
/// ridge opening angle widens outwards as A decreases), and smooth parabolic trenches of height 0
/// at r = (k + 1/2) lambda. The solid is closed by a cylindrical side wall at r = radius and a flat
/// bottom at z = -base. The mesh is polar: `rings_per_ripple` rings per period (so every ridge is
/// a ring of mesh edges, i.e. a true crease up to chordal error) and `sectors` sectors.
/// The noise that grows with the angle in the paper's figure is a scanner setting, not geometry.
struct RippleParams {
  double radius = 1.0;
  int ripples = 4;
  double amplitude = 0.15;
  double taper = 0.6;
  double base = 0.2;
  int rings_per_ripple = 16;
  int sectors = 256;
  static void declare(ParamDeclarer<RippleParams>& d) {
    d.real("radius", &RippleParams::radius, Range::above(0.0), "model", "disk radius");
    d.integer("ripples", &RippleParams::ripples, Range::closed(1, 256), "",
              "number of ripple periods between the apex and the rim");
    d.real("amplitude", &RippleParams::amplitude, Range::above(0.0), "model",
           "ridge height A at the centre");
    d.real("taper", &RippleParams::taper, Range::half_open(0.0, 1.0), "",
           "relative decrease of the ridge height from the centre to the rim");
    d.real("base", &RippleParams::base, Range::above(0.0), "model",
           "depth of the flat bottom below the trenches (z = -base)");
    d.integer("rings_per_ripple", &RippleParams::rings_per_ripple, Range::closed(2, 4096), "",
              "mesh rings per ripple period");
    d.integer("sectors", &RippleParams::sectors, Range::closed(3, 65536), "",
              "mesh sectors around the axis");
  }
};
/// The ripple height f(r) defined above (r >= 0), for tests and ground-truth checks.
double ripple_height(const RippleParams& p, double r);
TriangleMesh make_ripple(const RippleParams& p);

/// Merges vertices with exactly equal coordinates (no tolerance; -0 equals +0), keeps the first
/// occurrence's order and reindexes the faces. Faces whose corners coincide keep their repeated
/// indices (count_degenerate_faces() reports them); nothing is dropped. Used for STL files.
/// Throws InputError for face indices out of range.
TriangleMesh weld_coincident_vertices(const TriangleMesh& mesh);

}  // namespace scanbench
