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
#include <thread>

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

std::vector<Json> load_job_records(const fs::path& dir) {
  std::map<std::string, Json> by_id;
  const fs::path jobs = dir / "jobs";
  if (fs::is_directory(jobs)) {
    for (const auto& entry : fs::directory_iterator(jobs)) {
      const fs::path p = entry.path();
      if (p.extension() != ".json" || p.filename().string().front() == '.') continue;
      Json r = read_json_file(p);
      if (!r.is_object() || !r.contains("id") || !r["id"].is_string()) {
        throw IoError(fmt::format("{}: not a job record (no \"id\")", p.string()));
      }
      const std::string id = r["id"].get<std::string>();  // before r is moved from
      by_id[id] = std::move(r);
    }
  }
  std::vector<Json> out;
  if (fs::exists(dir / "plan.json")) {
    const Json plan = read_json_file(dir / "plan.json");
    if (plan.contains("jobs") && plan["jobs"].is_array()) {
      for (const auto& job : plan["jobs"]) {
        auto it = by_id.find(job.value("id", ""));
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
    if (!r.is_object() || !r.contains("id") || !r["id"].is_string()) {
      throw IoError(fmt::format("{}: not a job record (an object with an \"id\")", where));
    }
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
