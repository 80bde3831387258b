// scanbench algo NAME -i in.ply -o out.ply [--set key=value ...] [--seed N] [--threads N]
//                [--timings t.json] [--mixture m.ply] [--mesh m.ply] [--progress]
//                [--progress-interval S]
// Parses the flags and runs the algorithm pipeline (pipelines/algo_run.h), with the progress
// printer below on stderr.
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "cli/commands.h"
#include "scanbench/core/files.h"
#include "scanbench/core/run_context.h"
#include "scanbench/harness/pipelines/algo_run.h"
#include "scanbench/plugin.h"

namespace scanbench::harness {

namespace {

/// Progress lines on stderr while one step runs: "algo NAME: 12.0 s, <what> (42%)". A line when
/// the step reports a new phase (report_progress, plugin.h) at most every `interval` seconds,
/// and one every `interval` seconds while it reports nothing new, so a long step is never
/// silent; nothing for a step shorter than `interval` that reports nothing.
class ProgressPrinter {
 public:
  ProgressPrinter(const RunContext& ctx, std::string name, double interval)
      : name_(std::move(name)),
        interval_(interval),
        t0_(std::chrono::steady_clock::now()),
        listener_(ctx, [this](const std::string& what, double fraction) { on(what, fraction); }),
        ticker_([this] { tick(); }) {}
  ~ProgressPrinter() {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    wake_.notify_all();
    ticker_.join();
  }
  ProgressPrinter(const ProgressPrinter&) = delete;
  ProgressPrinter& operator=(const ProgressPrinter&) = delete;

 private:
  double elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  }
  /// Under mutex_.
  void print_line() {
    std::string line = fmt::format("algo {}: {:.1f} s", name_, elapsed());
    if (!what_.empty()) line += ", " + what_;
    if (fraction_ >= 0.0) line += fmt::format(" ({:.0f}%)", 100.0 * std::min(1.0, fraction_));
    std::fprintf(stderr, "%s\n", line.c_str());
    std::fflush(stderr);
    last_line_ = elapsed();
  }
  void on(const std::string& what, double fraction) {
    const std::lock_guard<std::mutex> lock(mutex_);
    const bool news = what != what_;
    what_ = what;
    fraction_ = fraction;
    if (news && elapsed() - last_line_ >= interval_) print_line();
  }
  void tick() {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!(interval_ > 0.0)) return;  // 0: only the phases the step reports
    while (!done_) {
      const auto due = t0_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                 std::chrono::duration<double>(last_line_ + interval_));
      if (wake_.wait_until(lock, due, [this] { return done_; })) break;
      if (elapsed() - last_line_ >= interval_) print_line();
    }
  }

  std::string name_;
  double interval_;
  std::chrono::steady_clock::time_point t0_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool done_ = false;
  std::string what_;
  double fraction_ = -1.0;
  double last_line_ = 0.0;  ///< seconds since t0_ of the last line (0: none yet)
  ProgressListener listener_;
  std::thread ticker_;
};

}  // namespace

void add_algo_command(Cli& cli) {
  struct Opts {
    std::string name;
    std::vector<std::string> inputs;
    std::string output;
    std::vector<std::string> sets;
    std::uint64_t seed = 0;
    int threads = 0;
    std::string timings;
    std::string mixture;
    std::string mesh;
    std::string covariance_mesh;
    bool progress = false;
    double progress_interval = 5.0;
  };
  auto opts = std::make_shared<Opts>();
  CLI::App* sub = cli.app.add_subcommand(
      "algo",
      "Run one registered algorithm (scanbench list algorithms) on files and write its primary "
      "output (points, mixture, mesh or covariance mesh, as the algorithm declares) as a binary "
      "PLY; other products go beside it");
  sub->add_option("name", opts->name, "Algorithm name, e.g. resample.wlop")->required();
  sub->add_option("-i,--input", opts->inputs,
                  "Input file, repeatable, one per kind the algorithm consumes: a point cloud "
                  "(.ply, .xyz, .pwn or an .off without faces), a mixture (.ply with element "
                  "component), a mesh (.ply with faces, "
                  ".off, .obj, .stl) or a covariance mesh (.ply with covxx..covzz per vertex)")
      ->required();
  sub->add_option("-o,--output", opts->output,
                  "Output (.ply, or .obj for a mesh): the algorithm's primary output")
      ->required();
  sub->add_option("--set", opts->sets,
                  "Algorithm parameter key=value (repeatable; unknown keys, wrong types and "
                  "out-of-range values are errors)");
  sub->add_option("--seed", opts->seed, "Seed of every random stream (default 0)");
  sub->add_option("--threads", opts->threads, "Worker threads (0 = all); never changes results")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--timings", opts->timings,
                  "Write the run record (effective parameters, phase wall seconds, total) as "
                  "JSON");
  sub->add_option("--mixture", opts->mixture,
                  "Where a mixture-producing algorithm writes its mixture PLY (default "
                  "<output>.mixture.ply)");
  sub->add_option("--mesh", opts->mesh,
                  "Where a mesh that is not the primary output goes (default <output>.mesh.ply)");
  sub->add_option("--covariance-mesh", opts->covariance_mesh,
                  "Where a covariance mesh that is not the primary output goes (default "
                  "<output>.covmesh.ply)");
  sub->add_flag("--progress", opts->progress,
                "Print the step's progress on stderr (on by default when stderr is a terminal): "
                "its elapsed time every --progress-interval seconds, and the phase and fraction "
                "the algorithm reports (plugins: scanbench::report_progress)");
  sub->add_option(
         "--progress-interval", opts->progress_interval,
         "Seconds between progress lines (default 5; 0: a line per phase the step reports, "
         "no timed lines)")
      ->check(CLI::Range(0.0, 3600.0));
  sub->callback([&cli, opts] {
    cli.action = [opts] {
      AlgoRunRequest r;
      r.name = opts->name;
      r.inputs = opts->inputs;
      r.output = opts->output;
      r.sets = opts->sets;
      r.seed = opts->seed;
      r.threads = opts->threads;
      r.mixture = opts->mixture;
      r.mesh = opts->mesh;
      r.covariance_mesh = opts->covariance_mesh;
      if (opts->progress || isatty(STDERR_FILENO) == 1) {
        const double interval = opts->progress_interval;
        r.watch = [interval](const RunContext& ctx, const std::string& name) {
          return std::make_shared<ProgressPrinter>(ctx, name, interval);
        };
      }
      const AlgoRunResult res = run_algo(r);
      if (!opts->timings.empty()) write_json_file(opts->timings, res.to_json(), 2);
      fmt::print("{}\n", res.summary);
      return 0;
    };
  });
}

}  // namespace scanbench::harness
