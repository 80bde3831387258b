#include "scanbench/harness/exec/runner.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <optional>
#include <regex>
#include <set>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "scanbench/core/errors.h"
#include "scanbench/core/run_program.h"
#include "scanbench/harness/config/plugins.h"
#include "scanbench/harness/results/records.h"

namespace scanbench::harness {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

std::string duration_text(double s) {
  if (!std::isfinite(s) || s < 0) return "?";
  const int t = static_cast<int>(std::lround(s));
  if (t >= 3600) return fmt::format("{}h{:02d}m", t / 3600, t / 60 % 60);
  if (t >= 60) return fmt::format("{}m{:02d}s", t / 60, t % 60);
  return fmt::format("{}s", t);
}

/// A progress bar with ETA on a terminal; one plain line per finished job otherwise.
class Progress {
 public:
  Progress(int total, int concurrency, bool quiet)
      : total_(total), concurrency_(concurrency), quiet_(quiet), tty_(isatty(STDERR_FILENO) != 0) {
    start_ = Clock::now();
  }
  void finished(const std::string& key, const std::string& status, double seconds) {
    ++done_;
    if (status != "ok") ++failed_;
    sum_s_ += seconds;
    if (quiet_) return;
    const double eta = sum_s_ / done_ * (total_ - done_) / concurrency_;
    if (tty_) {
      const int width = 30;
      const int filled = total_ ? width * done_ / total_ : width;
      std::string bar(filled, '#');
      bar += std::string(width - filled, '.');
      if (status != "ok") std::fprintf(stderr, "\r\033[K%s: %s\n", status.c_str(), key.c_str());
      std::fprintf(stderr, "\r\033[K[%s] %d/%d  failed %d  elapsed %s  ETA %s", bar.c_str(), done_,
                   total_, failed_, duration_text(elapsed()).c_str(), duration_text(eta).c_str());
      if (done_ == total_) std::fprintf(stderr, "\n");
    } else {
      std::fprintf(stderr, "[%d/%d] %-7s %7.2fs  %s  (ETA %s)\n", done_, total_, status.c_str(),
                   seconds, key.c_str(), duration_text(eta).c_str());
    }
    std::fflush(stderr);
  }
  double elapsed() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }

 private:
  int total_, concurrency_;
  bool quiet_, tty_;
  int done_ = 0, failed_ = 0;
  double sum_s_ = 0;
  Clock::time_point start_;
};

struct Child {
  pid_t pid = -1;
  const Job* job = nullptr;
  Clock::time_point start;
  std::string date;
  fs::path spec, result, log;
  bool timed_out = false;
};

pid_t spawn(const fs::path& exe, const Child& c, double memory_limit_mb) {
  // Everything the child needs is prepared before fork (no allocation after it).
  const std::string exe_s = exe.string(), spec_s = c.spec.string(), result_s = c.result.string(),
                    log_s = c.log.string();
  const char* argv[] = {exe_s.c_str(), "job", spec_s.c_str(), result_s.c_str(), nullptr};
  const rlim_t limit = static_cast<rlim_t>(memory_limit_mb * 1024.0 * 1024.0);
#ifdef SCANBENCH_SANITIZE
  // Sanitizer builds cannot limit the address space (see below): the child's AddressSanitizer
  // enforces the limit on its resident set instead (hard_rss_limit_mb; the log then says "hard
  // rss limit exhausted", which finish() records as status "memory").
  const char* prev_options = std::getenv("ASAN_OPTIONS");
  const std::string asan_options =
      fmt::format("ASAN_OPTIONS={}{}hard_rss_limit_mb={}", prev_options ? prev_options : "",
                  prev_options && *prev_options ? ":" : "", static_cast<long>(memory_limit_mb));
  std::vector<const char*> envp;
  for (char** e = environ; *e != nullptr; ++e) {
    if (std::strncmp(*e, "ASAN_OPTIONS=", 13) != 0) envp.push_back(*e);
  }
  envp.push_back(asan_options.c_str());
  envp.push_back(nullptr);
#endif
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) throw Error(fmt::format("run: fork failed: {}", std::strerror(errno)));
  if (pid == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(125);
    // The parent removed any earlier log (or a link in its place): a fresh file, never written
    // through a link.
    const int fd = open(log_s.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd >= 0) {
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
      close(fd);
    }
#ifndef SCANBENCH_SANITIZE
    struct rlimit rl {
      limit, limit
    };
    setrlimit(RLIMIT_AS, &rl);
#else
    // AddressSanitizer reserves terabytes of address space for its shadow memory, so an address-
    // space limit stops the child before main(); sanitizer builds (cmake/Sanitizers.cmake) run
    // jobs without the memory limit.
    (void)limit;
#endif
#ifdef SCANBENCH_SANITIZE
    execve(argv[0], const_cast<char* const*>(argv), const_cast<char* const*>(envp.data()));
#else
    execv(argv[0], const_cast<char* const*>(argv));
#endif
    _exit(127);
  }
  return pid;
}

// A child's log, whole ("" when it cannot be read: the child may have died before opening it).
std::string read_log(const fs::path& log) {
  try {
    return read_file(log);
  } catch (const Error&) {
    return "";
  }
}

// The last `max_chars` of the log on one line.
std::string last_lines(std::string text, std::size_t max_chars = 300) {
  while (!text.empty() && (text.back() == '\n' || text.back() == ' '))
    text.pop_back();
  if (text.size() > max_chars) text = "..." + text.substr(text.size() - max_chars);
  for (char& ch : text)
    if (ch == '\n') ch = ' ';
  return text;
}

// The first line of the log holding `needle`, without its newline ("" when none).
// AddressSanitizer prints its verdict first and a process memory map of a thousand lines after it,
// so the tail of the log does not show why a sanitized child stopped.
std::string line_with(std::string_view text, std::string_view needle) {
  const std::size_t at = text.find(needle);
  if (at == std::string_view::npos) return "";
  const std::size_t nl = text.rfind('\n', at);
  const std::size_t begin = nl == std::string_view::npos ? 0 : nl + 1;
  return std::string(text.substr(begin, text.find('\n', at) - begin));
}

Json base_record(const Job& job) {
  Json r = Json::object();
  r["id"] = job.id;
  r["key"] = job.key;
  r["experiment"] = job.experiment;
  r["status"] = "ok";
  r["error"] = "";
  r["dataset"] = {
      {"label", job.dataset_label}, {"name", job.dataset}, {"params", job.dataset_params}};
  r["scanner"] = {
      {"label", job.scanner_label}, {"preset", job.scanner_preset}, {"params", job.scanner_params}};
  r["variant"] = {{"label", job.variant}, {"chain", job.chain}};
  r["point"] = job.point;
  r["point_label"] = job.point_label;
  r["seed"] = job.seed;
  r["repeats"] = job.repeats;
  r["params"] = job.flat_params();
  return r;
}

Json finish_record(const Child& c, int wstatus, const struct rusage& ru, const Json& context) {
  const Job& job = *c.job;
  Json r = base_record(job);
  Json result;
  if (fs::exists(c.result)) {
    try {
      result = read_json_file(c.result);
    } catch (const Error&) {
      result = Json();
    }
  }
  std::string status, error;
  const std::string log_text = read_log(c.log);
  const std::string log_tail = last_lines(log_text);
  if (c.timed_out) {
    status = "timeout";
    error = fmt::format("killed after the per-job timeout of {} s", job.timeout_s);
  } else if (WIFSIGNALED(wstatus)) {
    const int sig = WTERMSIG(wstatus);
    const bool alloc = log_tail.find("bad_alloc") != std::string::npos;
    status = alloc ? "memory" : "crash";
    error = fmt::format(
        "killed by signal {} ({}){}", sig, sigdescr_np(sig) ? sigdescr_np(sig) : "",
        alloc ? fmt::format(" after failing to allocate under the {} MB limit", job.memory_limit_mb)
              : "");
    if (!log_tail.empty()) error += ": " + log_tail;
  } else if (const std::string rss = result.is_object()
                                         ? std::string()
                                         : line_with(log_text, "hard rss limit exhausted");
             !rss.empty()) {
    // A sanitizer build's child over its memory limit (see spawn).
    status = "memory";
    error =
        fmt::format("exceeded the {} MB limit on its resident set: {}", job.memory_limit_mb, rss);
  } else if (result.is_object() && result.contains("status")) {
    status = result.value("status", std::string("error"));
    error = result.value("error", std::string());
  } else {
    status = "crash";
    error = fmt::format("exited with code {} without a result", WEXITSTATUS(wstatus));
    if (!log_tail.empty()) error += ": " + log_tail;
  }
  r["status"] = status;
  r["error"] = error;
  Json timing = Json::object();
  if (result.is_object()) {
    for (const char* k :
         {"metrics", "histograms", "metric_params", "skipped", "scoring", "sizes", "artifacts",
          "repeat_outputs_identical", "output_kind", "dataset_origin"}) {
      if (result.contains(k)) r[k] = result[k];
    }
    if (result.contains("timing")) timing = result["timing"];
  }
  if (!r.contains("metrics")) r["metrics"] = Json::object();
  timing["job_wall_s"] = std::chrono::duration<double>(Clock::now() - c.start).count();
  r["timing"] = timing;
  r["peak_rss_mb"] = static_cast<double>(ru.ru_maxrss) / 1024.0;
  r["limits"] = {{"timeout_s", job.timeout_s}, {"memory_limit_mb", job.memory_limit_mb}};
  if (!r.contains("artifacts")) r["artifacts"] = Json::object();
  r["artifacts"]["log"] = fs::relative(c.log, c.log.parent_path().parent_path()).string();
  Json ctx = context;
  ctx["threads"] = job.threads;
  ctx["date"] = c.date;
  r["context"] = ctx;
  return r;
}

}  // namespace

namespace {

/// DIR/<sub> as a real folder: created when missing; a symbolic link or a file in its place is
/// refused (the harness writes nothing through a link it did not make). The one link it makes,
/// DIR/scans -> ../scans (claims and protocol tunings share their parent's scan cache), is kept.
void ensure_subfolder(const fs::path& dir, const char* sub) {
  const fs::path p = dir / sub;
  const fs::file_status st = fs::symlink_status(p);
  if (fs::is_symlink(st)) {
    if (std::string_view(sub) == "scans" && fs::read_symlink(p) == fs::path("..") / "scans") return;
    throw IoError(fmt::format(
        "{}: is a symbolic link; scanbench writes nothing in a results folder through a link it "
        "did not make (remove it, or choose another folder with -o)",
        p.string()));
  }
  if (fs::exists(st) && !fs::is_directory(st)) {
    throw IoError(fmt::format("{}: is not a folder (a file is in its place)", p.string()));
  }
  std::error_code ec;
  fs::create_directory(p, ec);
  if (ec) throw IoError(fmt::format("{}: cannot create the folder: {}", p.string(), ec.message()));
}

/// Removes what killed runs left behind: every entry of DIR/tmp, and the temp files (names
/// starting with '.') in the record, cache and artifact folders. Called under the folder's lock,
/// so no other writer owns them. fs::remove on a link removes the link, never its target.
void remove_leftovers(const fs::path& dir) {
  std::error_code ec;
  auto remove_entry = [&](const fs::directory_entry& entry) {
    if (fs::is_directory(entry.symlink_status())) {
      fs::remove_all(entry.path(), ec);  // does not follow links inside
    } else {
      fs::remove(entry.path(), ec);
    }
    if (ec) {
      throw IoError(
          fmt::format("{}: cannot remove a leftover: {}", entry.path().string(), ec.message()));
    }
  };
  for (const auto& entry : fs::directory_iterator(dir / "tmp"))
    remove_entry(entry);
  for (const char* sub : {"jobs", "scans", "outputs", "logs", "fields"}) {
    const fs::path p = dir / sub;
    if (!fs::is_directory(fs::symlink_status(p))) continue;  // absent, or the shared scans link
    for (const auto& entry : fs::directory_iterator(p)) {
      if (entry.path().filename().string().front() == '.') remove_entry(entry);
    }
  }
  for (const auto& entry : fs::directory_iterator(dir))
    if (is_temp_name(entry.path().filename().string())) remove_entry(entry);
}

/// The first JSON pointer at which two configs differ ("" when equal).
std::string first_difference(const Json& a, const Json& b) {
  const Json patch = Json::diff(a, b);
  if (patch.empty()) return "";
  const std::string path = patch[0].value("path", std::string());
  return path.empty() ? "/" : path;
}

/// Refuses a folder that holds another experiment: its config.json's config differs from `e`'s.
void check_same_experiment(const Experiment& e, const fs::path& out) {
  const fs::path file = out / "config.json";
  if (!fs::exists(fs::symlink_status(file))) return;
  const Json held = read_json_file(file);
  const Json held_config = held.is_object() ? held.value("config", Json()) : Json();
  const std::string at = first_difference(held_config, e.raw);
  if (at.empty()) return;
  throw ParamError(fmt::format(
      "{}: holds the results of another experiment ('{}'; its config.json differs at {}); "
      "choose another folder with -o",
      out.string(),
      held_config.is_object() ? held_config.value("name", std::string("?")) : std::string("?"),
      at));
}

}  // namespace

PreparedRun prepare_run(const Experiment& e, const RunOptions& opts) {
  PreparedRun prep;
  const fs::path out = opts.out;
  prep.lock = std::make_shared<FolderLock>(FolderLock::acquire(out, opts.command, 0, true));
  prep.plan = expand(e);
  const Plan& plan = prep.plan;
  std::optional<std::regex> filter;
  if (!opts.filter.empty()) {
    try {
      filter.emplace(opts.filter, std::regex::ECMAScript);
    } catch (const std::regex_error& ex) {
      throw ParamError(fmt::format("--filter '{}': not a valid regex: {}", opts.filter, ex.what()));
    }
    if (std::none_of(plan.jobs.begin(), plan.jobs.end(),
                     [&](const Job& j) { return std::regex_search(j.key, *filter); })) {
      throw ParamError(fmt::format(
          "--filter '{}': selects none of the plan's {} jobs (it is matched against keys such "
          "as '{}')",
          opts.filter, plan.jobs.size(),
          plan.jobs.empty() ? std::string() : plan.jobs.front().key));
    }
  }
  for (const char* sub : {"jobs", "scans", "outputs", "logs", "tmp"})
    ensure_subfolder(out, sub);
  check_same_experiment(e, out);

  std::set<std::string> recorded;
  for (const auto& entry : fs::directory_iterator(out / "jobs")) {
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() == ".json" && name.front() != '.') {
      recorded.insert(entry.path().stem().string());
    }
  }
  std::set<std::string> plan_ids;
  for (const auto& j : plan.jobs)
    plan_ids.insert(j.id);
  if (!opts.resume) {
    for (const auto& id : recorded) {
      if (plan_ids.count(id)) {
        throw ParamError(fmt::format(
            "{}: holds records of an earlier run; pass --resume to continue it, or choose another "
            "folder with -o",
            out.string()));
      }
    }
  }
  remove_leftovers(out);

  Json config = Json::object();
  config["source"] = e.file.empty() ? Json(nullptr) : Json(fs::absolute(e.file).string());
  config["config"] = e.raw;
  write_json_file(out / "config.json", config, 2);
  Json plan_json = Json::object();
  plan_json["experiment"] = e.name;
  plan_json["notes"] = plan.notes;
  Json jobs_json = Json::array();
  for (const auto& j : plan.jobs)
    jobs_json.push_back(j.to_json());
  plan_json["jobs"] = std::move(jobs_json);
  write_json_file(out / "plan.json", plan_json);

  if (!opts.quiet) {
    for (const auto& n : plan.notes)
      std::fprintf(stderr, "note: %s\n", n.c_str());
  }

  RunSummary& summary = prep.summary;
  for (std::size_t i = 0; i < plan.jobs.size(); ++i) {
    const Job& job = plan.jobs[i];
    if (filter && !std::regex_search(job.key, *filter)) continue;
    ++summary.planned;
    if (opts.resume && recorded.count(job.id)) {
      const std::string status =
          read_record_file(out / "jobs" / (job.id + ".json")).value("status", std::string());
      // "interrupted": the scheduler stopped the job (records.h), it has no outcome of its own.
      const bool again = status == "interrupted" || (opts.retry_failed && status != "ok");
      if (!again) {
        ++summary.skipped;
        continue;
      }
    }
    prep.todo.push_back(i);
  }
  return prep;
}

void run_jobs(const std::vector<const Job*>& jobs, const RunOptions& opts, RunSummary& summary,
              const RunHooks& hooks) {
  const fs::path out = opts.out;
  std::deque<const Job*> todo(jobs.begin(), jobs.end());
  const fs::path exe = opts.exe.empty() ? fs::read_symlink("/proc/self/exe") : opts.exe;
  const Json context = run_context_json();
  Progress progress(static_cast<int>(todo.size()), std::max(1, opts.jobs), opts.quiet);
  std::vector<Child> running;
  bool stopping = false;
  while ((!todo.empty() && !stopping) || !running.empty()) {
    if (!stopping && hooks.stop && hooks.stop()) {
      // Stop now: kill the running children (their records say why, see amend) and start no more.
      stopping = true;
      for (auto& c : running)
        kill(c.pid, SIGKILL);
    }
    while (!stopping && !todo.empty() &&
           static_cast<int>(running.size()) < std::max(1, opts.jobs)) {
      Child c;
      c.job = todo.front();
      todo.pop_front();
      c.spec = out / "tmp" / (c.job->id + ".spec.json");
      c.result = out / "tmp" / (c.job->id + ".result.json");
      c.log = out / "logs" / (c.job->id + ".log");
      Json spec = {{"job", c.job->to_json()}, {"out", fs::absolute(out).string()}};
      if (!loaded_plugins().empty()) spec["plugins"] = plugins_json();  // the child loads them
      write_file_atomic(c.spec, spec.dump());
      fs::remove(c.result);  // a link is removed itself, never its target
      fs::remove(c.log);
      if (hooks.started) hooks.started(*c.job);
      c.date = utc_now();
      c.start = Clock::now();
      c.pid = spawn(exe, c, c.job->memory_limit_mb);
      running.push_back(std::move(c));
    }
    bool reaped = false;
    for (auto it = running.begin(); it != running.end();) {
      int wstatus = 0;
      struct rusage ru {};
      const pid_t r = wait4(it->pid, &wstatus, WNOHANG, &ru);
      if (r == it->pid) {
        Json record = finish_record(*it, wstatus, ru, context);
        if (hooks.amend) hooks.amend(*it->job, record);
        write_json_file(out / "jobs" / (it->job->id + ".json"), record);
        const std::string status = record["status"].get<std::string>();
        ++summary.ran;
        ++summary.by_status[status];
        progress.finished(it->job->key, status, record["timing"]["job_wall_s"].get<double>());
        fs::remove(it->spec);
        fs::remove(it->result);
        it = running.erase(it);
        reaped = true;
        // The job's processes end with it: what its steps orphaned (and a killed job's child
        // left) was reparented to this subreaper (cli.cpp: become_subreaper).
        std::vector<int> keep;
        for (const auto& c : running)
          keep.push_back(c.pid);
        programs::reap_orphans(keep);
        continue;
      }
      if (!it->timed_out &&
          std::chrono::duration<double>(Clock::now() - it->start).count() > it->job->timeout_s) {
        kill(it->pid, SIGKILL);
        it->timed_out = true;
      }
      ++it;
    }
    if (!reaped) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

std::vector<Json> merge_records(const fs::path& out) {
  // The plan's jobs with records, in plan order (records of jobs no longer planned are left out).
  std::vector<Json> records;
  const fs::path plan_file = out / "plan.json";
  const Json plan = read_json_file(plan_file);
  if (!plan.is_object() || !plan.contains("jobs") || !plan["jobs"].is_array()) {
    throw IoError(fmt::format("{}: field \"jobs\" is not an array of jobs", plan_file.string()));
  }
  for (const auto& job : plan["jobs"]) {
    if (!job.is_object() || !job.contains("id") || !job["id"].is_string()) {
      throw IoError(fmt::format("{}: a job without a string \"id\"", plan_file.string()));
    }
    const fs::path p = out / "jobs" / (job["id"].get<std::string>() + ".json");
    if (fs::exists(p)) records.push_back(read_record_file(p));
  }
  write_merged(out, records);
  return records;
}

namespace {

volatile std::sig_atomic_t g_interrupted = 0;
extern "C" void on_interrupt(int) {
  g_interrupted = 1;
}

/// SIGINT and SIGTERM handled for the life of this value (then restored): the runner stops its
/// children and records them instead of dying with its records half-merged.
class InterruptGuard {
 public:
  InterruptGuard() {
    g_interrupted = 0;
    struct sigaction sa {};
    sa.sa_handler = on_interrupt;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    sigaction(SIGINT, &sa, &old_int_);
    sigaction(SIGTERM, &sa, &old_term_);
  }
  ~InterruptGuard() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  InterruptGuard(const InterruptGuard&) = delete;
  InterruptGuard& operator=(const InterruptGuard&) = delete;

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
};

}  // namespace

RunSummary run_experiment(const Experiment& e, const RunOptions& opts) {
  PreparedRun prep = prepare_run(e, opts);
  std::vector<const Job*> todo;
  for (std::size_t i : prep.todo)
    todo.push_back(&prep.plan.jobs[i]);
  if (!opts.quiet) {
    std::fprintf(stderr,
                 "%s: %zu jobs planned, %d selected, %d already done, %zu to run (%d at a "
                 "time) -> %s\n",
                 e.name.c_str(), prep.plan.jobs.size(), prep.summary.planned, prep.summary.skipped,
                 todo.size(), opts.jobs, opts.out.string().c_str());
  }
  {
    const InterruptGuard guard;
    RunHooks hooks;
    hooks.stop = [] { return g_interrupted != 0; };
    // Ctrl-C reaches the children too (one process group): a job that died of it, or that the
    // stop killed, did not fail; it was stopped, and --resume runs it again.
    hooks.amend = [](const Job&, Json& r) {
      if (g_interrupted && r.value("status", std::string()) != "ok") {
        r["status"] = "interrupted";
        r["error"] = "stopped by SIGINT/SIGTERM (Ctrl-C) before it finished";
      }
    };
    run_jobs(todo, opts, prep.summary, hooks);
  }
  merge_records(opts.out);
  if (g_interrupted) {
    const int done = prep.summary.by_status.count("ok") ? prep.summary.by_status.at("ok") : 0;
    const std::string again =
        opts.command == "scanbench run"
            ? fmt::format("scanbench run {} -o {} --resume",
                          e.file.empty() ? std::string("CONFIG") : e.file.string(),
                          opts.out.string())
            : "the same command with --resume";
    throw Interrupted(fmt::format(
        "{}: interrupted after {} of {} jobs; the finished ones are recorded; resume with: {}",
        opts.out.string(), done + prep.summary.skipped, prep.summary.planned, again));
  }
  return prep.summary;
}

Json failure_record(const Job& job, const std::string& status, const std::string& error,
                    const fs::path& out) {
  Json r = base_record(job);
  r["status"] = status;
  r["error"] = error;
  r["metrics"] = Json::object();
  r["timing"] = Json::object();
  r["limits"] = {{"timeout_s", job.timeout_s}, {"memory_limit_mb", job.memory_limit_mb}};
  r["artifacts"] = Json::object();
  if (fs::exists(out / "logs" / (job.id + ".log")))
    r["artifacts"]["log"] = "logs/" + job.id + ".log";
  Json ctx = run_context_json();
  ctx["threads"] = job.threads;
  r["context"] = ctx;
  return r;
}

int run_job_file(const fs::path& spec_path, const fs::path& result_path) {
  Json result = Json::object();
  try {
    const Json spec = read_json_file(spec_path);
    if (spec.contains("plugins")) load_spec_plugins(spec["plugins"]);
    const Job job = Job::from_json(spec.at("job"));
    result = execute_job(job, spec.at("out").get<std::string>());
    result["status"] = "ok";
  } catch (const std::bad_alloc&) {
    result = Json::object();
    result["status"] = "memory";
    result["error"] = "out of memory: allocation failed under the per-job memory limit";
  } catch (const Error& ex) {
    result = Json::object();
    result["status"] = "error";
    result["error"] = ex.what();
  } catch (const std::exception& ex) {
    result = Json::object();
    result["status"] = "error";
    result["error"] = fmt::format("internal error: {}", ex.what());
  }
  programs::reap_orphans();  // nothing a step started outlives its job
  write_file_atomic(result_path, result.dump());
  return 0;
}

RecordsRunner local_records_runner(int jobs, bool resume, bool quiet, const fs::path& exe) {
  return [=](const Json& config, const fs::path& out) {
    const Experiment e = parse_experiment(config, (out / "config.json").string());
    RunOptions o;
    o.out = out;
    o.jobs = jobs;
    o.resume = resume;
    o.quiet = quiet;
    o.exe = exe;
    run_experiment(e, o);
    return load_records(out);
  };
}

}  // namespace scanbench::harness
