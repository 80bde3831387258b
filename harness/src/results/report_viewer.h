#pragma once
// The report's 3D viewer (report.h): per dataset / scanner group one WebGL canvas with a view per
// method, written into the page at report time so that it works offline from file://.
//
// What each view shows: the output of the group's first ok job (first seed) of every variant and
// sweep point; points coloured by the point-to-plane error E(q) = <q - p, N_p> (CLOP paper
// sec. 10.2) to the ground-truth mesh, a mesh output's vertices by their distance to the ground
// truth; the colour is viridis (metrics::viridis_color) of |E| / saturation, saturation =
// kViewerSaturationRel x the ground truth's bbox diagonal (the per-job heatmaps' default range).
// Large outputs are subsampled deterministically: n points of N kept are the indices
// floor(k N / n), k = 0..n-1. Positions are quantised to 16 bits per axis over the group's cube,
// errors to signed 16 bits of their largest magnitude, normals to 8 bits; all inlined as base64.
//
// The JavaScript: three.js (npm, pinned by harness/report-assets/package.json, installed by
// scripts/setup.sh into harness/report-assets/node_modules) and harness/report-assets/viewer.js,
// inlined as text and loaded through an import map of blob: URLs (browsers refuse module scripts
// by src from file://; three.js r160+ ships modules only). Without three.js the section says how
// to install it and the rest of the report is unchanged.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <optional>

#include "scanbench/core/params.h"
#include "scanbench/core/triangle_mesh.h"

namespace scanbench::metrics {
class GroundTruth;
}

namespace scanbench::harness {

/// What one view shows (also one cell of `scanbench figure`): an output (its error per shown
/// point) or the scan.
struct OutputCloud {
  std::string label, job, kind;   // kind: "points" or "mesh"
  std::string variant, point;     // the record's variant and sweep point labels
  Eigen::Matrix3Xf positions;     // the shown points (mesh: every vertex)
  Eigen::Matrix3Xf normals;       // empty or per shown point
  Eigen::VectorXf errors;         // per shown point
  Eigen::Matrix3Xi faces;         // mesh only
  std::vector<Eigen::Index> idx;  // shown point -> index in the file
  Eigen::Index total = 0;         // points (vertices) in the file
  std::string note;
};

/// The output of record `r` (results folder `dir`) read in the ground truth's frame (rebased to
/// gt_mesh's origin), subsampled to `budget` points (indices floor(k N / n)), with its errors:
/// points by E(q) = <q - p, N_p> at the closest point (CLOP paper sec. 10.2), a mesh's vertices
/// by their distance. nullopt when the record has no output file. Throws Error for unreadable
/// files.
std::optional<OutputCloud> output_cloud(const std::filesystem::path& dir, const Json& r,
                                        const TriangleMesh& gt_mesh, const metrics::GroundTruth& gt,
                                        std::int64_t budget);

/// Colour saturation of the viewer, fraction of the ground truth's bbox diagonal.
inline constexpr double kViewerSaturationRel = 0.005;

struct ViewerBudget {
  std::int64_t points_per_view = 200000;  ///< most points (or mesh vertices) one view holds
  std::int64_t points_total = 2000000;    ///< most points over the whole page
  std::int64_t truth_faces = 400000;      ///< larger ground-truth meshes are shown as samples
};

/// The folder of the viewer's assets: $SCANBENCH_REPORT_ASSETS when set, else the source tree's
/// harness/report-assets.
std::filesystem::path report_assets_dir();

/// The HTML of the viewer section for the ok records of results folder `dir`; "" when no record
/// has an output file. Never throws for a missing three.js or an unreadable dataset: the section
/// says what is missing. `js_bytes` (if given) receives the bytes of JavaScript inlined.
std::string viewer_section(const std::filesystem::path& dir, const std::vector<const Json*>& ok,
                           const ViewerBudget& budget = {}, std::size_t* js_bytes = nullptr);

/// The Content-Security-Policy of the page: nothing outside the page and its folder.
inline constexpr const char* kReportCsp = "default-src 'self' data: blob: 'unsafe-inline'";

/// Standard base64 (RFC 4648, with padding) of n bytes: the page's inlined buffers and the
/// figure's embedded PNGs.
std::string base64(const void* data, std::size_t n);

}  // namespace scanbench::harness
