#include "scanbench/harness/results/records.h"

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

#include "scanbench/algorithms/peers/open3d_peers.h"
#include "scanbench/algorithms/peers/pcl_peers.h"
#include "scanbench/core/allocator.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/json_text.h"
#include "scanbench/core/simd.h"
#include "scanbench/core/version.h"
#include "scanbench/harness/config/plugins.h"

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

/// The fields of a job record that the readers (table, report, compare, claims, history, eval
/// --from-record) take as given, with their types; `*` is every key of an object or element of
/// an array. A field may be absent (a failed job writes few of them) but never of another type.
/// Written by hand: a JSON Schema validator is not among the project's libraries, and this list
/// is what docs/records.md documents. A type is nlohmann's; number_float stands for any number.
constexpr std::pair<const char*, Json::value_t> kRecordShape[] = {
    {"key", Json::value_t::string},
    {"experiment", Json::value_t::string},
    {"status", Json::value_t::string},
    {"error", Json::value_t::string},
    {"point_label", Json::value_t::string},
    {"output_kind", Json::value_t::string},
    {"seed", Json::value_t::number_float},
    {"repeats", Json::value_t::number_float},
    {"peak_rss_mb", Json::value_t::number_float},
    {"repeat_outputs_identical", Json::value_t::boolean},
    {"dataset", Json::value_t::object},
    {"dataset.label", Json::value_t::string},
    {"dataset.name", Json::value_t::string},
    {"dataset.params", Json::value_t::object},
    {"dataset_origin", Json::value_t::array},
    {"dataset_origin.*", Json::value_t::number_float},
    {"scanner", Json::value_t::object},
    {"scanner.label", Json::value_t::string},
    {"scanner.preset", Json::value_t::string},
    {"scanner.params", Json::value_t::object},
    {"variant", Json::value_t::object},
    {"variant.label", Json::value_t::string},
    {"variant.chain", Json::value_t::array},
    {"variant.chain.*", Json::value_t::object},
    {"variant.chain.*.algorithm", Json::value_t::string},
    {"variant.chain.*.label", Json::value_t::string},
    {"variant.chain.*.params", Json::value_t::object},
    {"params", Json::value_t::object},
    {"point", Json::value_t::object},
    {"metrics", Json::value_t::object},
    {"metric_params", Json::value_t::object},
    {"scoring", Json::value_t::object},
    {"skipped", Json::value_t::object},
    {"skipped.*", Json::value_t::string},
    {"sizes", Json::value_t::object},
    {"sizes.*", Json::value_t::number_float},
    {"limits", Json::value_t::object},
    {"limits.*", Json::value_t::number_float},
    {"artifacts", Json::value_t::object},
    {"artifacts.*", Json::value_t::string},
    {"histograms", Json::value_t::object},
    {"histograms.*", Json::value_t::object},
    {"histograms.*.unit", Json::value_t::string},
    {"histograms.*.min", Json::value_t::number_float},
    {"histograms.*.max", Json::value_t::number_float},
    {"histograms.*.count", Json::value_t::number_float},
    {"histograms.*.counts", Json::value_t::array},
    {"histograms.*.counts.*", Json::value_t::number_float},
    {"timing", Json::value_t::object},
    {"timing.scan_s", Json::value_t::number_float},
    {"timing.scan_cached", Json::value_t::boolean},
    {"timing.total_s", Json::value_t::array},
    {"timing.total_s.*", Json::value_t::number_float},
    {"timing.cpu_s", Json::value_t::array},
    {"timing.cpu_s.*", Json::value_t::number_float},
    {"timing.phases", Json::value_t::object},
    {"timing.phases.*", Json::value_t::array},
    {"timing.phases.*.*", Json::value_t::number_float},
    {"timing.step_peak_rss_mb", Json::value_t::object},
    {"timing.step_peak_rss_mb.*", Json::value_t::number_float},
    {"timing.step_work_mb", Json::value_t::object},
    {"timing.step_work_mb.*", Json::value_t::number_float},
    {"timing.step_program_peak_rss_mb", Json::value_t::object},
    {"timing.step_program_peak_rss_mb.*", Json::value_t::number_float},
    {"timing.metrics_s", Json::value_t::number_float},
    {"timing.metric_phases", Json::value_t::object},
    {"timing.metric_phases.*", Json::value_t::number_float},
    {"timing.job_wall_s", Json::value_t::number_float},
    {"context", Json::value_t::object},
    {"context.scanbench", Json::value_t::string},
    {"context.commit", Json::value_t::string},
    {"context.compiler", Json::value_t::string},
    {"context.build", Json::value_t::string},
    {"context.libraries", Json::value_t::object},
    {"context.libraries.*", Json::value_t::string},
    {"context.plugins", Json::value_t::array},
    {"context.host", Json::value_t::string},
    {"context.cpu", Json::value_t::string},
    {"context.hardware_threads", Json::value_t::number_float},
    {"context.isa", Json::value_t::string},
    {"context.isa_compiled", Json::value_t::string},
    {"context.isa_flags", Json::value_t::string},
    {"context.allocator", Json::value_t::string},
    {"context.date", Json::value_t::string},
    {"context.threads", Json::value_t::number_float},
};

/// kRecordShape with each path split at its dots, once.
struct RecordField {
  std::vector<std::string> path;
  Json::value_t type;
};

const std::vector<RecordField>& record_fields() {
  static const std::vector<RecordField> fields = [] {
    std::vector<RecordField> out;
    for (const auto& [field, type] : kRecordShape) {
      RecordField f{{}, type};
      for (std::string_view rest = field;;) {
        const auto dot = rest.find('.');
        f.path.emplace_back(rest.substr(0, dot));
        if (dot == std::string_view::npos) break;
        rest.remove_prefix(dot + 1);
      }
      out.push_back(std::move(f));
    }
    return out;
  }();
  return fields;
}

/// The steps taken from the record to a value: a key, or (key null) an array index. The field's
/// name is spelled from it only when the check fails.
using Trail = std::vector<std::pair<const std::string*, std::size_t>>;

std::string trail_name(const Trail& trail) {
  std::string name;
  for (const auto& [key, index] : trail)
    name += key ? (name.empty() ? "" : ".") + *key : fmt::format("[{}]", index);
  return name;
}

/// "a number", "an object", "null": nlohmann's type name with its article.
std::string type_phrase(const Json& v) {
  const std::string t = v.type_name();
  if (v.is_null()) return t;
  return (t.find_first_of("aeiou") == 0 ? "an " : "a ") + t;
}

/// Checks the values at F.path[i..] below V against F.type.
void check_path(const Json& v, const RecordField& f, std::size_t i, Trail& trail,
                const std::string& where) {
  if (i == f.path.size()) {
    const bool ok = f.type == Json::value_t::number_float ? v.is_number() : v.type() == f.type;
    if (!ok) {
      throw IoError(
          fmt::format("{}: field \"{}\" is {}, not {} (not a job record scanbench "
                      "wrote; docs/records.md lists the fields)",
                      where, trail_name(trail), type_phrase(v), type_phrase(Json(f.type))));
    }
    return;
  }
  const std::string& part = f.path[i];
  if (part == "*") {
    if (v.is_object()) {
      for (const auto& [k, x] : v.items()) {
        trail.emplace_back(&k, 0);
        check_path(x, f, i + 1, trail, where);
        trail.pop_back();
      }
    } else if (v.is_array()) {
      for (std::size_t e = 0; e < v.size(); ++e) {
        trail.emplace_back(nullptr, e);
        check_path(v[e], f, i + 1, trail, where);
        trail.pop_back();
      }
    }
    return;
  }
  if (!v.is_object() || !v.contains(part)) return;
  trail.emplace_back(&part, 0);
  check_path(v[part], f, i + 1, trail, where);
  trail.pop_back();
}

}  // namespace

void check_record(const Json& r, const std::string& where) {
  if (!r.is_object() || !r.contains("id") || !r["id"].is_string()) {
    throw IoError(fmt::format("{}: not a job record (an object with an \"id\")", where));
  }
  Trail trail;
  for (const RecordField& f : record_fields())
    check_path(r, f, 0, trail, where);
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

Json records_table(const std::vector<Json>& records) {
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
  Json columns = {"id",      "key",   "status", "dataset", "scanner",
                  "variant", "point", "seed",   "repeats"};
  for (const auto& k : params)
    columns.push_back("params." + k);
  for (const auto& k : metrics)
    columns.push_back("metrics." + k);
  columns.push_back("time.total_median_s");
  columns.push_back("time.cpu_median_s");
  for (const auto& k : phases)
    columns.push_back("time." + k + "_median_s");
  columns.push_back("peak_rss_mb");
  columns.push_back("error");
  Json rows = Json::array();
  for (const auto& r : records) {
    auto label = [&](const char* field) {
      const Json f = r.value(field, Json::object());
      return f.is_object() ? f.value("label", std::string()) : std::string();
    };
    Json row = {r.value("id", Json()),
                r.value("key", Json()),
                r.value("status", Json()),
                label("dataset"),
                label("scanner"),
                label("variant"),
                r.value("point_label", Json()),
                r.value("seed", Json()),
                r.value("repeats", Json())};
    const Json p = r.value("params", Json::object());
    for (const auto& k : params)
      row.push_back(p.value(k, Json()));
    const Json m = r.value("metrics", Json::object());
    for (const auto& k : metrics)
      row.push_back(m.value(k, Json()));
    auto num = [](double v) { return std::isnan(v) ? Json() : Json(v); };
    row.push_back(num(record_value(r, "time.total")));
    row.push_back(num(record_value(r, "time.cpu")));
    for (const auto& k : phases)
      row.push_back(num(record_value(r, "time." + k)));
    row.push_back(num(record_value(r, "peak_rss_mb")));
    row.push_back(r.value("error", Json()));
    rows.push_back(std::move(row));
  }
  return {{"columns", std::move(columns)}, {"rows", std::move(rows)}};
}

std::string records_csv(const std::vector<Json>& records) {
  const Json t = records_table(records);
  std::string out;
  for (const auto& c : t["columns"])
    out += (out.empty() ? "" : ",") + csv_field(c.get<std::string>());
  out += "\n";
  for (const auto& row : t["rows"]) {
    std::string line;
    for (std::size_t c = 0; c < row.size(); ++c) {
      const std::string& name = t["columns"][c].get_ref<const std::string&>();
      const Json& v = row[c];
      std::string cell;
      if (c >= 3 && c <= 5) {
        cell = csv_field(v.get<std::string>());  // the labels, always strings
      } else if (name.rfind("time.", 0) == 0 || name == "peak_rss_mb") {
        cell = v.is_null() ? std::string() : fmt::format("{:.9g}", v.get<double>());
      } else {
        cell = csv_value(v);
      }
      line += (c == 0 ? "" : ",") + cell;
    }
    out += line + "\n";
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
