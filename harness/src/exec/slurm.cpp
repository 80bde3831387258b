#include "scanbench/harness/exec/slurm.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <poll.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <ctime>
#include <map>
#include <set>
#include <sstream>
#include <thread>

#include "scanbench/harness/config/plugins.h"
#include "scanbench/harness/results/records.h"

namespace scanbench::harness {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

// ---- running Slurm's commands ---------------------------------------------------------------

std::string find_on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (!path) return "";
  std::istringstream in(path);
  for (std::string d; std::getline(in, d, ':');) {
    if (d.empty()) continue;
    const fs::path p = fs::path(d) / name;
    if (::access(p.c_str(), X_OK) == 0 && !fs::is_directory(p)) return p.string();
  }
  return "";
}

std::string trim(std::string s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back())))
    s.pop_back();
  std::size_t i = 0;
  while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i])))
    ++i;
  return s.substr(i);
}

/// The first non-empty line of a command's output (for one-line error messages).
std::string first_line(const std::string& text) {
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    line = trim(line);
    if (!line.empty()) return line;
  }
  return "(no output)";
}

struct CommandResult {
  int code = -1;  ///< exit code; -1 when killed (timeout) or not started
  std::string out;
  bool timed_out = false;
};

/// Runs argv[0] (an absolute path) with stdin from /dev/null; captures stdout and stderr;
/// kills it after timeout_s.
CommandResult run_command(const std::vector<std::string>& argv, double timeout_s) {
  std::vector<char*> args;
  for (const auto& a : argv)
    args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw SchedulerError("slurm: pipe failed");
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw SchedulerError("slurm: fork failed");
  }
  if (pid == 0) {
    const int nul = ::open("/dev/null", O_RDONLY);
    if (nul >= 0) ::dup2(nul, STDIN_FILENO);
    ::dup2(fds[1], STDOUT_FILENO);
    ::dup2(fds[1], STDERR_FILENO);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  ::close(fds[1]);
  CommandResult r;
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  char buf[4096];
  for (;;) {
    const double left = std::chrono::duration<double>(deadline - Clock::now()).count();
    if (left <= 0) {
      ::kill(pid, SIGKILL);
      r.timed_out = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int n = ::poll(&p, 1, static_cast<int>(std::ceil(left * 1000)));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) continue;
    const ssize_t got = ::read(fds[0], buf, sizeof(buf));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) break;
    r.out.append(buf, static_cast<std::size_t>(got));
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  r.code = !r.timed_out && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

struct Tools {
  std::string sbatch, squeue, scontrol, sinfo, scancel;
};

/// The client commands, or SchedulerError naming the first one missing.
Tools find_tools() {
  Tools t;
  for (auto [name, dst] : {std::pair{"sbatch", &t.sbatch}, std::pair{"squeue", &t.squeue},
                           std::pair{"scontrol", &t.scontrol}, std::pair{"sinfo", &t.sinfo},
                           std::pair{"scancel", &t.scancel}}) {
    *dst = find_on_path(name);
    if (dst->empty()) {
      throw SchedulerError(
          fmt::format("slurm: {} not found on PATH (install Slurm's client commands, e.g. Debian's "
                      "slurm-client, or run without --executor slurm)",
                      name));
    }
  }
  return t;
}

constexpr double kCommandTimeout = 60.0;

void check_controller(const Tools& t) {
  const CommandResult r = run_command({t.scontrol, "ping"}, 30.0);
  if (r.code != 0 || r.out.find(" is UP") == std::string::npos) {
    throw SchedulerError(fmt::format("slurm: the controller does not answer (scontrol ping: {}{})",
                                     first_line(r.out),
                                     r.timed_out ? ", no answer within 30 s" : ""));
  }
}

void check_partition(const Tools& t, const std::string& partition) {
  if (partition.empty()) return;
  const CommandResult r = run_command({t.sinfo, "-h", "-o", "%P"}, kCommandTimeout);
  if (r.code != 0) {
    throw SchedulerError(fmt::format("slurm: sinfo failed: {}", first_line(r.out)));
  }
  std::vector<std::string> known;
  std::istringstream in(r.out);
  for (std::string line; std::getline(in, line);) {
    line = trim(line);
    if (!line.empty() && line.back() == '*') line.pop_back();  // the default partition
    if (!line.empty() && std::find(known.begin(), known.end(), line) == known.end()) {
      known.push_back(line);
    }
  }
  if (std::find(known.begin(), known.end(), partition) == known.end()) {
    std::string list;
    for (const auto& k : known)
      list += (list.empty() ? "" : ", ") + k;
    throw SchedulerError(fmt::format("slurm: unknown partition '{}' (the cluster has: {})",
                                     partition, list.empty() ? "none" : list));
  }
}

struct QueueEntry {
  std::string id;         ///< %i: "12_3" or "13"
  std::string array_job;  ///< %F: the array's job id (the job id itself for a plain job)
  std::string task;       ///< %K: the array task id, "N/A" for a plain job
  std::string state;      ///< %T: PENDING, RUNNING, COMPLETING, ...
  std::string reason;     ///< %r
  std::string node;       ///< %N
  std::string time;       ///< %M
};

/// Every job in the queue named `tag` or `tag`-merge (one line per array task).
std::vector<QueueEntry> query_queue(const std::string& squeue, const std::string& tag) {
  const CommandResult r = run_command(
      {squeue, "-h", "-r", "-n", tag + "," + tag + "-merge", "-o", "%i|%F|%K|%T|%r|%N|%M"},
      kCommandTimeout);
  if (r.code != 0) {
    throw SchedulerError(fmt::format("slurm: squeue failed: {}{}", first_line(r.out),
                                     r.timed_out ? " (no answer within 60 s)" : ""));
  }
  std::vector<QueueEntry> out;
  std::istringstream in(r.out);
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> f;
    std::istringstream fs_(line);
    for (std::string x; std::getline(fs_, x, '|');)
      f.push_back(trim(x));
    if (f.size() < 7) continue;
    out.push_back({f[0], f[1], f[2], f[3], f[4], f[5], f[6]});
  }
  return out;
}

/// The job id of `sbatch --parsable` ("12" or "12;cluster").
std::string parsable_job_id(const CommandResult& r) {
  std::istringstream in(r.out);
  std::string last;
  for (std::string line; std::getline(in, line);)
    if (!trim(line).empty()) last = trim(line);
  last = last.substr(0, last.find(';'));
  if (last.empty() || !std::all_of(last.begin(), last.end(), ::isdigit)) return "";
  return last;
}

// ---- the results folder's Slurm files ---------------------------------------------------------

std::string folder_tag(const fs::path& dir) {
  return "sb-" + content_hash(fs::weakly_canonical(fs::absolute(dir)).string()).substr(0, 8);
}

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s)
    out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

/// Submission folders in DIR/slurm, by number.
std::vector<std::string> submission_ids(const fs::path& dir) {
  std::vector<std::string> ids;
  if (!fs::is_directory(dir / "slurm")) return ids;
  for (const auto& e : fs::directory_iterator(dir / "slurm")) {
    const std::string n = e.path().filename().string();
    if (e.is_directory() && !n.empty() && std::all_of(n.begin(), n.end(), ::isdigit) &&
        fs::exists(e.path() / "submission.json")) {
      ids.push_back(n);
    }
  }
  // Numeric order of digit strings without converting them (a planted name of 30 digits would
  // overflow std::stol): shorter first once leading zeros are dropped, then lexicographic.
  auto digits = [](const std::string& n) {
    const auto nz = n.find_first_not_of('0');
    return nz == std::string::npos ? std::string() : n.substr(nz);
  };
  std::sort(ids.begin(), ids.end(), [&](const std::string& a, const std::string& b) {
    const std::string x = digits(a), y = digits(b);
    return x.size() != y.size() ? x.size() < y.size() : x < y;
  });
  return ids;
}

/// The "*** JOB 12 ON node CANCELLED AT 2026-... [DUE TO TIME LIMIT] ***" line that slurmstepd
/// writes to a task's output when it stops it (the text between the stars), from byte `offset`
/// on; the last one when there are several, "" when none.
std::string stop_line(const fs::path& out_file, std::uintmax_t offset) {
  std::string text;
  try {
    text = read_file(out_file);
  } catch (const Error&) {
    return "";
  }
  if (offset > text.size()) offset = 0;  // truncated meanwhile
  std::istringstream in(text.substr(static_cast<std::size_t>(offset)));
  std::string found;
  for (std::string line; std::getline(in, line);) {
    const auto a = line.find("*** ");
    const auto b = line.rfind(" ***");
    if (a != std::string::npos && b != std::string::npos && b > a + 4 &&
        (line.find("CANCELLED", a) != std::string::npos ||
         line.find("DUE TO", a) != std::string::npos)) {
      found = line.substr(a + 4, b - a - 4);
    }
  }
  return found;
}

/// JobState and Reason of one job from `scontrol show job -o` ("" when Slurm no longer knows it).
std::pair<std::string, std::string> scontrol_state(const std::string& scontrol,
                                                   const std::string& job) {
  if (scontrol.empty()) return {"", ""};
  const CommandResult r = run_command({scontrol, "show", "job", "-o", job}, kCommandTimeout);
  if (r.code != 0) return {"", ""};
  auto field = [&](const std::string& name) {
    const auto p = r.out.find(" " + name + "=");
    if (p == std::string::npos) return std::string();
    const auto s = p + name.size() + 2;
    return r.out.substr(s, r.out.find(' ', s) - s);
  };
  return {field("JobState"), field("Reason")};
}

std::string status_of_slurm_state(const std::string& state, const std::string& line) {
  if (state == "TIMEOUT" || state == "DEADLINE" ||
      line.find("DUE TO TIME LIMIT") != std::string::npos)
    return "timeout";
  if (state == "OUT_OF_MEMORY") return "memory";
  return "interrupted";
}

std::map<std::string, Job> plan_jobs(const fs::path& dir, std::vector<std::string>* order) {
  const Json plan = read_json_file(dir / "plan.json");
  std::map<std::string, Job> jobs;
  for (const auto& j : plan.at("jobs")) {
    Job job = Job::from_json(j);
    if (order) order->push_back(job.id);
    const std::string id = job.id;
    jobs.emplace(id, std::move(job));
  }
  return jobs;
}

volatile std::sig_atomic_t g_stop_requested = 0;

extern "C" void on_sigterm(int) {
  g_stop_requested = 1;
}

}  // namespace

// ---- submit -----------------------------------------------------------------------------------

std::string resume_command(const fs::path& dir) {
  std::string source = "CONFIG";
  try {
    const Json c = read_json_file(dir / "config.json");
    if (c.contains("source") && c["source"].is_string()) source = c["source"].get<std::string>();
  } catch (const Error&) {
  }
  const bool slurm = fs::is_directory(dir / "slurm") && !submission_ids(dir).empty();
  return fmt::format("scanbench run {} -o {}{} --resume", shell_quote(source),
                     shell_quote(dir.string()), slurm ? " --executor slurm" : "");
}

namespace {

/// Throws SchedulerError ending with `consequence` when Slurm jobs of `dir` are in the queue.
void refuse_if_queued(const std::string& squeue, const fs::path& dir,
                      std::string_view consequence) {
  const std::vector<QueueEntry> queued = query_queue(squeue, folder_tag(dir));
  if (queued.empty()) return;
  std::set<std::string> ids;
  for (const auto& q : queued)
    ids.insert(q.array_job);
  std::string list;
  for (const auto& id : ids)
    list += (list.empty() ? "" : " ") + id;
  throw SchedulerError(fmt::format(
      "{}: an earlier submission is still writing this folder (Slurm jobs {} are in the "
      "queue); wait for them (scanbench status {}) or cancel them (scancel {}){}",
      dir.string(), list, dir.string(), list, consequence));
}

}  // namespace

void refuse_if_submission_queued(const fs::path& dir_in) {
  const fs::path dir = fs::absolute(dir_in).lexically_normal();
  if (!fs::is_directory(dir / "slurm")) return;
  const std::string squeue = find_on_path("squeue");
  if (squeue.empty()) return;  // no Slurm here: no task of this machine can be writing
  try {
    refuse_if_queued(squeue, dir, "");
  } catch (const SchedulerError& e) {
    // A controller that does not answer runs no task either; a queue that holds ours does.
    if (std::string_view(e.what()).find("still writing") != std::string_view::npos) throw;
  }
}

SlurmSubmission submit_slurm(const Experiment& e, const RunOptions& opts, const SlurmOptions& so) {
  if (so.chunk < 1) throw ParamError(fmt::format("--chunk: expected >= 1, got {}", so.chunk));
  const Tools tools = find_tools();
  check_controller(tools);
  check_partition(tools, so.partition);

  const fs::path dir = fs::absolute(opts.out).lexically_normal();
  fs::create_directories(dir);
  // The folder's lock while the submission prepares it (folder_lock.h); the array's tasks then
  // write only their own jobs' files, and the merge job takes the lock again.
  const FolderLock lock = FolderLock::acquire(dir, "scanbench run --executor slurm", 0, true);
  const std::string tag = folder_tag(dir);
  refuse_if_queued(tools.squeue, dir, "; nothing submitted");

  RunOptions o = opts;
  o.out = dir;
  SlurmSubmission s;
  s.prepared = prepare_run(e, o);  // the same lock, re-entrant
  const PreparedRun& prep = s.prepared;
  const std::size_t n = prep.todo.size();
  if (n == 0) return s;  // nothing to submit: the caller merges and presents the folder

  const std::size_t chunk = static_cast<std::size_t>(so.chunk);
  s.tasks = static_cast<int>((n + chunk - 1) / chunk);
  double task_time = 0, mem = 0;
  int cpus = 0;
  Json ids = Json::array();
  for (std::size_t t = 0; t < static_cast<std::size_t>(s.tasks); ++t) {
    double sum = 0;
    for (std::size_t k = t * chunk; k < std::min(n, (t + 1) * chunk); ++k) {
      const Job& job = prep.plan.jobs[prep.todo[k]];
      sum += job.timeout_s;
      mem = std::max(mem, job.memory_limit_mb);
      cpus = std::max(cpus, job.threads);
      ids.push_back(job.id);
    }
    task_time = std::max(task_time, sum);
  }
  const long minutes = static_cast<long>(std::ceil((task_time + 60.0) / 60.0));
  const long mem_mb = static_cast<long>(std::ceil(mem));

  const auto existing = submission_ids(dir);
  long last = 0;
  if (!existing.empty()) {
    const std::string& n = existing.back();
    const auto [end, ec] = std::from_chars(n.data(), n.data() + n.size(), last);
    if (ec != std::errc() || end != n.data() + n.size() || last >= 999999) {
      throw IoError(
          fmt::format("{}: submission folder '{}' is not a submission number scanbench "
                      "wrote; move it away",
                      (dir / "slurm").string(), n));
    }
  }
  s.id = fmt::format("{:03d}", last + 1);
  const fs::path sub = dir / "slurm" / s.id;
  fs::create_directories(sub / "started");
  const fs::path exe = opts.exe.empty() ? fs::read_symlink("/proc/self/exe") : opts.exe;
  // The tasks load the plugins this process loaded (and a job's child checks their hashes).
  std::string with_plugins = shell_quote(exe.string());
  for (const auto& p : loaded_plugins())
    with_plugins += " --plugin " + shell_quote(p.path.string());
  write_file_atomic(sub / "task.sh",
                    fmt::format("#!/bin/sh\n# scanbench: array task $SLURM_ARRAY_TASK_ID of "
                                "submission {} (see submission.json)\nexec {} slurm-task {} {}\n",
                                s.id, with_plugins, shell_quote(dir.string()), s.id));
  write_file_atomic(sub / "merge.sh",
                    fmt::format("#!/bin/sh\n# scanbench: merge of submission {}\nexec {} merge "
                                "{} --submission {}\n",
                                s.id, with_plugins, shell_quote(dir.string()), s.id));

  Json record = Json::object();
  record["id"] = s.id;
  record["experiment"] = e.name;
  record["job_name"] = tag;
  record["submitted"] = utc_now();
  record["chunk"] = chunk;
  record["tasks"] = s.tasks;
  record["jobs"] = ids;
  record["time_limit_min"] = minutes;
  record["mem_mb"] = mem_mb;
  record["array_job"] = "";
  record["merge_job"] = "";
  // The tasks read "jobs" and "chunk": written before the array exists.
  write_json_file(sub / "submission.json", record);

  std::vector<std::string> common;
  if (!so.partition.empty()) common.push_back("--partition=" + so.partition);
  common.push_back("--chdir=" + dir.string());
  std::vector<std::string> array = {
      tools.sbatch,
      "--parsable",
      "--job-name=" + tag,
      fmt::format("--array=0-{}{}", s.tasks - 1,
                  so.array_limit > 0 ? fmt::format("%{}", so.array_limit) : std::string()),
      fmt::format("--time={}", minutes),
      fmt::format("--mem={}M", mem_mb)};
  if (cpus > 0) array.push_back(fmt::format("--cpus-per-task={}", cpus));
  array.insert(array.end(), common.begin(), common.end());
  array.push_back("--output=" + (sub / "task-%a.out").string());
  array.push_back("--open-mode=append");
  array.insert(array.end(), so.sbatch_args.begin(), so.sbatch_args.end());
  array.push_back((sub / "task.sh").string());

  auto give_up = [&](const std::string& what, const CommandResult& r) {
    fs::remove_all(sub);
    std::string msg = first_line(r.out);
    if (r.timed_out) msg += " (no answer within 60 s)";
    if (msg.find("array") != std::string::npos)
      msg += " (fewer tasks: --chunk N runs N jobs a task)";
    throw SchedulerError(
        fmt::format("slurm: sbatch refused the {}: {}; nothing submitted", what, msg));
  };
  const CommandResult ra = run_command(array, kCommandTimeout);
  s.array_job = ra.code == 0 ? parsable_job_id(ra) : "";
  if (s.array_job.empty()) give_up("job array", ra);

  std::vector<std::string> merge = {tools.sbatch,
                                    "--parsable",
                                    "--job-name=" + tag + "-merge",
                                    "--dependency=afterany:" + s.array_job,
                                    "--time=30",
                                    fmt::format("--mem={}M", std::max<long>(1024, mem_mb))};
  merge.insert(merge.end(), common.begin(), common.end());
  merge.push_back("--output=" + (sub / "merge.out").string());
  merge.push_back("--open-mode=append");
  merge.insert(merge.end(), so.sbatch_args.begin(), so.sbatch_args.end());
  merge.push_back((sub / "merge.sh").string());
  const CommandResult rm = run_command(merge, kCommandTimeout);
  s.merge_job = rm.code == 0 ? parsable_job_id(rm) : "";
  if (s.merge_job.empty()) {
    run_command({tools.scancel, s.array_job}, kCommandTimeout);
    give_up("merge job (the array " + s.array_job + " was cancelled)", rm);
  }

  record["array_job"] = s.array_job;
  record["merge_job"] = s.merge_job;
  record["sbatch"] = {array, merge};
  write_json_file(sub / "submission.json", record);
  s.prepared.lock.reset();  // the merge job takes it (merge_and_finish)
  return s;
}

void wait_for_submission(const fs::path& dir, const SlurmSubmission& s) {
  if (s.array_job.empty()) return;
  const Tools tools = find_tools();
  const std::string tag = folder_tag(dir);
  int failures = 0;
  for (;;) {
    std::vector<QueueEntry> q;
    try {
      q = query_queue(tools.squeue, tag);
      failures = 0;
    } catch (const SchedulerError&) {
      if (++failures >= 5) throw;
      std::this_thread::sleep_for(std::chrono::seconds(2));
      continue;
    }
    const bool ours = std::any_of(q.begin(), q.end(), [&](const QueueEntry& e) {
      return e.array_job == s.array_job || e.array_job == s.merge_job;
    });
    if (!ours) return;
    std::this_thread::sleep_for(std::chrono::seconds(2));
  }
}

// ---- array task -------------------------------------------------------------------------------

int run_slurm_task(const fs::path& dir, const std::string& submission) {
  const char* task_env = std::getenv("SLURM_ARRAY_TASK_ID");
  if (!task_env || !*task_env) {
    throw SchedulerError(
        "slurm-task: SLURM_ARRAY_TASK_ID is not set (this command runs inside a Slurm array "
        "task)");
  }
  const int task = std::atoi(task_env);
  const fs::path sub = dir / "slurm" / submission;
  const Json s = read_json_file(sub / "submission.json");
  const std::size_t chunk = s.at("chunk").get<std::size_t>();
  const std::vector<std::string> ids = s.at("jobs").get<std::vector<std::string>>();
  const std::size_t begin = static_cast<std::size_t>(task) * chunk;
  if (task < 0 || begin >= ids.size()) {
    throw ParamError(fmt::format("slurm-task: task {} is not in submission {} ({} jobs)", task,
                                 submission, ids.size()));
  }
  const std::map<std::string, Job> jobs = plan_jobs(dir, nullptr);
  std::vector<const Job*> todo;
  for (std::size_t k = begin; k < std::min(ids.size(), begin + chunk); ++k) {
    const auto it = jobs.find(ids[k]);
    if (it == jobs.end()) {
      throw ParamError(
          fmt::format("slurm-task: job {} is not in {}/plan.json", ids[k], dir.string()));
    }
    // A requeued task does not redo the jobs it finished before.
    const fs::path rec = dir / "jobs" / (ids[k] + ".json");
    if (fs::exists(rec) && read_record_file(rec).value("status", std::string()) == "ok") continue;
    todo.push_back(&it->second);
  }

  struct sigaction sa {};
  sa.sa_handler = on_sigterm;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  sigaction(SIGTERM, &sa, nullptr);

  const fs::path out_file = sub / fmt::format("task-{}.out", task);
  std::error_code ec;
  const std::uintmax_t offset = fs::exists(out_file) ? fs::file_size(out_file, ec) : 0;
  const std::string array_job =
      std::getenv("SLURM_ARRAY_JOB_ID") ? std::getenv("SLURM_ARRAY_JOB_ID") : "?";
  const std::string slurm_job = std::getenv("SLURM_JOB_ID") ? std::getenv("SLURM_JOB_ID") : "?";
  char host[256] = {0};
  if (gethostname(host, sizeof(host) - 1) != 0) host[0] = 0;

  RunOptions o;
  o.out = dir;
  o.jobs = 1;
  RunHooks hooks;
  hooks.started = [&](const Job& job) {
    const Json m = {{"task", task}, {"array_job", array_job}, {"slurm_job", slurm_job},
                    {"host", host}, {"pid", getpid()},        {"date", utc_now()}};
    write_json_file(sub / "started" / job.id, m, -1);
  };
  hooks.stop = [] { return g_stop_requested != 0; };
  hooks.amend = [&](const Job&, Json& r) {
    if (r.value("status", std::string()) == "ok") return;
    const bool sigterm = r.value("error", std::string()).find("signal 15 ") != std::string::npos;
    if (!g_stop_requested && !sigterm) return;
    // Slurm signals the child and this process at about the same time: give ours a moment.
    for (int i = 0; i < 200 && !g_stop_requested; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (!g_stop_requested) return;  // somebody else's SIGTERM: an ordinary crash
    std::string line;
    for (int i = 0; i < 100 && line.empty(); ++i) {
      line = stop_line(out_file, offset);
      if (line.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    r["status"] = status_of_slurm_state("", line);
    r["error"] = line.empty()
                     ? fmt::format(
                           "Slurm stopped array task {}_{} (job {}) with SIGTERM and gave "
                           "no reason in its output (scancel, time limit, preemption or "
                           "shutdown)",
                           array_job, task, slurm_job)
                     : fmt::format("Slurm stopped array task {}_{}: {}", array_job, task, line);
  };
  std::fprintf(stderr, "scanbench: array task %s_%d (job %s on %s): %zu jobs\n", array_job.c_str(),
               task, slurm_job.c_str(), host, todo.size());
  RunSummary summary;
  run_jobs(todo, o, summary, hooks);
  if (g_stop_requested) {
    std::fprintf(stderr, "scanbench: stopped by Slurm after %d of %zu jobs\n", summary.ran,
                 todo.size());
    return 1;
  }
  return 0;
}

// ---- merge ------------------------------------------------------------------------------------

MergedFolder merge_folder(const fs::path& dir, const std::string& submission) {
  if (!fs::exists(dir / "plan.json")) {
    throw IoError(fmt::format("{}: no plan.json (not a results folder)", dir.string()));
  }
  std::vector<std::string> order;
  const std::map<std::string, Job> jobs = plan_jobs(dir, &order);
  std::vector<std::string> scope = order;
  if (!submission.empty()) {
    const fs::path sub = dir / "slurm" / submission;
    const Json s = read_json_file(sub / "submission.json");
    const std::size_t chunk = s.at("chunk").get<std::size_t>();
    scope = s.at("jobs").get<std::vector<std::string>>();
    const std::string array_job = s.value("array_job", std::string());
    const std::string scontrol = find_on_path("scontrol");
    for (std::size_t k = 0; k < scope.size(); ++k) {
      const fs::path marker = sub / "started" / scope[k];
      const fs::path rec = dir / "jobs" / (scope[k] + ".json");
      if (!fs::exists(marker)) continue;  // never started: missing, listed below
      if (fs::exists(rec) && fs::last_write_time(rec) >= fs::last_write_time(marker)) continue;
      const auto it = jobs.find(scope[k]);
      if (it == jobs.end()) continue;
      const std::size_t task = k / chunk;
      const std::string task_id = fmt::format("{}_{}", array_job, task);
      const auto [state, reason] = scontrol_state(scontrol, task_id);
      const std::string line = stop_line(sub / fmt::format("task-{}.out", task), 0);
      const std::string status = status_of_slurm_state(state, line);
      const std::string error = fmt::format(
          "Slurm array task {} ended {} before the job wrote its record{}", task_id,
          state.empty() ? std::string("(Slurm no longer knows its state)")
                        : "in state " + state +
                              (reason.empty() || reason == "None" ? "" : " (" + reason + ")"),
          line.empty() ? "" : ": " + line);
      write_json_file(rec, failure_record(it->second, status, error, dir));
      fmt::print("recorded {} as {}: {}\n", it->second.key, status, error);
    }
  }
  merge_records(dir);
  MergedFolder m;
  for (const auto& id : scope) {
    if (fs::exists(dir / "jobs" / (id + ".json"))) continue;
    const auto it = jobs.find(id);
    m.missing.push_back({id, it == jobs.end() ? std::string("?") : it->second.key});
  }
  if (!m.missing.empty()) m.resume_hint = resume_command(dir);
  return m;
}

std::string render_missing(const MergedFolder& m) {
  if (m.missing.empty()) return {};
  std::string out = fmt::format("{} job{} without a record:\n", m.missing.size(),
                                m.missing.size() == 1 ? "" : "s");
  for (const auto& [id, key] : m.missing)
    out += fmt::format("  {}  {}\n", id, key);
  return out + fmt::format("run them with: {}\n", m.resume_hint);
}

// ---- status -----------------------------------------------------------------------------------

FolderStatus folder_status(const fs::path& dir_in) {
  const fs::path dir = fs::absolute(dir_in).lexically_normal();
  if (!fs::exists(dir / "plan.json")) {
    throw IoError(fmt::format("{}: no plan.json (not a results folder)", dir_in.string()));
  }
  FolderStatus st;
  st.experiment = read_json_file(dir / "plan.json").value("experiment", std::string());
  std::vector<std::string> order;
  const std::map<std::string, Job> jobs = plan_jobs(dir, &order);

  // Jobs in the queue: id -> (running?, detail).
  std::map<std::string, std::pair<bool, std::string>> queued;
  const auto subs = submission_ids(dir);
  if (!subs.empty()) {
    std::vector<QueueEntry> q;
    const std::string squeue = find_on_path("squeue");
    if (squeue.empty()) {
      st.queue_error = "squeue not found on PATH";
    } else {
      try {
        q = query_queue(squeue, folder_tag(dir));
      } catch (const SchedulerError& e) {
        st.queue_error = e.what();
      }
    }
    for (const auto& sid : subs) {
      const fs::path sub = dir / "slurm" / sid;
      const Json s = read_json_file(sub / "submission.json");
      const std::string array_job = s.value("array_job", std::string());
      const std::string merge_job = s.value("merge_job", std::string());
      const std::size_t chunk = s.value("chunk", std::size_t{1});
      const auto ids = s.value("jobs", std::vector<std::string>());
      for (const auto& e : q) {
        if (!merge_job.empty() && e.array_job == merge_job) {
          st.other_jobs.push_back(fmt::format("merge job {} of submission {}: {}{}", e.id, sid,
                                              e.state,
                                              e.reason == "None" ? "" : " (" + e.reason + ")"));
          continue;
        }
        if (array_job.empty() || e.array_job != array_job) continue;
        if (e.task.empty() || !std::all_of(e.task.begin(), e.task.end(), ::isdigit)) continue;
        std::size_t task = 0;
        const auto [end, ec] = std::from_chars(e.task.data(), e.task.data() + e.task.size(), task);
        if (ec != std::errc() || end != e.task.data() + e.task.size()) continue;
        const bool running = e.state != "PENDING";
        for (std::size_t k = task * chunk; k < std::min(ids.size(), (task + 1) * chunk); ++k) {
          const std::string& id = ids[k];
          const fs::path marker = sub / "started" / id;
          const fs::path rec = dir / "jobs" / (id + ".json");
          const bool started = fs::exists(marker);
          const bool finished =
              started && fs::exists(rec) && fs::last_write_time(rec) >= fs::last_write_time(marker);
          if (finished) continue;  // its record tells
          if (running && started) {
            queued[id] = {true, fmt::format("Slurm job {} on {}, {}", e.id, e.node, e.time)};
          } else {
            queued[id] = {false,
                          running ? fmt::format("Slurm job {} runs the jobs before it", e.id)
                                  : fmt::format("Slurm job {} {} ({})", e.id, e.state, e.reason)};
          }
        }
      }
    }
  }

  for (const auto& id : order) {
    const Job& job = jobs.at(id);
    FolderStatus::Item item{id, job.key, "", ""};
    if (const auto it = queued.find(id); it != queued.end()) {
      item.status = it->second.first ? "running" : "pending";
      item.detail = it->second.second;
      (it->second.first ? st.running : st.pending).push_back(item);
      continue;
    }
    const fs::path rec = dir / "jobs" / (id + ".json");
    if (!fs::exists(rec)) {
      st.not_run.push_back(item);
      continue;
    }
    const Json r = read_record_file(rec);
    item.status = r.value("status", std::string("?"));
    item.detail = r.value("error", std::string());
    (item.status == "ok" ? st.done : st.failed).push_back(item);
  }
  if (!st.not_run.empty() || !st.failed.empty()) st.resume_hint = resume_command(dir_in);
  return st;
}

std::string render_status(const FolderStatus& s, std::size_t max_lines) {
  const std::size_t total =
      s.done.size() + s.failed.size() + s.running.size() + s.pending.size() + s.not_run.size();
  std::string out =
      fmt::format("{}: {} jobs: {} done, {} failed, {} running, {} pending, {} without a record\n",
                  s.experiment, total, s.done.size(), s.failed.size(), s.running.size(),
                  s.pending.size(), s.not_run.size());
  auto list = [&](const char* title, const std::vector<FolderStatus::Item>& items, bool status) {
    if (items.empty()) return;
    out += fmt::format("{} ({}):\n", title, items.size());
    for (std::size_t i = 0; i < items.size() && i < max_lines; ++i) {
      const auto& it = items[i];
      out += "  ";
      if (status) out += fmt::format("{:<11} ", it.status);
      out += it.key;
      if (!it.detail.empty()) out += (status ? ": " : "  (") + it.detail + (status ? "" : ")");
      out += "\n";
    }
    if (items.size() > max_lines)
      out += fmt::format("  ... and {} more\n", items.size() - max_lines);
  };
  list("failed", s.failed, true);
  list("running", s.running, false);
  list("pending", s.pending, false);
  list("without a record", s.not_run, false);
  for (const auto& o : s.other_jobs)
    out += o + "\n";
  if (!s.queue_error.empty()) out += "queue unknown: " + s.queue_error + "\n";
  if (!s.resume_hint.empty() && s.running.empty() && s.pending.empty()) {
    out +=
        "to run what has no record (and, with --retry-failed, the failed jobs): " + s.resume_hint +
        "\n";
  }
  return out;
}

Json status_json(const FolderStatus& s) {
  auto items = [](const std::vector<FolderStatus::Item>& v) {
    Json a = Json::array();
    for (const auto& it : v)
      a.push_back({{"id", it.id}, {"key", it.key}, {"status", it.status}, {"detail", it.detail}});
    return a;
  };
  Json j = Json::object();
  j["experiment"] = s.experiment;
  j["counts"] = {{"done", s.done.size()},
                 {"failed", s.failed.size()},
                 {"running", s.running.size()},
                 {"pending", s.pending.size()},
                 {"without_record", s.not_run.size()}};
  j["done"] = items(s.done);
  j["failed"] = items(s.failed);
  j["running"] = items(s.running);
  j["pending"] = items(s.pending);
  j["without_record"] = items(s.not_run);
  j["other_jobs"] = s.other_jobs;
  j["queue_error"] = s.queue_error;
  j["resume_hint"] = s.resume_hint;
  return j;
}

}  // namespace scanbench::harness
