#include "scanbench/harness/records.h"

#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <CGAL/version.h>
#include <OpenImageIO/oiioversion.h>
#include <embree3/rtcore_config.h>
#include <oneapi/tbb/version.h>
#include <openvdb/version.h>
#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

#include "scanbench/algorithms/open3d_peers.h"
#include "scanbench/algorithms/pcl_peers.h"
#include "scanbench/core/allocator.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/json_text.h"
#include "scanbench/core/simd.h"
#include "scanbench/core/version.h"
#include "scanbench/harness/plugins.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

#define SCANBENCH_STR2(x) #x
#define SCANBENCH_STR(x) SCANBENCH_STR2(x)

Json run_context_json() {
  Json c = Json::object();
  c["scanbench"] = version_string();
  c["commit"] = git_commit();
#if defined(__clang__)
  c["compiler"] = fmt::format("clang {}", __clang_version__);
#elif defined(__GNUC__)
  c["compiler"] = fmt::format("gcc {}", __VERSION__);
#else
  c["compiler"] = "unknown";
#endif
#ifdef NDEBUG
  c["build"] = "release";
#else
  c["build"] = "debug";
#endif
  c["libraries"] = {
      {"eigen",
       fmt::format("{}.{}.{}", EIGEN_WORLD_VERSION, EIGEN_MAJOR_VERSION, EIGEN_MINOR_VERSION)},
      {"tbb", TBB_VERSION_STRING},
      {"embree", RTC_VERSION_STRING},
      {"openvdb", OPENVDB_LIBRARY_VERSION_STRING},
      {"openimageio", OIIO_VERSION_STRING},
      {"cgal", SCANBENCH_STR(CGAL_VERSION)},
      {"nlohmann_json", fmt::format("{}.{}.{}", NLOHMANN_JSON_VERSION_MAJOR,
                                    NLOHMANN_JSON_VERSION_MINOR, NLOHMANN_JSON_VERSION_PATCH)},
      {"fmt",
       fmt::format("{}.{}.{}", FMT_VERSION / 10000, FMT_VERSION / 100 % 100, FMT_VERSION % 100)},
      // The peers' libraries: Open3D is linked, PCL runs as the pcl-tools programs.
      {"open3d", algorithms::open3d_version()},
      {"pcl_tools", algorithms::pcl_tools_version()},
  };
  // The plugins loaded (path and SHA-256 of each file): which build of a user's method ran.
  if (!loaded_plugins().empty()) c["plugins"] = plugins_json();
  char host[256] = {0};
  if (gethostname(host, sizeof(host) - 1) != 0) host[0] = 0;
  c["host"] = host;
  std::string cpu = "unknown";
  std::ifstream info("/proc/cpuinfo");
  for (std::string line; std::getline(info, line);) {
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) cpu = line.substr(line.find_first_not_of(" \t", colon + 1));
      break;
    }
  }
  c["cpu"] = cpu;
  c["hardware_threads"] = std::thread::hardware_concurrency();
  // The SIMD path of the kernels (scanbench/core/simd.h): results agree across ISAs only
  // within float rounding, so compare and nightly name a baseline of another ISA.
  c["isa"] = std::string(simd::name(simd::active()));
  c["isa_compiled"] = std::string(simd::name(simd::compiled()));
  c["isa_flags"] = std::string(simd::compile_flags());
  c["allocator"] = std::string(allocator_policy());
  c["date"] = utc_now();
  return c;
}

std::string utc_now(const char* format) {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char date[64];
  if (std::strftime(date, sizeof(date), format, &tm) == 0) return {};
  return date;
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += c == '\n' ? ' ' : c;
  }
  return out + "\"";
}

std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(fmt::format("{}: cannot open", path.string()));
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

Json read_json_file(const fs::path& path) {
  return parse_json_text(read_file(path), path.string());
}

namespace {

/// The JSON type a field of a job record has (docs/records.md).
enum class Shape { String, Number, Bool, Object, Array };

const char* shape_name(Shape s) {
  switch (s) {
    case Shape::String:
      return "a string";
    case Shape::Number:
      return "a number";
    case Shape::Bool:
      return "a boolean";
    case Shape::Object:
      return "an object";
    case Shape::Array:
      return "an array";
  }
  return "?";
}

bool has_shape(const Json& v, Shape s) {
  switch (s) {
    case Shape::String:
      return v.is_string();
    case Shape::Number:
      return v.is_number();
    case Shape::Bool:
      return v.is_boolean();
    case Shape::Object:
      return v.is_object();
    case Shape::Array:
      return v.is_array();
  }
  return false;
}

const char* json_kind(const Json& v) {
  if (v.is_null()) return "null";
  if (v.is_string()) return "a string";
  if (v.is_number()) return "a number";
  if (v.is_boolean()) return "a boolean";
  if (v.is_object()) return "an object";
  if (v.is_array()) return "an array";
  return "a binary value";
}

/// The fields of a job record that the readers (table, report, compare, claims, history, eval
/// --from-record) take as given, with their types; `*` is every key of an object or element of
/// an array. A field may be absent (a failed job writes few of them) but never of another type.
/// Written by hand: a JSON Schema validator is not among the project's libraries, and this list
/// is what docs/records.md documents.
constexpr std::pair<const char*, Shape> kRecordShape[] = {
    {"key", Shape::String},
    {"experiment", Shape::String},
    {"status", Shape::String},
    {"error", Shape::String},
    {"point_label", Shape::String},
    {"output_kind", Shape::String},
    {"seed", Shape::Number},
    {"repeats", Shape::Number},
    {"peak_rss_mb", Shape::Number},
    {"repeat_outputs_identical", Shape::Bool},
    {"dataset", Shape::Object},
    {"dataset.label", Shape::String},
    {"dataset.name", Shape::String},
    {"dataset.params", Shape::Object},
    {"dataset_origin", Shape::Array},
    {"dataset_origin.*", Shape::Number},
    {"scanner", Shape::Object},
    {"scanner.label", Shape::String},
    {"scanner.preset", Shape::String},
    {"scanner.params", Shape::Object},
    {"variant", Shape::Object},
    {"variant.label", Shape::String},
    {"variant.chain", Shape::Array},
    {"variant.chain.*", Shape::Object},
    {"variant.chain.*.algorithm", Shape::String},
    {"variant.chain.*.label", Shape::String},
    {"variant.chain.*.params", Shape::Object},
    {"params", Shape::Object},
    {"point", Shape::Object},
    {"metrics", Shape::Object},
    {"metric_params", Shape::Object},
    {"scoring", Shape::Object},
    {"skipped", Shape::Object},
    {"skipped.*", Shape::String},
    {"sizes", Shape::Object},
    {"sizes.*", Shape::Number},
    {"limits", Shape::Object},
    {"limits.*", Shape::Number},
    {"artifacts", Shape::Object},
    {"artifacts.*", Shape::String},
    {"histograms", Shape::Object},
    {"histograms.*", Shape::Object},
    {"histograms.*.unit", Shape::String},
    {"histograms.*.min", Shape::Number},
    {"histograms.*.max", Shape::Number},
    {"histograms.*.count", Shape::Number},
    {"histograms.*.counts", Shape::Array},
    {"histograms.*.counts.*", Shape::Number},
    {"timing", Shape::Object},
    {"timing.scan_s", Shape::Number},
    {"timing.scan_cached", Shape::Bool},
    {"timing.total_s", Shape::Array},
    {"timing.total_s.*", Shape::Number},
    {"timing.cpu_s", Shape::Array},
    {"timing.cpu_s.*", Shape::Number},
    {"timing.phases", Shape::Object},
    {"timing.phases.*", Shape::Array},
    {"timing.phases.*.*", Shape::Number},
    {"timing.step_peak_rss_mb", Shape::Object},
    {"timing.step_peak_rss_mb.*", Shape::Number},
    {"timing.step_work_mb", Shape::Object},
    {"timing.step_work_mb.*", Shape::Number},
    {"timing.step_program_peak_rss_mb", Shape::Object},
    {"timing.step_program_peak_rss_mb.*", Shape::Number},
    {"timing.metrics_s", Shape::Number},
    {"timing.metric_phases", Shape::Object},
    {"timing.metric_phases.*", Shape::Number},
    {"timing.job_wall_s", Shape::Number},
    {"context", Shape::Object},
    {"context.scanbench", Shape::String},
    {"context.commit", Shape::String},
    {"context.compiler", Shape::String},
    {"context.build", Shape::String},
    {"context.libraries", Shape::Object},
    {"context.libraries.*", Shape::String},
    {"context.plugins", Shape::Array},
    {"context.host", Shape::String},
    {"context.cpu", Shape::String},
    {"context.hardware_threads", Shape::Number},
    {"context.isa", Shape::String},
    {"context.isa_compiled", Shape::String},
    {"context.isa_flags", Shape::String},
    {"context.allocator", Shape::String},
    {"context.date", Shape::String},
    {"context.threads", Shape::Number},
};

/// Checks the values at PATH[i..] below V (named NAME so far) against S.
void check_path(const Json& v, const std::vector<std::string>& path, std::size_t i,
                const std::string& name, Shape s, const std::string& where) {
  if (i == path.size()) {
    if (!has_shape(v, s)) {
      throw IoError(
          fmt::format("{}: field \"{}\" is {}, not {} (not a job record scanbench "
                      "wrote; docs/records.md lists the fields)",
                      where, name, json_kind(v), shape_name(s)));
    }
    return;
  }
  const std::string& part = path[i];
  if (part == "*") {
    if (v.is_object()) {
      for (const auto& [k, x] : v.items())
        check_path(x, path, i + 1, name + "." + k, s, where);
    } else if (v.is_array()) {
      for (std::size_t e = 0; e < v.size(); ++e)
        check_path(v[e], path, i + 1, fmt::format("{}[{}]", name, e), s, where);
    }
    return;
  }
  if (!v.is_object() || !v.contains(part)) return;
  check_path(v[part], path, i + 1, name.empty() ? part : name + "." + part, s, where);
}

}  // namespace

void check_record(const Json& r, const std::string& where) {
  if (!r.is_object() || !r.contains("id") || !r["id"].is_string()) {
    throw IoError(fmt::format("{}: not a job record (an object with an \"id\")", where));
  }
  for (const auto& [field, shape] : kRecordShape) {
    std::vector<std::string> path;
    for (std::string_view rest = field;;) {
      const auto dot = rest.find('.');
      path.emplace_back(rest.substr(0, dot));
      if (dot == std::string_view::npos) break;
      rest.remove_prefix(dot + 1);
    }
    check_path(r, path, 0, "", shape, where);
  }
}

Json read_record_file(const fs::path& path) {
  Json r = read_json_file(path);
  check_record(r, path.string());
  return r;
}

std::vector<Json> load_job_records(const fs::path& dir) {
  std::map<std::string, Json> by_id;
  const fs::path jobs = dir / "jobs";
  if (fs::is_directory(jobs)) {
    for (const auto& entry : fs::directory_iterator(jobs)) {
      const fs::path p = entry.path();
      if (p.extension() != ".json" || p.filename().string().front() == '.') continue;
      Json r = read_record_file(p);
      const std::string id = r["id"].get<std::string>();  // before r is moved from
      by_id[id] = std::move(r);
    }
  }
  std::vector<Json> out;
  if (fs::exists(dir / "plan.json")) {
    const Json plan = read_json_file(dir / "plan.json");
    if (plan.contains("jobs") && plan["jobs"].is_array()) {
      for (const auto& job : plan["jobs"]) {
        if (!job.is_object() || !job.contains("id") || !job["id"].is_string()) continue;
        auto it = by_id.find(job["id"].get<std::string>());
        if (it != by_id.end()) {
          out.push_back(std::move(it->second));
          by_id.erase(it);
        }
      }
    }
  }
  for (auto& [id, r] : by_id)
    out.push_back(std::move(r));
  return out;
}

namespace {

/// The records of a runs.jsonl file; a line that is not a JSON object, or a job id that appears
/// twice, is refused (a duplicated line would count a job twice in every median).
std::vector<Json> read_runs_jsonl(const fs::path& merged) {
  std::vector<Json> out;
  std::map<std::string, int> line_of;
  std::istringstream in(read_file(merged));
  int line_no = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    if (line.empty()) continue;
    const std::string where = fmt::format("{}: line {}", merged.string(), line_no);
    Json r = parse_json_text(line, where);
    check_record(r, where);
    const auto [it, fresh] = line_of.emplace(r["id"].get<std::string>(), line_no);
    if (!fresh) {
      throw IoError(
          fmt::format("{}: job {} appears twice (also line {}); the file is damaged "
                      "(`scanbench merge {}` rebuilds it from jobs/)",
                      where, it->first, it->second, merged.parent_path().string()));
    }
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace

std::vector<Json> load_records(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw IoError(fmt::format("{}: not a results folder", dir.string()));
  const fs::path merged = dir / "runs.jsonl";
  const bool have_merged = fs::exists(merged);
  const bool have_jobs = fs::is_directory(dir / "jobs");
  if (!have_jobs) {
    // A folder of merged records only (a committed baseline).
    if (!have_merged) {
      throw IoError(fmt::format("{}: no runs.jsonl and no jobs/ folder (not a results folder)",
                                dir.string()));
    }
    return read_runs_jsonl(merged);
  }
  // jobs/ holds the records themselves (one file each, written atomically); runs.jsonl is their
  // merge. It is used only when it says exactly what jobs/ says; else jobs/ is, with a line that
  // says why (a run stopped before its merge, lines lost or duplicated).
  std::vector<Json> records = load_job_records(dir);
  if (!have_merged) return records;
  std::string why;
  try {
    const std::vector<Json> lines = read_runs_jsonl(merged);
    if (lines.size() != records.size()) {
      why = fmt::format("holds {} records, jobs/ {}", lines.size(), records.size());
    } else {
      for (std::size_t i = 0; i < lines.size() && why.empty(); ++i) {
        if (lines[i] != records[i]) {
          why = fmt::format("line {} (job {}) differs from its record in jobs/", i + 1,
                            lines[i].value("id", std::string("?")));
        }
      }
    }
  } catch (const IoError& e) {
    why = e.what();
  }
  if (!why.empty()) {
    std::fprintf(stderr,
                 "scanbench: %s: %s; using the records in jobs/ (`scanbench merge %s` rewrites "
                 "it)\n",
                 merged.string().c_str(), why.c_str(), dir.string().c_str());
  }
  return records;
}

std::vector<double> record_samples(const Json& r, const std::string& q) {
  std::vector<double> out;
  auto from_array = [&](const Json& a) {
    if (!a.is_array()) return;
    for (const auto& x : a)
      if (x.is_number()) out.push_back(x.get<double>());
  };
  const Json timing = r.value("timing", Json::object());
  if (q == "time.total") {
    from_array(timing.value("total_s", Json()));
  } else if (q == "time.cpu") {
    from_array(timing.value("cpu_s", Json()));
  } else if (q.rfind("time.", 0) == 0) {
    const Json phases = timing.value("phases", Json::object());
    const std::string name = q.substr(5);
    if (phases.contains(name)) from_array(phases[name]);
  } else {
    const double v = record_value(r, q);
    if (!std::isnan(v)) out.push_back(v);
  }
  return out;
}

double record_value(const Json& r, const std::string& q) {
  if (q.rfind("time.", 0) == 0) return median(record_samples(r, q));
  const Json* src = nullptr;
  std::string key = q;
  if (q == "peak_rss_mb") {
    return r.contains(q) && r[q].is_number() ? r[q].get<double>() : std::nan("");
  }
  if (q.rfind("sizes.", 0) == 0) {
    if (r.contains("sizes")) src = &r["sizes"];
    key = q.substr(6);
  } else if (r.contains("metrics")) {
    src = &r["metrics"];
  }
  if (!src || !src->is_object() || !src->contains(key) || !(*src)[key].is_number()) {
    return std::nan("");
  }
  return (*src)[key].get<double>();
}

namespace {

std::string csv_value(const Json& v) {
  if (v.is_null()) return "";
  if (v.is_string()) return csv_field(v.get<std::string>());
  if (v.is_number_float()) return fmt::format("{:.9g}", v.get<double>());
  return csv_field(v.dump());
}

}  // namespace

std::string records_csv(const std::vector<Json>& records) {
  // Union of keys in first-seen order.
  std::vector<std::string> params, metrics, phases;
  std::set<std::string> sp, sm, sph;
  for (const auto& r : records) {
    const Json rp = r.value("params", Json::object()), rm = r.value("metrics", Json::object());
    for (const auto& [k, v] : rp.items())
      if (sp.insert(k).second) params.push_back(k);
    for (const auto& [k, v] : rm.items())
      if (v.is_number() && sm.insert(k).second) metrics.push_back(k);
    const Json timing = r.value("timing", Json::object());
    const Json tp = timing.value("phases", Json::object());
    for (const auto& [k, v] : tp.items())
      if (sph.insert(k).second) phases.push_back(k);
  }
  std::string out = "id,key,status,dataset,scanner,variant,point,seed,repeats";
  for (const auto& k : params)
    out += "," + csv_field("params." + k);
  for (const auto& k : metrics)
    out += "," + csv_field("metrics." + k);
  out += ",time.total_median_s,time.cpu_median_s";
  for (const auto& k : phases)
    out += "," + csv_field("time." + k + "_median_s");
  out += ",peak_rss_mb,error\n";
  for (const auto& r : records) {
    auto label = [&](const char* field) {
      const Json f = r.value(field, Json::object());
      return f.is_object() ? f.value("label", std::string()) : std::string();
    };
    out += fmt::format("{},{},{},{},{},{},{},{},{}", csv_value(r.value("id", Json())),
                       csv_value(r.value("key", Json())), csv_value(r.value("status", Json())),
                       csv_field(label("dataset")), csv_field(label("scanner")),
                       csv_field(label("variant")), csv_value(r.value("point_label", Json())),
                       csv_value(r.value("seed", Json())), csv_value(r.value("repeats", Json())));
    const Json p = r.value("params", Json::object());
    for (const auto& k : params)
      out += "," + csv_value(p.value(k, Json()));
    const Json m = r.value("metrics", Json::object());
    for (const auto& k : metrics)
      out += "," + csv_value(m.value(k, Json()));
    auto num = [](double v) { return std::isnan(v) ? std::string() : fmt::format("{:.9g}", v); };
    out += "," + num(record_value(r, "time.total")) + "," + num(record_value(r, "time.cpu"));
    for (const auto& k : phases)
      out += "," + num(record_value(r, "time." + k));
    out += "," + num(record_value(r, "peak_rss_mb")) + "," + csv_value(r.value("error", Json()));
    out += "\n";
  }
  return out;
}

void write_merged(const fs::path& dir, const std::vector<Json>& records) {
  std::string jsonl;
  for (const auto& r : records)
    jsonl += r.dump() + "\n";
  write_file_atomic(dir / "runs.jsonl", jsonl);
  write_file_atomic(dir / "runs.csv", records_csv(records));
}

}  // namespace scanbench::harness
