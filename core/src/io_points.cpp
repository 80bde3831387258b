// Point clouds from the plain text formats users bring: XYZ / PWN and point-only OFF (io.h).
#include <fmt/format.h>

#include <array>
#include <cmath>
#include <vector>

#include "float_precision.h"
#include "io_readers.h"
#include "scanbench/core/errors.h"
#include "text_lines.h"

namespace scanbench::io_detail {

PointCloud cloud_from_xyz(std::string_view text, const std::string& name) {
  Lines lines(text);
  std::string_view line;
  std::string_view tok;
  auto fail = [&](const std::string& what) -> void {
    throw IoError(fmt::format("{}: line {}: {}", name, lines.number(), what));
  };
  std::vector<float> values;
  std::size_t columns = 0;
  std::int64_t declared = -1;
  std::int64_t points = 0;
  std::vector<float> row;
  std::vector<double> xyz;  // columns 1-3 in double, for the local origin (float_precision.h)
  std::array<double, 3> row_d{};
  while (lines.next(line)) {
    Tokens t(line);
    row.clear();
    while (t.next(tok)) {
      float x = 0.0f;
      if (row.size() < 3) {
        double d = 0.0;  // positions in double first, for the float32 precision check
        if (!parse_number(tok, d)) fail(fmt::format("'{}' is not a number", tok.substr(0, 40)));
        row_d[row.size()] = d;
        x = static_cast<float>(d);
      } else if (!parse_number(tok, x)) {
        fail(fmt::format("'{}' is not a number", tok.substr(0, 40)));
      }
      if (!std::isfinite(x)) fail(fmt::format("non-finite value in column {}", row.size() + 1));
      row.push_back(x);
    }
    // CGAL's read_XYZ accepts the point count alone on the first line.
    if (row.size() == 1 && points == 0 && declared < 0) {
      std::int64_t n = -1;
      Tokens c(line);
      c.next(tok);
      if (!parse_number(tok, n) || n < 0) fail("a single value must be the point count");
      declared = n;
      continue;
    }
    if (row.size() < 3) fail(fmt::format("expected x y z, got {} value(s)", row.size()));
    xyz.insert(xyz.end(), row_d.begin(), row_d.end());
    if (columns == 0) columns = row.size();
    if (row.size() != columns) {
      fail(fmt::format("{} values where the first point has {} (inconsistent columns)", row.size(),
                       columns));
    }
    values.insert(values.end(), row.begin(), row.end());
    ++points;
  }
  if (points == 0) throw IoError(fmt::format("{}: no points", name));
  if (declared >= 0 && declared != points) {
    throw IoError(fmt::format("{}: the first line declares {} points, the file holds {}", name,
                              declared, points));
  }
  const auto n = static_cast<Eigen::Index>(points);
  const auto cols = static_cast<Eigen::Index>(columns);
  const Eigen::Map<const Eigen::MatrixXf> table(values.data(), cols, n);
  PointCloud cloud;
  cloud.origin = localize(
      n, [&](int k, Eigen::Index i) { return xyz[static_cast<std::size_t>(3 * i + k)]; },
      cloud.positions, name, "point");
  if (columns == 6) {
    // CGAL writes (0, 0, 0) for a point set without normals (e.g. data/points_3/blobby.xyz).
    if (!table.bottomRows(3).isZero(0.0f)) cloud.normals = table.bottomRows(3);
  } else {
    for (Eigen::Index c = 3; c < cols; ++c)
      cloud.properties[fmt::format("column{}", c + 1)] = table.row(c).transpose();
  }
  cloud.validate(name);
  return cloud;
}

bool is_xyz_extension(std::string_view lower_ext) {
  return lower_ext == ".xyz" || lower_ext == ".pwn";
}

PointCloud cloud_from_off(const OffData& off, const std::string& name) {
  if (off.faces != 0) {
    throw IoError(
        fmt::format("{}: an OFF with {} faces is a mesh, not a point cloud", name, off.faces));
  }
  if (off.xyz.empty()) throw IoError(fmt::format("{}: no points", name));
  const auto n = static_cast<Eigen::Index>(off.xyz.size() / 3);
  PointCloud cloud;
  cloud.positions = Eigen::Map<const Eigen::Matrix3Xf>(off.xyz.data(), 3, n);
  cloud.origin = off.origin;
  if (!off.normals.empty())
    cloud.normals = Eigen::Map<const Eigen::Matrix3Xf>(off.normals.data(), 3, n);
  cloud.validate(name);
  return cloud;
}

}  // namespace scanbench::io_detail
