// `scanbench history bisect`: the first bad commit between GOOD and BAD for one job's quantity,
// like `asv find`: each probed commit is checked out in a scratch worktree, built with its own
// scripts/build.sh (ccache makes the rebuilds cheap) and that one job rerun.
#include <fmt/format.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <regex>

#include "scanbench/core/errors.h"
#include "scanbench/harness/results/compare.h"
#include "scanbench/harness/results/history.h"
#include "scanbench/harness/results/records.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

namespace {

std::string quote(const std::string& s) {
  std::string out = "'";
  for (char c : s)
    out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

/// Runs a shell command with its output appended to `log`; true when it exits 0.
bool run_logged(const std::string& cmd, const fs::path& log) {
  const int rc = std::system((cmd + " >>" + quote(log.string()) + " 2>&1").c_str());
  return rc != -1 && WIFEXITED(rc) && WEXITSTATUS(rc) == 0;
}

/// The lines a command prints (stderr dropped); throws IoError naming `what` when it fails.
std::vector<std::string> lines_of(const std::string& cmd, const std::string& what) {
  FILE* p = popen((cmd + " 2>/dev/null").c_str(), "r");
  if (!p) throw IoError(what + ": cannot run git");
  std::vector<std::string> out;
  char buf[512];
  while (fgets(buf, sizeof(buf), p)) {
    std::string l = buf;
    while (!l.empty() && (l.back() == '\n' || l.back() == '\r'))
      l.pop_back();
    if (!l.empty()) out.push_back(l);
  }
  if (pclose(p) != 0) throw IoError(what);
  return out;
}

std::string regex_escape(const std::string& s) {
  static const std::regex special(R"([.^$|()\[\]{}*+?\\])");
  return std::regex_replace(s, special, R"(\$&)");
}

}  // namespace

BisectResult history_bisect(const BisectOptions& o) {
  const std::string git = "git -C " + quote(o.repo.string());
  std::vector<std::string> commits = lines_of(
      fmt::format("{} rev-list --reverse --ancestry-path {}..{}", git, quote(o.good), quote(o.bad)),
      fmt::format("{}: {}..{} is no commit range of this repository", o.repo.string(), o.good,
                  o.bad));
  if (commits.empty()) {
    throw ParamError(fmt::format("{}..{}: BAD is not a descendant of GOOD", o.good, o.bad));
  }
  const std::string good =
      lines_of(git + " rev-parse " + quote(o.good + "^{commit}"), o.good + ": no such commit")
          .front();
  fs::create_directories(o.scratch);
  const fs::path wt = fs::absolute(o.scratch / "worktree");
  const fs::path log = fs::absolute(o.scratch / "bisect.log");
  if (!run_logged(fmt::format("{} worktree add --detach {} {}", git, quote(wt.string()), good),
                  log)) {
    throw IoError(
        fmt::format("{}: cannot add a scratch worktree (see {})", wt.string(), log.string()));
  }
  BisectResult res;
  const int direction = quantity_direction(o.metric);
  // The quantity at a commit: NaN when the commit does not build, throws when the job fails.
  auto measure = [&](const std::string& commit) {
    const fs::path out = fs::absolute(o.scratch / ("run-" + commit.substr(0, 12)));
    const fs::path build = fs::absolute(o.scratch / "build");
    fmt::print("bisect: {} ...", commit.substr(0, 12));
    std::fflush(stdout);
    if (!run_logged(fmt::format("git -C {} checkout -q --detach {}", quote(wt.string()), commit),
                    log) ||
        !run_logged(fmt::format("SCANBENCH_BUILD_DIR={} SCANBENCH_TARGETS=scanbench bash {}",
                                quote(build.string()), quote((wt / "scripts/build.sh").string())),
                    log)) {
      fmt::print(" does not build\n");
      return std::nan("");
    }
    fs::remove_all(out);
    const std::string run = fmt::format("{} run {} -o {} -q --filter {}",
                                        quote((build / "harness" / "scanbench").string()),
                                        quote((wt / o.config).string()), quote(out.string()),
                                        quote("^" + regex_escape(o.job) + "$"));
    std::vector<Json> recs;
    if (run_logged(run, log) || fs::exists(out / "runs.jsonl")) recs = load_records(out);
    if (recs.empty() || recs.front().value("status", std::string()) != "ok") {
      throw IoError(
          fmt::format("bisect: job {} did not run ok at {} (see {})", o.job, commit, log.string()));
    }
    const double v = record_value(recs.front(), o.metric);
    fmt::print(" {} = {}\n", o.metric, v);
    res.values.push_back({commit, v});
    return v;
  };
  const double v_good = measure(good);
  if (std::isnan(v_good)) {
    throw IoError(fmt::format("bisect: GOOD {} does not build or lacks {} (see {})", o.good,
                              o.metric, log.string()));
  }
  // Bad: worse than GOOD (by the quantity's direction; any change for informational ones) by
  // more than rel x |GOOD|.
  auto is_bad = [&](double v) {
    const double d = v - v_good;
    const double limit = o.rel * std::abs(v_good);
    return direction == 0 ? std::abs(d) > limit : d * direction < -limit;
  };
  std::size_t lo = 0, hi = commits.size() - 1;  // commits[hi] is bad, commits before lo good
  const double v_bad = measure(commits[hi]);
  if (std::isnan(v_bad) || !is_bad(v_bad)) {
    res.stopped = std::isnan(v_bad) ? "BAD does not build" : "BAD is not worse than GOOD";
    run_logged(fmt::format("{} worktree remove --force {}", git, quote(wt.string())), log);
    return res;
  }
  while (lo < hi) {
    const std::size_t mid = lo + (hi - lo) / 2;
    const double v = measure(commits[mid]);
    if (std::isnan(v)) {
      res.stopped = fmt::format("{} does not build; the first bad commit lies in {}..{}",
                                commits[mid], lo == 0 ? good : commits[lo - 1], commits[hi]);
      break;
    }
    if (is_bad(v)) {
      hi = mid;
    } else {
      lo = mid + 1;
    }
  }
  if (res.stopped.empty()) res.first_bad = commits[hi];
  run_logged(fmt::format("{} worktree remove --force {}", git, quote(wt.string())), log);
  return res;
}

}  // namespace scanbench::harness
