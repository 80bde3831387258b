// scanbench algo NAME -i in.ply -o out.ply [--set key=value ...] [--seed N] [--threads N]
//                [--timings t.json] [--mixture m.ply] [--mesh m.ply] [--progress]
//                [--progress-interval S]
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "cli/commands.h"
#include "scanbench/algorithms/registry.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/run_context.h"
#include "scanbench/harness/chain.h"
#include "scanbench/harness/records.h"
#include "scanbench/plugin.h"

namespace scanbench::harness {

namespace {

// "<out>.<suffix>.ply" next to the output: out.ply -> out.mixture.ply.
std::filesystem::path sibling(const std::filesystem::path& out, const std::string& suffix) {
  std::filesystem::path p = out;
  p.replace_extension();
  p += "." + suffix + ".ply";
  return p;
}

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
      const auto& entry = algorithms::registry().at(opts->name);
      Json given = Json::object();
      for (const auto& s : opts->sets)
        apply_assignment(given, s);
      const Json params = entry.params.validate(given, "algo " + entry.name);
      StageData input;
      Eigen::Vector3d origin = Eigen::Vector3d::Zero();
      for (const auto& path : opts->inputs) {
        StageData d = read_stage_file(path);
        if (&path == &opts->inputs.front()) origin = d.origin(path);
        const DataKinds k = d.kinds();
        if ((input.kinds().bits & k.bits) != 0) {
          throw ParamError(fmt::format("algo: {}: a second {} input (give one file per kind)", path,
                                       kinds_names(k)));
        }
        input = StageData::carry(std::move(d), input, k);
      }
      // Local origin (core stage_data.h): the inputs in the frame of the first one; the algorithm
      // sees them at origin zero (as data at the world origin) and the outputs get it back.
      input.rebase(origin);
      input.set_origin(Eigen::Vector3d::Zero());
      const auto& io = entry.fn.io;
      if (!input.kinds().contains(io.consumes)) {
        throw ParamError(
            fmt::format("algo {}: consumes {}, but the inputs ({}) hold {}: give {} with -i",
                        entry.name, kinds_names(io.consumes), fmt::join(opts->inputs, ", "),
                        kinds_names(input.kinds()), kinds_names(io.consumes - input.kinds())));
      }

      RunContext ctx(opts->seed, opts->threads);
      const auto t0 = std::chrono::steady_clock::now();
      StageData out;
      try {
        std::optional<ProgressPrinter> progress;
        if (opts->progress || isatty(STDERR_FILENO) == 1)
          progress.emplace(ctx, entry.name, opts->progress_interval);
        out = entry.fn(input, params, ctx);
      } catch (const InputError& e) {
        // The algorithm rejected the data (a non-manifold mesh, too few points...): name the files
        // it came from, so the one-line error says which input to look at.
        throw InputError(fmt::format("{}: {}", fmt::join(opts->inputs, ", "), e.what()));
      }
      const double total =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

      out.set_origin(origin);
      const std::map<DataKind, std::string> named = {
          {DataKind::Mixture, opts->mixture},
          {DataKind::Mesh, opts->mesh},
          {DataKind::CovarianceMesh, opts->covariance_mesh}};
      const auto path_of = [&](DataKind kind) {
        if (kind == io.primary) return std::filesystem::path(opts->output);
        const auto it = named.find(kind);
        return it == named.end() || it->second.empty()
                   ? sibling(opts->output, std::string(kind_suffix(kind)))
                   : std::filesystem::path(it->second);
      };
      std::string extra;
      for (const auto& [kind, path] : write_stage_data(out, io.produces | io.primary, path_of)) {
        if (kind != io.primary) extra += fmt::format(", {} -> {}", kind_name(kind), path.string());
      }
      if (!opts->timings.empty()) {
        Json record = Json::object();
        record["algorithm"] = entry.name;
        record["params"] = params;
        record["seed"] = opts->seed;
        record["threads"] = opts->threads;
        record["inputs"] = opts->inputs;
        record["input_points"] = input.points.size();
        record["output_kind"] = kind_name(io.primary);
        if (!origin.isZero(0.0)) record["dataset_origin"] = {origin.x(), origin.y(), origin.z()};
        record["output_points"] = out.points.size();
        if (out.mesh) record["output_mesh_faces"] = out.mesh->num_faces();
        if (out.covariance_mesh)
          record["output_covariance_mesh_faces"] = out.covariance_mesh->num_faces();
        Json phases = Json::object();
        for (const auto& [name, seconds] : ctx.phase_seconds())
          phases[name] = seconds;
        record["phases"] = phases;
        Json cpu = Json::object();
        for (const auto& [name, seconds] : ctx.phase_cpu_seconds())
          cpu[name] = seconds;
        record["phases_cpu"] = cpu;
        record["total_s"] = total;
        write_json_file(opts->timings, record, 2);
      }
      fmt::print("{}: {} -> {} in {:.3f} s -> {}{}\n", entry.name, kinds_names(input.kinds()),
                 kind_name(io.primary), total, opts->output, extra);
      return 0;
    };
  });
}

}  // namespace scanbench::harness
