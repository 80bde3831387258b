#pragma once
// PolygonFaces: polygon connectivity in compressed rows, the one face layout of the covariance
// mesh (covariance_mesh.h, its PLY faces) and of the subdivision engine
// (scanbench/algorithms/gps/subdivision.h). Face f holds indices[offsets[f] .. offsets[f + 1]),
// counter-clockwise seen from outside; offsets has num_faces() + 1 entries (a single 0 without
// faces). Any mix of polygon sizes: triangles for Loop, quads for Catmull-Clark.
#include <cstddef>
#include <initializer_list>
#include <span>
#include <vector>

namespace scanbench {

struct PolygonFaces {
  std::vector<int> offsets{0};
  std::vector<int> indices;

  int num_faces() const { return static_cast<int>(offsets.size()) - 1; }
  int size(std::ptrdiff_t f) const {
    return offsets[static_cast<std::size_t>(f) + 1] - offsets[static_cast<std::size_t>(f)];
  }
  std::span<const int> face(std::ptrdiff_t f) const {
    return {indices.data() + offsets[static_cast<std::size_t>(f)],
            static_cast<std::size_t>(size(f))};
  }
  void add(std::span<const int> face) {
    indices.insert(indices.end(), face.begin(), face.end());
    offsets.push_back(static_cast<int>(indices.size()));
  }
  void add(std::initializer_list<int> face) {
    add(std::span<const int>(face.begin(), face.size()));
  }
  /// True when every face has exactly `k` vertices (and there is at least one face).
  bool all_of_size(int k) const {
    if (num_faces() == 0) return false;
    for (int f = 0; f < num_faces(); ++f)
      if (size(f) != k) return false;
    return true;
  }
  /// Removes every face.
  void clear() {
    offsets.assign(1, 0);
    indices.clear();
  }
  bool operator==(const PolygonFaces&) const = default;
};

}  // namespace scanbench
