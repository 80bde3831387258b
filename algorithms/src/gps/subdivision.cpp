#include "scanbench/algorithms/gps/subdivision.h"

#include <sys/resource.h>
#include <unistd.h>

#include <fmt/format.h>
#include <tbb/parallel_for.h>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "scanbench/core/errors.h"
#include "scanbench/core/radix_sort.h"

namespace scanbench::algorithms {

namespace {

// Corner/twin connectivity. Corner c of face f is half-edge v[c] -> v[next(c)].
struct Topology {
  int nv = 0, nf = 0, ne = 0;
  const PolygonFaces* faces = nullptr;
  std::vector<int> face_of;     // corner -> face
  std::vector<int> twin;        // corner -> opposite corner, -1 on the boundary
  std::vector<int> edge_of;     // corner -> edge
  std::vector<int> edge_first;  // edge -> its first corner
  std::vector<int> ring_off;    // vertex -> outgoing corners (ring_off[v] .. ring_off[v+1])
  std::vector<int> ring;        //   counter-clockwise; boundary vertices start at the boundary
  std::vector<std::uint8_t> boundary;  // vertex on the boundary

  int vert(int c) const { return faces->indices[c]; }
  int next(int c) const {
    const int f = face_of[c];
    return c + 1 == faces->offsets[f + 1] ? faces->offsets[f] : c + 1;
  }
  int prev(int c) const {
    const int f = face_of[c];
    return c == faces->offsets[f] ? faces->offsets[f + 1] - 1 : c - 1;
  }
  int target(int c) const { return vert(next(c)); }
  int valence(int v) const { return ring_off[v + 1] - ring_off[v]; }
  // The last neighbour of a boundary vertex (source of the incoming boundary half-edge).
  int last_boundary_neighbour(int v) const { return vert(prev(ring[ring_off[v + 1] - 1])); }
};

Topology build_topology(const PolygonFaces& faces, int nv, std::string_view where,
                        bool triangles_only) {
  Topology t;
  t.nv = nv;
  t.nf = faces.num_faces();
  t.faces = &faces;
  const int nc = static_cast<int>(faces.indices.size());
  if (faces.offsets.empty() || faces.offsets.back() != nc)
    throw InputError(fmt::format("{}: face offsets do not match the face indices", where));
  t.face_of.resize(nc);
  for (int f = 0; f < t.nf; ++f) {
    const int b = faces.offsets[f], e = faces.offsets[f + 1];
    if (e - b < 3)
      throw InputError(fmt::format("{}: face {} has {} vertices (at least 3)", where, f, e - b));
    if (triangles_only && e - b != 3)
      throw InputError(fmt::format(
          "{}: face {} has {} vertices; Loop subdivision takes triangles only", where, f, e - b));
    for (int c = b; c < e; ++c) {
      const int v = faces.indices[c];
      if (v < 0 || v >= nv)
        throw InputError(
            fmt::format("{}: face {} has vertex index {} outside [0, {})", where, f, v, nv));
      for (int c2 = b; c2 < c; ++c2)
        if (faces.indices[c2] == v)
          throw InputError(fmt::format("{}: face {} repeats vertex {}", where, f, v));
      t.face_of[c] = f;
    }
  }
  // Group the half-edges by undirected edge: one radix sort of (min, max) keys.
  struct Key {
    std::uint64_t key;
    int corner;
  };
  std::vector<Key> keys(nc);
  for (int c = 0; c < nc; ++c) {
    const auto a = static_cast<std::uint64_t>(t.vert(c)),
               b = static_cast<std::uint64_t>(t.target(c));
    keys[c] = {std::min(a, b) << 32 | std::max(a, b), c};
  }
  radix_sort(keys, [](const Key& k) { return k.key; });
  t.twin.assign(nc, -1);
  t.edge_of.resize(nc);
  std::vector<std::pair<int, int>> edges;  // (first corner, second corner or -1), sorted later
  for (int i = 0; i < nc;) {
    int j = i + 1;
    while (j < nc && keys[j].key == keys[i].key)
      ++j;
    if (j - i > 2)
      throw InputError(
          fmt::format("{}: face {}: edge ({}, {}) is shared by {} faces "
                      "(non-manifold)",
                      where, t.face_of[keys[i + 2].corner], t.vert(keys[i].corner),
                      t.target(keys[i].corner), j - i));
    int c0 = keys[i].corner, c1 = j - i == 2 ? keys[i + 1].corner : -1;
    if (c1 >= 0) {
      if (t.vert(c0) == t.vert(c1))
        throw InputError(fmt::format(
            "{}: face {}: edge ({}, {}) has the same direction in faces "
            "{} and {} (inconsistent orientation)",
            where, t.face_of[c1], t.vert(c0), t.target(c0), t.face_of[c0], t.face_of[c1]));
      t.twin[c0] = c1;
      t.twin[c1] = c0;
    }
    edges.emplace_back(std::min(c0, c1 < 0 ? c0 : c1), c1);
    i = j;
  }
  // Edge ids in the order of their first corner (face order), independent of the sort.
  std::sort(edges.begin(), edges.end());
  t.ne = static_cast<int>(edges.size());
  t.edge_first.resize(t.ne);
  for (int e = 0; e < t.ne; ++e) {
    const int c = edges[e].first;
    t.edge_first[e] = c;
    t.edge_of[c] = e;
    if (t.twin[c] >= 0) t.edge_of[t.twin[c]] = e;
  }
  // Outgoing corners per vertex, then ordered counter-clockwise by rot(c) = twin(prev(c)).
  t.ring_off.assign(nv + 1, 0);
  for (int c = 0; c < nc; ++c)
    ++t.ring_off[t.vert(c) + 1];
  for (int v = 0; v < nv; ++v)
    t.ring_off[v + 1] += t.ring_off[v];
  std::vector<int> unordered(nc), fill(t.ring_off.begin(), t.ring_off.end() - 1);
  for (int c = 0; c < nc; ++c)
    unordered[fill[t.vert(c)]++] = c;
  t.ring.resize(nc);
  t.boundary.assign(nv, 0);
  for (int v = 0; v < nv; ++v) {
    const int b = t.ring_off[v], e = t.ring_off[v + 1];
    if (b == e) continue;
    int start = unordered[b], starts = 0;
    for (int i = b; i < e; ++i)
      if (t.twin[unordered[i]] < 0) {
        start = unordered[i];
        ++starts;
      }
    if (starts > 1)
      throw InputError(
          fmt::format("{}: face {}: vertex {} joins {} separate fans of faces "
                      "(non-manifold vertex)",
                      where, t.face_of[start], v, starts));
    t.boundary[v] = starts == 1;
    int c = start, k = b;
    do {
      if (k == e) break;
      t.ring[k++] = c;
      const int p = t.twin[t.prev(c)];
      if (p < 0) break;
      c = p;
    } while (c != start);
    if (k != e)
      throw InputError(
          fmt::format("{}: face {}: vertex {} joins separate fans of faces "
                      "(non-manifold vertex)",
                      where, t.face_of[start], v));
  }
  return t;
}

// A sparse row-major operator: row r = sum over [off[r], off[r+1]) of w * value[col].
struct Stencil {
  std::vector<int> off{0};
  std::vector<int> col;
  std::vector<double> w;
  void push(int c, double weight) {
    col.push_back(c);
    w.push_back(weight);
  }
  void end_row() { off.push_back(static_cast<int>(col.size())); }
  // Merges repeated columns of the current row (Catmull-Clark vertices repeat in faces).
  void merge_row() {
    const int b = off.back(), e = static_cast<int>(col.size());
    std::vector<std::pair<int, double>> row;
    for (int i = b; i < e; ++i)
      row.emplace_back(col[i], w[i]);
    std::sort(row.begin(), row.end(),
              [](const auto& x, const auto& y) { return x.first < y.first; });
    col.resize(b);
    w.resize(b);
    for (std::size_t i = 0; i < row.size(); ++i) {
      if (i > 0 && row[i].first == col.back())
        w.back() += row[i].second;
      else
        push(row[i].first, row[i].second);
    }
    end_row();
  }
  int rows() const { return static_cast<int>(off.size()) - 1; }
};

double loop_beta(int n, LoopBeta kind) {
  if (kind == LoopBeta::Warren) return n == 3 ? 3.0 / 16.0 : 3.0 / (8.0 * n);
  const double a = 3.0 / 8.0 + 0.25 * std::cos(2.0 * std::numbers::pi / n);
  return (5.0 / 8.0 - a * a) / n;
}

void boundary_vertex_row(const Topology& t, int v, Stencil& s) {
  s.push(t.vert(t.next(t.ring[t.ring_off[v]])), 1.0 / 8.0);
  s.push(v, 6.0 / 8.0);
  s.push(t.last_boundary_neighbour(v), 1.0 / 8.0);
  s.end_row();
}

// One level of Loop: stencil rows (V vertex rows, then E edge rows) and the new faces.
void loop_level(const Topology& t, LoopBeta beta, Stencil& s, PolygonFaces& out) {
  for (int v = 0; v < t.nv; ++v) {
    const int n = t.valence(v);
    if (n == 0) {
      s.push(v, 1.0);
      s.end_row();
    } else if (t.boundary[v]) {
      boundary_vertex_row(t, v, s);
    } else {
      const double b = loop_beta(n, beta);
      s.push(v, 1.0 - n * b);
      for (int i = t.ring_off[v]; i < t.ring_off[v + 1]; ++i)
        s.push(t.target(t.ring[i]), b);
      s.end_row();
    }
  }
  for (int e = 0; e < t.ne; ++e) {
    const int c = t.edge_first[e], o = t.twin[c];
    if (o < 0) {
      s.push(t.vert(c), 0.5);
      s.push(t.target(c), 0.5);
    } else {
      s.push(t.vert(c), 3.0 / 8.0);
      s.push(t.target(c), 3.0 / 8.0);
      s.push(t.vert(t.prev(c)), 1.0 / 8.0);
      s.push(t.vert(t.prev(o)), 1.0 / 8.0);
    }
    s.end_row();
  }
  out = PolygonFaces{};
  out.offsets.reserve(4 * t.nf + 1);
  out.indices.reserve(12 * t.nf);
  const int V = t.nv;
  for (int f = 0; f < t.nf; ++f) {
    const int c0 = t.faces->offsets[f], c1 = c0 + 1, c2 = c0 + 2;
    const int a = t.vert(c0), b = t.vert(c1), c = t.vert(c2);
    const int ab = V + t.edge_of[c0], bc = V + t.edge_of[c1], ca = V + t.edge_of[c2];
    out.add({a, ab, ca});
    out.add({b, bc, ab});
    out.add({c, ca, bc});
    out.add({ab, bc, ca});
  }
}

// One level of Catmull-Clark: rows V vertices, E edges, F faces; the new quads.
void catmull_clark_level(const Topology& t, Stencil& s, PolygonFaces& out) {
  const auto& fo = t.faces->offsets;
  auto add_face_point = [&](int f, double weight) {
    const double w = weight / (fo[f + 1] - fo[f]);
    for (int c = fo[f]; c < fo[f + 1]; ++c)
      s.push(t.vert(c), w);
  };
  for (int v = 0; v < t.nv; ++v) {
    const int n = t.valence(v);
    if (n == 0) {
      s.push(v, 1.0);
      s.end_row();
    } else if (t.boundary[v]) {
      boundary_vertex_row(t, v, s);
    } else {
      // (Q + 2R + (n-3) v)/n, Q = mean face point, R = mean edge midpoint.
      const double nn = static_cast<double>(n) * n;
      s.push(v, (n - 3.0) / n + 1.0 / n);
      for (int i = t.ring_off[v]; i < t.ring_off[v + 1]; ++i) {
        const int c = t.ring[i];
        s.push(t.target(c), 1.0 / nn);
        add_face_point(t.face_of[c], 1.0 / nn);
      }
      s.merge_row();
    }
  }
  for (int e = 0; e < t.ne; ++e) {
    const int c = t.edge_first[e], o = t.twin[c];
    if (o < 0) {
      s.push(t.vert(c), 0.5);
      s.push(t.target(c), 0.5);
      s.end_row();
    } else {
      s.push(t.vert(c), 0.25);
      s.push(t.target(c), 0.25);
      add_face_point(t.face_of[c], 0.25);
      add_face_point(t.face_of[o], 0.25);
      s.merge_row();
    }
  }
  for (int f = 0; f < t.nf; ++f) {
    add_face_point(f, 1.0);
    s.end_row();
  }
  out = PolygonFaces{};
  const int V = t.nv, E = t.ne;
  out.offsets.reserve(t.faces->indices.size() + 1);
  out.indices.reserve(4 * t.faces->indices.size());
  for (int f = 0; f < t.nf; ++f)
    for (int c = fo[f]; c < fo[f + 1]; ++c)
      out.add({t.vert(c), V + t.edge_of[c], V + E + f, V + t.edge_of[t.prev(c)]});
}

template <int D>
void apply(const Stencil& s, const ValueMatrix<D>& in, ValueMatrix<D>& out) {
  out.resize(in.rows(), s.rows());
  tbb::parallel_for(tbb::blocked_range<int>(0, s.rows(), 4096), [&](const auto& r) {
    for (int i = r.begin(); i != r.end(); ++i) {
      Eigen::Matrix<double, D, 1> acc = Eigen::Matrix<double, D, 1>::Zero(in.rows());
      for (int k = s.off[i]; k < s.off[i + 1]; ++k)
        acc.noalias() += s.w[k] * in.col(s.col[k]);
      out.col(i) = acc;
    }
  });
}

std::size_t memory_limit_bytes() {
  rlimit rl{};
  std::size_t limit = 0;
  if (getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY)
    limit = static_cast<std::size_t>(rl.rlim_cur);
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  if (pages > 0 && page > 0) {
    const auto phys = static_cast<std::size_t>(pages) * static_cast<std::size_t>(page);
    if (limit == 0 || phys < limit) limit = phys;
  }
  return limit;
}

}  // namespace

void check_polygon_mesh(const PolygonFaces& faces, int num_vertices, bool triangles_only,
                        std::string_view where) {
  (void)build_topology(faces, num_vertices, where, triangles_only);
}

SubdivisionCounts subdivision_counts(const PolygonFaces& faces, int num_vertices, int levels,
                                     SubdivisionScheme scheme) {
  // Euler bookkeeping per level; edges from the half-edge count (boundary edges counted once).
  double V = num_vertices, F = faces.num_faces(), C = static_cast<double>(faces.indices.size());
  // Edges: E = (C + B)/2 with B boundary half-edges; B doubles per level. Bound B by C.
  double E = C;  // an upper bound (all boundary) is enough for a memory estimate
  for (int l = 0; l < levels; ++l) {
    if (scheme == SubdivisionScheme::Loop) {
      V += E;
      E = 2 * E + 3 * F;
      F *= 4;
      C = 3 * F;
    } else {
      V += E + F;
      E = 2 * E + C;
      F = C;
      C = 4 * F;
    }
  }
  return {V, F, C};
}

void check_subdivision_memory(const PolygonFaces& faces, int num_vertices, int levels,
                              SubdivisionScheme scheme, double bytes_per_vertex,
                              std::string_view where) {
  const SubdivisionCounts n = subdivision_counts(faces, num_vertices, levels, scheme);
  // Values in and out, stencil rows (~8 entries of 12 bytes), the corner tables of two levels
  // (indices, face, twin, edge, ring, sort keys: ~48 bytes per corner).
  const double bytes = n.vertices * (2 * bytes_per_vertex + 8 * 12 + 16) + n.corners * 48;
  const double limit = static_cast<double>(memory_limit_bytes());
  if (n.corners > 2.0e9 || (limit > 0 && bytes > limit))
    throw ParamError(fmt::format(
        "{}.levels: {} levels give {:.3g} faces and need about {:.3g} MB, more than the memory "
        "limit of {:.0f} MB",
        where, levels, n.faces, bytes / 1048576.0, limit / 1048576.0));
}

template <int D>
void subdivide_values(ValueMatrix<D>& values, PolygonFaces& faces, int levels,
                      const SubdivisionOptions& options, std::string_view where) {
  const bool loop = options.scheme == SubdivisionScheme::Loop;
  check_subdivision_memory(faces, static_cast<int>(values.cols()), levels, options.scheme,
                           8.0 * values.rows(), where);
  ValueMatrix<D> next;
  for (int l = 0; l < levels; ++l) {
    const Topology t = build_topology(faces, static_cast<int>(values.cols()), where, loop);
    Stencil s;
    s.off.reserve(static_cast<std::size_t>(t.nv + t.ne + t.nf) + 1);
    s.col.reserve(faces.indices.size() * (loop ? 4 : 8));
    s.w.reserve(faces.indices.size() * (loop ? 4 : 8));
    PolygonFaces refined;
    if (loop)
      loop_level(t, options.beta, s, refined);
    else
      catmull_clark_level(t, s, refined);
    apply<D>(s, values, next);
    values.swap(next);
    faces = std::move(refined);
  }
  if (levels == 0) build_topology(faces, static_cast<int>(values.cols()), where, loop);
}

template <int D>
LimitJets<D> limit_jets(const ValueMatrix<D>& values, const PolygonFaces& faces,
                        const SubdivisionOptions& options, std::string_view where) {
  const bool loop = options.scheme == SubdivisionScheme::Loop;
  const Topology t = build_topology(faces, static_cast<int>(values.cols()), where, loop);
  if (!loop)
    for (int f = 0; f < t.nf; ++f)
      if (faces.size(f) != 4)
        throw InputError(
            fmt::format("{}: face {} has {} vertices; Catmull-Clark limit masks need "
                        "quads (subdivide at least one level)",
                        where, f, faces.size(f)));
  const int d = static_cast<int>(values.rows()), nv = t.nv;
  LimitJets<D> j;
  for (auto* m : {&j.value, &j.du, &j.dv, &j.duu, &j.duv, &j.dvv})
    m->setZero(d, nv);
  j.kind.assign(nv, VertexKind::Isolated);
  const double pi = std::numbers::pi;
  tbb::parallel_for(tbb::blocked_range<int>(0, nv, 1024), [&](const auto& r) {
    using Vec = Eigen::Matrix<double, D, 1>;
    for (int v = r.begin(); v != r.end(); ++v) {
      const int b = t.ring_off[v], n = t.valence(v);
      const Vec x = values.col(v);
      if (n == 0) {
        j.value.col(v) = x;
        continue;
      }
      if (t.boundary[v]) {
        const Vec p = values.col(t.target(t.ring[b])), q = values.col(t.last_boundary_neighbour(v));
        j.value.col(v) = (p + 4.0 * x + q) / 6.0;
        j.du.col(v) = (p - q) / 2.0;
        Vec inner = Vec::Zero(d);
        int count = 0;
        for (int i = b + 1; i < b + n; ++i, ++count)
          inner += values.col(t.target(t.ring[i]));
        j.dv.col(v) = count > 0 ? Vec(inner / count - x) : Vec(Vec::Zero(d));
        if (count == 0) {  // a single face: its centroid direction
          Vec c = Vec::Zero(d);
          const int f = t.face_of[t.ring[b]];
          for (int k = faces.offsets[f]; k < faces.offsets[f + 1]; ++k)
            c += values.col(faces.indices[k]);
          j.dv.col(v) = c / faces.size(f) - x;
        }
        j.kind[v] = VertexKind::Boundary;
        continue;
      }
      if (loop) {
        const double beta = loop_beta(n, options.beta);
        const double chi = 1.0 / (3.0 / (8.0 * beta) + n);
        Vec sum = Vec::Zero(d), tu = Vec::Zero(d), tv = Vec::Zero(d);
        for (int i = 0; i < n; ++i) {
          const Vec p = values.col(t.target(t.ring[b + i]));
          sum += p;
          tu += std::cos(2 * pi * i / n) * p;
          tv += std::sin(2 * pi * i / n) * p;
        }
        j.value.col(v) = (1.0 - n * chi) * x + chi * sum;
        j.du.col(v) = (2.0 / n) * tu;
        j.dv.col(v) = (2.0 / n) * tv;
        if (n == 6) {
          Vec a[3];
          for (int k = 0; k < 3; ++k)
            a[k] = values.col(t.target(t.ring[b + k])) + values.col(t.target(t.ring[b + k + 3])) -
                   2.0 * x;
          j.duu.col(v) = a[0];
          j.dvv.col(v) = (2.0 * (a[1] + a[2]) - a[0]) / 3.0;
          j.duv.col(v) = (a[1] - a[2]) / std::sqrt(3.0);
          j.kind[v] = VertexKind::Regular;
        } else {
          j.kind[v] = VertexKind::Extraordinary;
        }
      } else {
        // Edge neighbours e_i and diagonal neighbours d_i (opposite corner of quad i).
        Vec se = Vec::Zero(d), sd = Vec::Zero(d), tu = Vec::Zero(d), tv = Vec::Zero(d);
        const double cn = std::cos(2 * pi / n);
        const double an = 1.0 + cn + std::cos(pi / n) * std::sqrt(2.0 * (9.0 + cn));
        for (int i = 0; i < n; ++i) {
          const int c = t.ring[b + i];
          const Vec e = values.col(t.target(c)), dg = values.col(t.vert(t.next(t.next(c))));
          se += e;
          sd += dg;
          const double c0 = std::cos(2 * pi * i / n), c1 = std::cos(2 * pi * (i + 1) / n);
          const double s0 = std::sin(2 * pi * i / n), s1 = std::sin(2 * pi * (i + 1) / n);
          tu += an * c0 * e + (c0 + c1) * dg;
          tv += an * s0 * e + (s0 + s1) * dg;
        }
        j.value.col(v) = (double(n) * n * x + 4.0 * se + sd) / (double(n) * (n + 5));
        j.du.col(v) = tu / (3.0 * n);
        j.dv.col(v) = tv / (3.0 * n);
        if (n == 4) {
          auto e = [&](int i) -> Vec { return values.col(t.target(t.ring[b + i])); };
          auto dg = [&](int i) -> Vec { return values.col(t.vert(t.next(t.next(t.ring[b + i])))); };
          // Grid P(1,0)=e0, P(0,1)=e1, P(-1,0)=e2, P(0,-1)=e3, P(1,1)=d0, P(-1,1)=d1,
          // P(-1,-1)=d2, P(1,-1)=d3; B-spline masks at a knot.
          j.duu.col(v) = ((dg(3) - 2.0 * e(3) + dg(2)) + 4.0 * (e(0) - 2.0 * x + e(2)) +
                          (dg(0) - 2.0 * e(1) + dg(1))) /
                         6.0;
          j.dvv.col(v) = ((dg(1) - 2.0 * e(2) + dg(2)) + 4.0 * (e(1) - 2.0 * x + e(3)) +
                          (dg(0) - 2.0 * e(0) + dg(3))) /
                         6.0;
          j.duv.col(v) = (dg(0) - dg(3) - dg(1) + dg(2)) / 4.0;
          j.kind[v] = VertexKind::Regular;
        } else {
          j.kind[v] = VertexKind::Extraordinary;
        }
      }
    }
  });
  return j;
}

template void subdivide_values<3>(ValueMatrix<3>&, PolygonFaces&, int, const SubdivisionOptions&,
                                  std::string_view);
template void subdivide_values<9>(ValueMatrix<9>&, PolygonFaces&, int, const SubdivisionOptions&,
                                  std::string_view);
template LimitJets<3> limit_jets<3>(const ValueMatrix<3>&, const PolygonFaces&,
                                    const SubdivisionOptions&, std::string_view);
template LimitJets<9> limit_jets<9>(const ValueMatrix<9>&, const PolygonFaces&,
                                    const SubdivisionOptions&, std::string_view);

}  // namespace scanbench::algorithms
