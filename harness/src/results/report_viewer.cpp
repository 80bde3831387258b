#include "results/report_viewer.h"

#include <fmt/format.h>
#include <openssl/evp.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

#include "scanbench/core/datasets.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/stage_data.h"
#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/results/table.h"
#include "scanbench/metrics/ground_truth.h"
#include "scanbench/metrics/heatmap.h"

#ifndef SCANBENCH_REPORT_ASSETS_DIR
#define SCANBENCH_REPORT_ASSETS_DIR ""
#endif

namespace scanbench::harness {

namespace fs = std::filesystem;

namespace {

// The files the page inlines, relative to the assets folder.
constexpr const char* kThreeCore = "node_modules/three/build/three.core.min.js";
constexpr const char* kThreeModule = "node_modules/three/build/three.module.min.js";
constexpr const char* kOrbitControls = "node_modules/three/examples/jsm/controls/OrbitControls.js";
constexpr const char* kViewerJs = "viewer.js";
// three.module.min.js imports its core by a relative path, which a blob: URL cannot resolve;
// the page maps this bare name instead.
constexpr const char* kCoreImport = "from\"./three.core.min.js\"";
constexpr const char* kCoreBare = "from\"three-core\"";

template <class T>
std::string base64(const std::vector<T>& v) {
  return harness::base64(v.data(), v.size() * sizeof(T));
}

std::optional<std::string> read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Kept indices of n points under a budget: floor(k N / n), k = 0..n-1 (all when N <= budget).
std::vector<Eigen::Index> kept_indices(Eigen::Index total, std::int64_t budget) {
  const Eigen::Index n = std::min<Eigen::Index>(total, std::max<std::int64_t>(1, budget));
  std::vector<Eigen::Index> idx(static_cast<std::size_t>(n));
  for (Eigen::Index k = 0; k < n; ++k)
    idx[static_cast<std::size_t>(k)] = static_cast<Eigen::Index>(
        static_cast<std::int64_t>(k) * static_cast<std::int64_t>(total) / n);
  return idx;
}

/// The group's quantisation cube: positions p are stored as round((p - lo) / size x 65535).
struct Cube {
  Eigen::Vector3f lo = Eigen::Vector3f::Zero();
  float size = 1.0f;
  std::uint16_t q(float v, int axis) const {
    const float t = (v - lo[axis]) / size;
    return static_cast<std::uint16_t>(std::lround(std::clamp(t, 0.0f, 1.0f) * 65535.0f));
  }
};

std::string positions_b64(const Eigen::Matrix3Xf& pos, const std::vector<Eigen::Index>& idx,
                          const Cube& c) {
  std::vector<std::uint16_t> q;
  q.reserve(idx.size() * 3);
  for (Eigen::Index i : idx)
    for (int a = 0; a < 3; ++a)
      q.push_back(c.q(pos(a, i), a));
  return base64(q);
}

/// Errors as int16 of e / scale with scale = max |e| / 32767 (1 when all are zero).
Json errors_json(const Eigen::VectorXf& e, Json& j) {
  const float m = e.size() ? e.cwiseAbs().maxCoeff() : 0.0f;
  const double scale = m > 0.0f ? static_cast<double>(m) / 32767.0 : 1.0;
  std::vector<std::int16_t> q(static_cast<std::size_t>(e.size()));
  for (Eigen::Index i = 0; i < e.size(); ++i)
    q[static_cast<std::size_t>(i)] =
        static_cast<std::int16_t>(std::clamp<long>(std::lround(e[i] / scale), -32767L, 32767L));
  j["err"] = base64(q);
  j["err_scale"] = scale;
  return j;
}

std::string normals_b64(const Eigen::Matrix3Xf& n, const std::vector<Eigen::Index>& idx) {
  std::vector<std::int8_t> q;
  q.reserve(idx.size() * 3);
  for (Eigen::Index i : idx)
    for (int a = 0; a < 3; ++a)
      q.push_back(static_cast<std::int8_t>(std::lround(std::clamp(n(a, i), -1.0f, 1.0f) * 127.0f)));
  return base64(q);
}

}  // namespace

std::optional<OutputCloud> output_cloud(const fs::path& dir, const Json& r,
                                        const TriangleMesh& gt_mesh, const metrics::GroundTruth& gt,
                                        std::int64_t budget) {
  const Json art = r.value("artifacts", Json::object());
  const std::string kind = r.value("output_kind", std::string("points"));
  OutputCloud c;
  c.job = r.value("id", std::string());
  c.variant = c.label = field_value(r, "variant");
  c.point = field_value(r, "point");
  if (!c.point.empty()) c.label += " (" + c.point + ")";
  auto file = [&](const char* key) {
    const std::string rel = art.value(key, std::string());
    if (rel.empty() || rel.find("..") != std::string::npos || fs::path(rel).is_absolute())
      return fs::path();
    return fs::exists(dir / rel) ? dir / rel : fs::path();
  };
  std::optional<TriangleMesh> mesh;
  if (kind == "mesh" && !file("mesh").empty()) {
    mesh = read_mesh(file("mesh"));
  } else if (kind == "covariance_mesh" && !file("covariance_mesh").empty()) {
    mesh = read_covariance_mesh(file("covariance_mesh")).mean_mesh();
  }
  if (mesh) {
    rebase(*mesh, gt_mesh.origin);
    c.total = mesh->num_vertices();
    if (c.total <= budget && mesh->num_faces() <= 2 * budget) {
      c.kind = "mesh";
      c.faces = mesh->faces;
      c.idx = kept_indices(c.total, c.total);
    } else {
      c.kind = "points";
      c.idx = kept_indices(c.total, budget);
      c.note = fmt::format("a mesh of {} faces, shown by its vertices", mesh->num_faces());
    }
    c.positions.resize(3, static_cast<Eigen::Index>(c.idx.size()));
    for (std::size_t k = 0; k < c.idx.size(); ++k)
      c.positions.col(static_cast<Eigen::Index>(k)) = mesh->vertices.col(c.idx[k]);
    // The distance to the ground truth, signed by the side: + where v - c points along the
    // normal N of the closest face at the closest point c (outside), - inside.
    const auto cps = gt.closest_points(c.positions);
    c.errors.resize(c.positions.cols());
    for (Eigen::Index k = 0; k < c.positions.cols(); ++k) {
      const auto& cp = cps[static_cast<std::size_t>(k)];
      c.errors[k] = std::copysign(cp.distance, (c.positions.col(k) - cp.point).dot(cp.normal));
    }
    return c;
  }
  if (file("output").empty()) return std::nullopt;
  PointCloud pts = read_point_cloud(file("output"));
  if (pts.empty()) return std::nullopt;
  rebase(pts, gt_mesh.origin);
  c.kind = "points";
  c.total = pts.size();
  c.idx = kept_indices(c.total, budget);
  const auto n = static_cast<Eigen::Index>(c.idx.size());
  c.positions.resize(3, n);
  if (pts.has_normals()) c.normals.resize(3, n);
  for (Eigen::Index k = 0; k < n; ++k) {
    c.positions.col(k) = pts.positions.col(c.idx[static_cast<std::size_t>(k)]);
    if (pts.has_normals()) c.normals.col(k) = pts.normals.col(c.idx[static_cast<std::size_t>(k)]);
  }
  // The heatmaps' error (job_exec's write_job_heatmap): E = <q - p, N_p> at the closest point.
  const auto cps = gt.closest_points(c.positions);
  c.errors.resize(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const auto& cp = cps[static_cast<std::size_t>(k)];
    c.errors[k] = (c.positions.col(k) - cp.point).dot(cp.normal);
  }
  return c;
}

namespace {

Json cloud_json(const OutputCloud& c, const Cube& cube) {
  Json j = {{"label", c.label},
            {"job", c.job},
            {"kind", c.kind},
            {"count", c.idx.size()},
            {"total", c.total},
            {"pos", positions_b64(c.positions, kept_indices(c.positions.cols(), c.positions.cols()),
                                  cube)}};
  if (!c.note.empty()) j["note"] = c.note;
  if (!c.variant.empty()) j["variant"] = c.variant;
  if (!c.point.empty()) j["point"] = c.point;
  if (c.normals.cols() > 0)
    j["nrm"] = normals_b64(c.normals, kept_indices(c.normals.cols(), c.normals.cols()));
  if (c.errors.size() > 0) errors_json(c.errors, j);
  if (c.faces.cols() > 0 && c.positions.cols() <= 65536) {  // 16-bit indices when they fit
    std::vector<std::uint16_t> f(static_cast<std::size_t>(c.faces.size()));
    for (std::size_t i = 0; i < f.size(); ++i)
      f[i] = static_cast<std::uint16_t>(c.faces.data()[i]);
    j["tri16"] = base64(f);
  } else if (c.faces.cols() > 0) {
    std::vector<std::uint32_t> f(static_cast<std::size_t>(c.faces.size()));
    std::memcpy(f.data(), c.faces.data(), f.size() * sizeof(std::uint32_t));
    j["tri"] = base64(f);
  }
  return j;
}

/// Points of a scan with an "outlier" property split into inliers and outliers.
std::pair<Json, Json> scan_json(const fs::path& file, const TriangleMesh& gt_mesh, const Cube& cube,
                                std::int64_t budget) {
  PointCloud scan = read_point_cloud(file);
  rebase(scan, gt_mesh.origin);
  const auto it = scan.properties.find("outlier");
  std::vector<Eigen::Index> in, out;
  for (Eigen::Index i = 0; i < scan.size(); ++i)
    (it != scan.properties.end() && it->second[i] > 0.5f ? out : in).push_back(i);
  auto part = [&](const std::vector<Eigen::Index>& all, const char* label) {
    if (all.empty()) return Json();
    std::vector<Eigen::Index> idx;
    for (Eigen::Index k : kept_indices(static_cast<Eigen::Index>(all.size()), budget))
      idx.push_back(all[static_cast<std::size_t>(k)]);
    return Json{{"label", label},
                {"kind", "points"},
                {"count", idx.size()},
                {"total", all.size()},
                {"pos", positions_b64(scan.positions, idx, cube)}};
  };
  return {part(in, "scan"), part(out, "scan outliers")};
}

/// One dataset / scanner group: its ground truth, scan and a view per (variant, sweep point).
struct Group {
  std::string label;
  std::vector<const Json*> records;  // first seed of each (variant, point), in record order
};

std::string missing_three_html(const fs::path& assets) {
  return "<h2 id=\"viewer\">3D viewer</h2>\n<p id=\"viewer-missing\">The 3D viewer needs "
         "three.js, which is not installed in <code>" +
         html_escape(assets.string()) +
         "</code>. Install it with <code>bash scripts/setup.sh</code> (or <code>npm ci "
         "--prefix harness/report-assets</code>) and run <code>scanbench report</code> "
         "again.</p>\n";
}

/// `</` inside an inlined script would end it; JSON and JavaScript both read `<\/` as `</`.
std::string script_safe(std::string s) {
  for (std::size_t p = s.find("</"); p != std::string::npos; p = s.find("</", p + 3))
    s.replace(p, 2, "<\\/");
  return s;
}

/// A colour bar (SVG, static: readable without the script): Magnitude, |E| in viridis from 0 to
/// the saturation (shown); Signed, the signed error in the diverging map from -saturation to
/// +saturation (shown when the viewer's colour choice is "signed").
std::string colour_bar(std::size_t group, double saturation_abs, metrics::ErrorScale scale) {
  const bool sgn = scale == metrics::ErrorScale::Signed;
  std::string stops;
  for (int i = 0; i <= 16; ++i) {
    const Eigen::Vector3f c = metrics::map_color(std::min(1.0f, static_cast<float>(i) / 16), scale);
    stops +=
        fmt::format("<stop offset=\"{:.4f}\" stop-color=\"rgb({},{},{})\"/>", i / 16.0,
                    std::lround(c.x() * 255), std::lround(c.y() * 255), std::lround(c.z() * 255));
  }
  std::string ticks;
  for (int k = 0; k <= 4; ++k) {
    const double x = 24 + k * 70.0;
    ticks += fmt::format(
        "<line x1=\"{0}\" x2=\"{0}\" y1=\"26\" y2=\"30\" stroke=\"#333\"/><text x=\"{0}\" y=\"42\" "
        "text-anchor=\"middle\">{1}</text>",
        x, format_number(metrics::bar_value(k / 4.0, kViewerSaturationRel, scale)));
  }
  const std::string pm = sgn ? "&#177;" : "";
  return fmt::format(
      "<svg class=\"colour-bar {0}\"{1} width=\"560\" height=\"62\" font-family=\"sans-serif\" "
      "font-size=\"11\"><defs><linearGradient id=\"{2}-{3}\">{4}</linearGradient></defs>"
      "<rect x=\"24\" y=\"8\" width=\"280\" height=\"18\" fill=\"url(#{2}-{3})\"/>{5}"
      "<text x=\"314\" y=\"21\">{6}</text><text x=\"24\" y=\"58\">saturates at {7}{8} x "
      "diagonal = {7}{9} (mesh units); {10}</text></svg>",
      sgn ? "signed" : "magnitude", sgn ? " style=\"display:none\"" : "",
      sgn ? "coolwarm" : "viridis", group, stops, ticks,
      sgn ? "signed E / diagonal (- inside, + outside)" : "|E| / diagonal", pm,
      format_number(kViewerSaturationRel), format_number(saturation_abs),
      sgn ? "larger errors take the end colours" : "larger errors are yellow");
}

}  // namespace

fs::path report_assets_dir() {
  if (const char* e = std::getenv("SCANBENCH_REPORT_ASSETS"); e && *e) return e;
  return SCANBENCH_REPORT_ASSETS_DIR;
}

std::string viewer_section(const fs::path& dir, const std::vector<const Json*>& ok,
                           const ViewerBudget& budget, std::size_t* js_bytes) {
  if (js_bytes) *js_bytes = 0;
  // Groups and their views: the first ok job of each (variant, sweep point) with an output.
  std::vector<Group> groups;
  std::map<std::string, std::size_t> group_index;
  std::map<std::string, bool> seen;
  for (const Json* r : ok) {
    const Json art = r->value("artifacts", Json::object());
    if (!art.contains("output") && !art.contains("mesh") && !art.contains("covariance_mesh"))
      continue;
    const std::string g = field_value(*r, "dataset") + " / " + field_value(*r, "scanner");
    const std::string view =
        g + "\x1f" + field_value(*r, "variant") + "\x1f" + field_value(*r, "point");
    if (seen[view]) continue;
    seen[view] = true;
    if (!group_index.count(g)) {
      group_index[g] = groups.size();
      groups.push_back({g, {}});
    }
    groups[group_index[g]].records.push_back(r);
  }
  if (groups.empty()) return "";

  const fs::path assets = report_assets_dir();
  std::optional<std::string> core = read_text(assets / kThreeCore),
                             module = read_text(assets / kThreeModule),
                             orbit = read_text(assets / kOrbitControls),
                             viewer = read_text(assets / kViewerJs);
  if (!core || !module || !orbit || !viewer) return missing_three_html(assets);
  if (module->find(kCoreImport) == std::string::npos) {
    return "<h2 id=\"viewer\">3D viewer</h2>\n<p id=\"viewer-missing\">The 3D viewer: " +
           html_escape((assets / kThreeModule).string()) +
           " does not import its core as the pinned three.js does; run <code>npm ci --prefix "
           "harness/report-assets</code>.</p>\n";
  }
  for (std::size_t p = module->find(kCoreImport); p != std::string::npos;
       p = module->find(kCoreImport, p))
    module->replace(p, std::strlen(kCoreImport), kCoreBare);

  // Budget per view: the page's total shared by every view, at most points_per_view each.
  std::size_t views = 0;
  for (const auto& g : groups)
    views += g.records.size();
  const std::int64_t per_view = std::max<std::int64_t>(
      1000,
      std::min(budget.points_per_view,
               budget.points_total / static_cast<std::int64_t>(std::max<std::size_t>(1, views))));

  Json data = {{"version", 1}, {"budget", per_view}, {"saturation_rel", kViewerSaturationRel}};
  Json cmap = Json::array();
  for (const auto& c : metrics::viridis_table())
    cmap.push_back({std::lround(c[0] * 255), std::lround(c[1] * 255), std::lround(c[2] * 255)});
  data["colormap"] = cmap;
  Json cmap_signed = Json::array();
  for (const auto& c : metrics::diverging_table())
    cmap_signed.push_back(
        {std::lround(c[0] * 255), std::lround(c[1] * 255), std::lround(c[2] * 255)});
  data["colormap_signed"] = cmap_signed;
  std::vector<Json> groups_json;  // one script element each, parsed when the group is shown
  std::string html, notes;
  for (const auto& g : groups) {
    const Json& first = *g.records.front();
    const Json dataset = first.value("dataset", Json::object());
    const Json params = dataset.value("params", Json::object());
    if (params.contains("gt_points")) {
      notes += "<li>" + html_escape(g.label) + ": a point-cloud ground truth; not shown.</li>\n";
      continue;
    }
    const bool from_points =
        first.value("scanner", Json::object()).value("preset", std::string()) == kPointsInput;
    try {
      const TriangleMesh gt_mesh =
          load_dataset(dataset.value("name", std::string()), from_points ? Json::object() : params);
      const metrics::GroundTruth gt(gt_mesh, 0);
      std::vector<OutputCloud> clouds;
      std::vector<std::string> failed;
      for (const Json* r : g.records) {
        try {
          if (auto c = output_cloud(dir, *r, gt_mesh, gt, per_view))
            clouds.push_back(std::move(*c));
        } catch (const Error& e) {
          failed.push_back(field_value(*r, "variant") + ": " + e.what());
        }
      }
      for (const auto& f : failed)
        notes += "<li>" + html_escape(g.label + ", " + f) + "</li>\n";
      if (clouds.empty()) continue;
      // The cube: the ground truth's box and every shown point.
      BoundingBox box = gt.bbox();
      for (const auto& c : clouds)
        for (Eigen::Index i = 0; i < c.positions.cols(); ++i)
          box.extend(c.positions.col(i));
      Cube cube;
      cube.lo = box.min;
      cube.size = std::max(1e-12f, (box.max - box.min).maxCoeff());
      const double diag = gt.diagonal();
      Json gj = {
          {"label", g.label},
          {"lo", {cube.lo.x(), cube.lo.y(), cube.lo.z()}},
          {"size", cube.size},
          {"center", {gt.bbox().center().x(), gt.bbox().center().y(), gt.bbox().center().z()}},
          {"diagonal", diag},
          {"saturation", kViewerSaturationRel * diag},
          {"origin", {gt_mesh.origin.x(), gt_mesh.origin.y(), gt_mesh.origin.z()}},
          {"views", Json::array()}};
      for (const auto& c : clouds)
        gj["views"].push_back(cloud_json(c, cube));
      // The ground truth: the mesh, or (too large) its vertices.
      OutputCloud truth;
      truth.label = "ground truth";
      truth.total = gt_mesh.num_vertices();
      if (gt_mesh.num_faces() <= budget.truth_faces) {
        truth.kind = "mesh";
        truth.idx = kept_indices(truth.total, truth.total);
        truth.positions = gt_mesh.vertices;
        truth.faces = gt_mesh.faces;
      } else {
        truth.kind = "points";
        truth.idx = kept_indices(truth.total, per_view);
        truth.positions.resize(3, static_cast<Eigen::Index>(truth.idx.size()));
        for (std::size_t k = 0; k < truth.idx.size(); ++k)
          truth.positions.col(static_cast<Eigen::Index>(k)) = gt_mesh.vertices.col(truth.idx[k]);
      }
      gj["truth"] = cloud_json(truth, cube);
      const std::string scan_rel =
          first.value("artifacts", Json::object()).value("scan", std::string());
      if (!scan_rel.empty() && scan_rel.find("..") == std::string::npos &&
          fs::exists(dir / scan_rel)) {
        auto [in, out] = scan_json(dir / scan_rel, gt_mesh, cube, per_view);
        if (!in.is_null()) gj["scan"] = in;
        if (!out.is_null()) gj["outliers"] = out;
      }
      const std::size_t gi = groups_json.size();
      html += fmt::format(
          "<div class=\"sb-viewer\" id=\"viewer-{0}\" data-group=\"{0}\"><h3>{1}</h3>"
          "<div class=\"sb-controls\"></div><div class=\"sb-stage\"><canvas></canvas></div>"
          "{2}<div class=\"sb-pick\">Click a point to see its error and coordinates.</div>"
          "</div>\n",
          gi, html_escape(g.label),
          colour_bar(gi, kViewerSaturationRel * diag, metrics::ErrorScale::Magnitude) +
              colour_bar(gi, kViewerSaturationRel * diag, metrics::ErrorScale::Signed));
      groups_json.push_back(std::move(gj));
    } catch (const Error& e) {
      notes += "<li>" + html_escape(g.label) + ": " + html_escape(e.what()) + "</li>\n";
    }
  }
  if (groups_json.empty()) {
    return "<h2 id=\"viewer\">3D viewer</h2>\n<ul id=\"viewer-notes\">" + notes + "</ul>\n";
  }
  std::string h =
      "<h2 id=\"viewer\">3D viewer</h2>\n<p class=\"aggregates\">Per dataset, each method's "
      "output (the first seed of each variant and sweep point): points coloured by "
      "|E|, their point-to-plane error to the ground truth (CLOP paper sec. 10.2), a mesh "
      "output's vertices by their distance to it, in viridis from 0 to the saturation stated "
      "under each viewer; or (the colour choice above each viewer) by the signed error in "
      "Moreland's cool-warm diverging map, blue inside the surface, red outside, grey on it. Drag "
      "to turn (every view of a dataset turns together), wheel to zoom, "
      "right-drag to pan; click a point for its error and coordinates. Shading: the normals when "
      "the output has them, eye-dome lighting otherwise. " +
      fmt::format(
          "At most {} points a view (a deterministic subsample, indices floor(k N / n); "
          "the count is shown on each view).",
          per_view) +
      " Everything is inside this page: it works offline.</p>\n";
  if (!notes.empty()) h += "<ul id=\"viewer-notes\">" + notes + "</ul>\n";
  h += "<div id=\"sb-viewer-root\">\n" + html + "</div>\n";
  h += "<pre id=\"sb-viewer-status\" style=\"display:none\"></pre>\n";
  h += "<script type=\"application/json\" id=\"sb-viewer-data\">" + script_safe(data.dump()) +
       "</script>\n";
  for (std::size_t gi = 0; gi < groups_json.size(); ++gi) {
    h += fmt::format("<script type=\"application/json\" id=\"sb-viewer-group-{}\">", gi) +
         script_safe(groups_json[gi].dump()) + "</script>\n";
  }
  const std::string js_core = script_safe(*core), js_module = script_safe(*module),
                    js_orbit = script_safe(*orbit), js_viewer = script_safe(*viewer);
  // The boot script: blob: URLs for the inlined modules, an import map naming them, then the
  // viewer module (an import map must be in place before the first module loads).
  const std::string boot =
      "(function(){var t=function(id){return document.getElementById(id).textContent;};"
      "var u=function(id){return URL.createObjectURL(new Blob([t(id)],{type:'text/javascript'}))"
      ";};var m=document.createElement('script');m.type='importmap';m.textContent="
      "JSON.stringify({imports:{'three-core':u('sb-three-core'),'three':u('sb-three'),"
      "'three/addons/controls/OrbitControls.js':u('sb-three-orbit')}});"
      "document.head.appendChild(m);var v=document.createElement('script');v.type='module';"
      "v.src=u('sb-viewer-js');document.body.appendChild(v);})();";
  h += "<script type=\"text/plain\" id=\"sb-three-core\">" + js_core + "</script>\n";
  h += "<script type=\"text/plain\" id=\"sb-three\">" + js_module + "</script>\n";
  h += "<script type=\"text/plain\" id=\"sb-three-orbit\">" + js_orbit + "</script>\n";
  h += "<script type=\"text/plain\" id=\"sb-viewer-js\">" + js_viewer + "</script>\n";
  h += "<script>" + boot + "</script>\n";
  if (js_bytes)
    *js_bytes =
        js_core.size() + js_module.size() + js_orbit.size() + js_viewer.size() + boot.size();
  return h;
}

std::string base64(const void* data, std::size_t n) {
  // OpenSSL's encoder (libcrypto is linked for the cache seals). EVP_EncodeBlock takes an int
  // length and writes a terminating NUL: the bytes go in chunks of a multiple of 3, whose
  // encodings concatenate to the encoding of the whole.
  constexpr std::size_t kChunk = std::size_t{3} << 20;
  const auto* p = static_cast<const unsigned char*>(data);
  std::string out;
  out.reserve((n + 2) / 3 * 4 + 1);
  for (std::size_t i = 0; i < n; i += kChunk) {
    const std::size_t m = std::min(kChunk, n - i);
    const std::size_t at = out.size();
    out.resize(at + (m + 2) / 3 * 4 + 1);
    const int written = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data() + at), p + i,
                                        static_cast<int>(m));
    out.resize(at + static_cast<std::size_t>(written));
  }
  return out;
}

}  // namespace scanbench::harness
