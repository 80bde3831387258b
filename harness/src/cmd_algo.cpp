// scanbench algo NAME -i in.ply -o out.ply [--set key=value ...] [--seed N] [--threads N]
//                [--timings t.json] [--mixture m.ply] [--mesh m.ply]
#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "scanbench/algorithms/registry.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/run_context.h"

namespace scanbench::harness {

namespace {

// "<out>.<suffix>.ply" next to the output: out.ply -> out.mixture.ply.
std::filesystem::path sibling(const std::filesystem::path& out, const std::string& suffix) {
  std::filesystem::path p = out;
  p.replace_extension();
  p += "." + suffix + ".ply";
  return p;
}

void write_json(const Json& j, const std::filesystem::path& path) {
  std::ofstream f(path);
  if (!f) throw IoError(fmt::format("{}: cannot open for writing", path.string()));
  f << j.dump(2) << '\n';
  if (!f) throw IoError(fmt::format("{}: write failed", path.string()));
}

}  // namespace

void add_algo_command(Cli& cli) {
  struct Opts {
    std::string name;
    std::string input;
    std::string output;
    std::vector<std::string> sets;
    std::uint64_t seed = 0;
    int threads = 0;
    std::string timings;
    std::string mixture;
    std::string mesh;
  };
  auto opts = std::make_shared<Opts>();
  CLI::App* sub = cli.app.add_subcommand(
      "algo",
      "Run one registered algorithm (scanbench list algorithms) on a point cloud and write the "
      "result as a binary PLY");
  sub->add_option("name", opts->name, "Algorithm name, e.g. resample.wlop")->required();
  sub->add_option("-i,--input", opts->input, "Input point cloud (.ply)")->required();
  sub->add_option("-o,--output", opts->output, "Output point cloud (.ply)")->required();
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
                  "Where a reconstruction writes its mesh PLY (default <output>.mesh.ply)");
  sub->callback([&cli, opts] {
    cli.action = [opts] {
      const auto& entry = algorithms::registry().at(opts->name);
      Json given = Json::object();
      for (const auto& s : opts->sets)
        apply_assignment(given, s);
      const Json params = entry.params.validate(given, "algo " + entry.name);
      const PointCloud input = read_point_cloud(opts->input);

      RunContext ctx(opts->seed, opts->threads);
      const auto t0 = std::chrono::steady_clock::now();
      algorithms::AlgorithmOutput out = entry.fn(input, params, ctx);
      const double total =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      out.points.validate(entry.name);

      write_point_cloud(out.points, opts->output);
      std::string extra;
      if (out.mixture) {
        const auto path = opts->mixture.empty() ? sibling(opts->output, "mixture")
                                                : std::filesystem::path(opts->mixture);
        write_mixture(*out.mixture, path);
        extra += fmt::format(", mixture of {} -> {}", out.mixture->size(), path.string());
      }
      if (out.mesh) {
        const auto path =
            opts->mesh.empty() ? sibling(opts->output, "mesh") : std::filesystem::path(opts->mesh);
        write_mesh(*out.mesh, path);
        extra += fmt::format(", mesh -> {}", path.string());
      }
      if (!opts->timings.empty()) {
        Json record = Json::object();
        record["algorithm"] = entry.name;
        record["params"] = params;
        record["seed"] = opts->seed;
        record["threads"] = opts->threads;
        record["input"] = opts->input;
        record["input_points"] = input.size();
        record["output_points"] = out.points.size();
        Json phases = Json::object();
        for (const auto& [name, seconds] : ctx.phase_seconds())
          phases[name] = seconds;
        record["phases"] = phases;
        Json cpu = Json::object();
        for (const auto& [name, seconds] : ctx.phase_cpu_seconds())
          cpu[name] = seconds;
        record["phases_cpu"] = cpu;
        record["total_s"] = total;
        write_json(record, opts->timings);
      }
      fmt::print("{}: {} -> {} points in {:.3f} s -> {}{}\n", entry.name, input.size(),
                 out.points.size(), total, opts->output, extra);
      return 0;
    };
  });
}

}  // namespace scanbench::harness
