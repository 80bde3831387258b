#include "scanbench/algorithms/peers/pcl_peers.h"

#include <fmt/format.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <vector>

#include "input_checks.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/run_program.h"

namespace scanbench::algorithms {

namespace fs = std::filesystem;

namespace {

constexpr const char* kPclPackage = "pcl-tools";

bool on_path(const std::string& program) {
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path != nullptr ? path : "");
  for (std::string dir; std::getline(dirs, dir, ':');) {
    // An empty entry is the current directory. (Not `dir = "."`: GCC 12 warns about that
    // assignment, -Wstringop-overflow, a false positive that -Werror turned into an error in
    // builds without unity batches.)
    const fs::path base = dir.empty() ? fs::path(".") : fs::path(dir);
    if (::access((base / program).c_str(), X_OK) == 0) return true;
  }
  return false;
}

/// Throws the one-line "not found; install" Error for the first program not on PATH.
void require_programs(std::initializer_list<const char*> programs, std::string_view stage) {
  for (const char* p : programs) {
    if (!on_path(p)) {
      throw Error(fmt::format("{}: {} not found in PATH; install the Debian package {}", stage, p,
                              kPclPackage));
    }
  }
}

/// Points and (when the file has them) normals of a PCD v0.7 file, ascii or binary; rows with a
/// non-finite position (PCL's invalid points) are skipped.
struct PcdPoints {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;
};

struct PcdField {
  std::string name;
  int size = 4;
  char type = 'F';
  int count = 1;
  std::size_t offset = 0;  // bytes (binary) or tokens (ascii) from the row's start
};

std::vector<std::string> pcd_words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> w;
  for (std::string s; in >> s;)
    w.push_back(s);
  return w;
}

PcdPoints read_pcd(const fs::path& path, std::string_view stage) {
  std::ifstream in(path, std::ios::binary);
  auto fail = [&](const std::string& why) {
    return Error(fmt::format("{}: {}: {}", stage, path.filename().string(), why));
  };
  if (!in) throw fail("cannot open");
  std::vector<PcdField> fields;
  std::size_t points = 0;
  std::string data;
  for (std::string line; data.empty() && std::getline(in, line);) {
    const auto w = pcd_words(line);
    if (w.empty() || w[0][0] == '#') continue;
    if (w[0] == "FIELDS") {
      for (std::size_t i = 1; i < w.size(); ++i)
        fields.push_back({w[i]});
    } else if (w[0] == "SIZE" || w[0] == "TYPE" || w[0] == "COUNT") {
      if (w.size() != fields.size() + 1) throw fail(w[0] + " does not match FIELDS");
      for (std::size_t i = 0; i < fields.size(); ++i) {
        if (w[0] == "SIZE") fields[i].size = std::atoi(w[i + 1].c_str());
        if (w[0] == "TYPE") fields[i].type = w[i + 1][0];
        if (w[0] == "COUNT") fields[i].count = std::atoi(w[i + 1].c_str());
      }
    } else if (w[0] == "POINTS" && w.size() == 2) {
      points = static_cast<std::size_t>(std::atoll(w[1].c_str()));
    } else if (w[0] == "DATA" && w.size() == 2) {
      data = w[1];
    }
  }
  if (data != "ascii" && data != "binary") throw fail("DATA '" + data + "' is not ascii or binary");
  std::size_t row = 0;  // bytes (binary) or tokens (ascii) per row
  for (auto& f : fields) {
    f.offset = row;
    row += static_cast<std::size_t>(data == "binary" ? f.size * f.count : f.count);
  }
  auto find = [&](const char* name) -> const PcdField* {
    for (const auto& f : fields) {
      if (f.name == name && f.type == 'F' && f.size == 4 && f.count == 1) return &f;
    }
    return nullptr;
  };
  const PcdField* xyz[3] = {find("x"), find("y"), find("z")};
  const PcdField* nxyz[3] = {find("normal_x"), find("normal_y"), find("normal_z")};
  if (!xyz[0] || !xyz[1] || !xyz[2]) throw fail("no float fields x y z");
  const bool has_normals = nxyz[0] && nxyz[1] && nxyz[2];
  PcdPoints out;
  std::vector<char> bytes(row);
  std::vector<float> values(6);
  for (std::size_t r = 0; r < points; ++r) {
    if (data == "binary") {
      if (!in.read(bytes.data(), static_cast<std::streamsize>(row))) throw fail("truncated data");
      for (int c = 0; c < 3; ++c) {
        std::memcpy(&values[c], bytes.data() + xyz[c]->offset, 4);
        if (has_normals) std::memcpy(&values[3 + c], bytes.data() + nxyz[c]->offset, 4);
      }
    } else {
      std::string line;
      if (!std::getline(in, line)) throw fail("truncated data");
      const auto w = pcd_words(line);
      if (w.size() != row)
        throw fail(fmt::format("row {} has {} values, not {}", r, w.size(), row));
      for (int c = 0; c < 3; ++c) {
        values[c] = std::strtof(w[xyz[c]->offset].c_str(), nullptr);
        if (has_normals) values[3 + c] = std::strtof(w[nxyz[c]->offset].c_str(), nullptr);
      }
    }
    const Eigen::Vector3f p(values[0], values[1], values[2]);
    if (!p.allFinite()) continue;
    out.positions.push_back(p);
    if (has_normals) out.normals.emplace_back(values[3], values[4], values[5]);
  }
  return out;
}

/// A private directory holding the input as PCD (through pcl_ply2pcd).
struct PclJob {
  programs::TempDir dir;
  fs::path input;
  PclJob(const PointCloud& points, std::string_view name, double timeout_s, std::string_view stage,
         RunContext& ctx)
      : dir(name), input(dir.path() / "input.pcd") {
    const fs::path ply = dir.path() / "input.ply";
    write_point_cloud_rgb(points, ply);
    run("pcl_ply2pcd", {"-format", "1", ply.string(), input.string()}, input, "point cloud",
        timeout_s, stage, ctx);
  }
  /// Runs `program` with `args`; `output` must then be a non-empty file.
  void run(const char* program, std::vector<std::string> args, const fs::path& output,
           std::string_view what, double timeout_s, std::string_view stage, RunContext& ctx) const {
    args.insert(args.begin(), program);
    programs::run_program(args, dir.path(), timeout_s, stage, ctx);
    programs::require_output(output, dir.path(), program, what, stage);
  }
};

using detail::check_points;
using detail::checked_diagonal;

std::string number(double v) {
  return fmt::format("{}", v);
}

}  // namespace

std::string pcl_tools_version() {
  static const std::string version = [] {
    RunContext quiet;
    try {
      const programs::TempDir dir("pcl-version");
      programs::run_program({"dpkg-query", "-W", "-f=${Version}", kPclPackage}, dir.path(), 30.0,
                            "pcl-tools version", quiet);
      std::ifstream in(dir.path() / "stdout.txt");
      std::string v;
      std::getline(in, v);
      return v.empty() ? std::string("unknown") : v;
    } catch (const Error&) {
      return std::string(on_path("pcl_ply2pcd") ? "unknown" : "not installed");
    }
  }();
  return version;
}

PointCloud pcl_mls(const PointCloud& in, const PclMlsParams& p, RunContext& ctx) {
  constexpr std::string_view stage = "peer.pcl_mls";
  const double radius = p.radius * checked_diagonal(in, stage, 3);
  require_programs({"pcl_ply2pcd", "pcl_mls_smoothing"}, stage);
  auto timer = ctx.phase("pcl");
  const PclJob job(in, "pcl-mls", p.timeout_s, stage, ctx);
  const fs::path output = job.dir.path() / "output.pcd";
  job.run("pcl_mls_smoothing",
          {job.input.string(), output.string(), "-radius", number(radius), "-sqr_gauss_param",
           number(radius * radius), "-polynomial_order", std::to_string(p.polynomial_order)},
          output, "point cloud", p.timeout_s, stage, ctx);
  const PcdPoints pcd = read_pcd(output, stage);
  if (pcd.positions.empty()) {
    throw Error(
        fmt::format("{}: pcl_mls_smoothing kept no point (radius {} too small?)", stage, p.radius));
  }
  PointCloud out;
  out.resize(static_cast<Eigen::Index>(pcd.positions.size()));
  for (std::size_t i = 0; i < pcd.positions.size(); ++i)
    out.positions.col(static_cast<Eigen::Index>(i)) = pcd.positions[i];
  if (!pcd.normals.empty()) {
    out.normals.resize(3, out.size());
    for (std::size_t i = 0; i < pcd.normals.size(); ++i)
      out.normals.col(static_cast<Eigen::Index>(i)) = pcd.normals[i];
  }
  out.validate(stage);  // PCL output is checked, not trusted
  return out;
}

PointCloud pcl_outlier_removal(const PointCloud& in, const PclOutlierParams& p, RunContext& ctx) {
  constexpr std::string_view stage = "peer.pcl_outlier_removal";
  const double diag = checked_diagonal(in, stage, 2);
  require_programs({"pcl_ply2pcd", "pcl_outlier_removal", "pcl_convert_pcd_ascii_binary"}, stage);
  auto timer = ctx.phase("pcl");
  PointCloud positions;
  positions.positions = in.positions;
  const PclJob job(positions, "pcl-outliers", p.timeout_s, stage, ctx);
  const fs::path output = job.dir.path() / "output.pcd";
  std::vector<std::string> args = {job.input.string(), output.string(), "-method", p.method};
  if (p.method == "radius") {
    args.insert(args.end(),
                {"-radius", number(p.radius * diag), "-min_pts", std::to_string(p.min_points)});
  } else {
    args.insert(args.end(), {"-mean_k", std::to_string(p.k), "-std_dev_mul", number(p.std_ratio)});
  }
  job.run("pcl_outlier_removal", args, output, "point cloud", p.timeout_s, stage, ctx);
  // pcl_outlier_removal writes binary_compressed (LZF) PCD; PCL's converter makes it binary.
  const fs::path binary = job.dir.path() / "output_binary.pcd";
  job.run("pcl_convert_pcd_ascii_binary", {output.string(), binary.string(), "1"}, binary,
          "point cloud", p.timeout_s, stage, ctx);
  const PcdPoints pcd = read_pcd(binary, stage);
  // PCL keeps the input order: match the kept points back (bitwise) to keep every attribute.
  std::vector<Eigen::Index> kept;
  kept.reserve(pcd.positions.size());
  std::size_t j = 0;
  for (Eigen::Index i = 0; i < in.size() && j < pcd.positions.size(); ++i) {
    if (std::memcmp(in.positions.col(i).data(), pcd.positions[j].data(), 3 * sizeof(float)) == 0) {
      kept.push_back(i);
      ++j;
    }
  }
  if (j != pcd.positions.size()) {
    throw Error(
        fmt::format("{}: pcl_outlier_removal's point {} is not an input point in order", stage, j));
  }
  PointCloud out = in.subset(kept);
  out.validate(stage);
  return out;
}

StageData pcl_poisson(const StageData& in, const PclPoissonParams& p, RunContext& ctx) {
  constexpr std::string_view stage = "peer.pcl_poisson";
  check_points(in.points, stage, 4);
  detail::require_unit_normals(in.points, stage, "normals.pca -> peer.pcl_poisson");
  require_programs({"pcl_ply2pcd", "pcl_poisson_reconstruction", "pcl_vtk2ply"}, stage);
  PointCloud points;
  points.positions = in.points.positions;
  points.normals = detail::unit_normals(in.points);
  auto timer = ctx.phase("pcl");
  const PclJob job(points, "pcl-poisson", p.timeout_s, stage, ctx);
  const fs::path vtk = job.dir.path() / "mesh.vtk";
  const fs::path ply = job.dir.path() / "mesh.ply";
  job.run("pcl_poisson_reconstruction",
          {job.input.string(), vtk.string(), "-depth", std::to_string(p.depth), "-point_weight",
           number(p.point_weight)},
          vtk, "mesh", p.timeout_s, stage, ctx);
  job.run("pcl_vtk2ply", {vtk.string(), ply.string()}, ply, "mesh", p.timeout_s, stage, ctx);
  StageData out;
  try {
    out.mesh = read_mesh(ply);
  } catch (const IoError& e) {
    throw Error(
        fmt::format("{}: pcl_poisson_reconstruction's mesh is unusable: {}", stage, e.what()));
  }
  if (out.mesh->num_faces() == 0) {
    throw Error(fmt::format("{}: pcl_poisson_reconstruction returned no face", stage));
  }
  return out;
}

}  // namespace scanbench::algorithms
