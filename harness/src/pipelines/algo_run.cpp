#include "scanbench/harness/pipelines/algo_run.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <chrono>
#include <map>

#include "scanbench/algorithms/registry.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/stage_data.h"
#include "scanbench/harness/exec/chain.h"

namespace scanbench::harness {

namespace {

// "<out>.<suffix>.ply" next to the output: out.ply -> out.mixture.ply.
std::filesystem::path sibling(const std::filesystem::path& out, const std::string& suffix) {
  std::filesystem::path p = out;
  p.replace_extension();
  p += "." + suffix + ".ply";
  return p;
}

}  // namespace

StepRun run_step(
    const std::string& name, const StageData& input, const Json& given, std::uint64_t seed,
    int threads,
    const std::function<std::shared_ptr<void>(const RunContext&, const std::string&)>& watch) {
  const auto& entry = algorithms::registry().at(name);
  StepRun res;
  res.params = entry.params.validate(given, "algo " + entry.name);
  RunContext ctx(seed, threads);
  const auto t0 = std::chrono::steady_clock::now();
  {
    const std::shared_ptr<void> watching = watch ? watch(ctx, entry.name) : nullptr;
    res.output = entry.fn(input, res.params, ctx);
  }
  res.total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  res.phases = Json::object();
  for (const auto& [phase, seconds] : ctx.phase_seconds())
    res.phases[phase] = seconds;
  res.phases_cpu = Json::object();
  for (const auto& [phase, seconds] : ctx.phase_cpu_seconds())
    res.phases_cpu[phase] = seconds;
  return res;
}

AlgoRunResult run_algo(const AlgoRunRequest& r) {
  AlgoRunResult res;
  const auto& entry = algorithms::registry().at(r.name);
  Json given = Json::object();
  for (const auto& s : r.sets)
    apply_assignment(given, s);
  (void)entry.params.validate(given, "algo " + entry.name);  // before reading any file
  StageData input;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  for (const auto& path : r.inputs) {
    StageData d = read_stage_file(path);
    if (&path == &r.inputs.front()) origin = d.origin(path);
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
                    entry.name, kinds_names(io.consumes), fmt::join(r.inputs, ", "),
                    kinds_names(input.kinds()), kinds_names(io.consumes - input.kinds())));
  }

  StepRun step = [&] {
    try {
      return run_step(entry.name, input, given, r.seed, r.threads, r.watch);
    } catch (const InputError& e) {
      // The algorithm rejected the data (a non-manifold mesh, too few points...): name the files
      // it came from, so the one-line error says which input to look at.
      throw InputError(fmt::format("{}: {}", fmt::join(r.inputs, ", "), e.what()));
    }
  }();
  StageData out = std::move(step.output);
  const double total = step.total_s;

  out.set_origin(origin);
  const std::map<DataKind, std::string> named = {{DataKind::Mixture, r.mixture},
                                                 {DataKind::Mesh, r.mesh},
                                                 {DataKind::CovarianceMesh, r.covariance_mesh}};
  const auto path_of = [&](DataKind kind) {
    if (kind == io.primary) return std::filesystem::path(r.output);
    const auto it = named.find(kind);
    return it == named.end() || it->second.empty()
               ? sibling(r.output, std::string(kind_suffix(kind)))
               : std::filesystem::path(it->second);
  };
  std::string extra;
  for (const auto& [kind, path] : write_stage_data(out, io.produces | io.primary, path_of)) {
    if (kind != io.primary) extra += fmt::format(", {} -> {}", kind_name(kind), path.string());
  }
  {
    Json& record = res.record;
    record = Json::object();
    record["algorithm"] = entry.name;
    record["params"] = step.params;
    record["seed"] = r.seed;
    record["threads"] = r.threads;
    record["inputs"] = r.inputs;
    record["input_points"] = input.points.size();
    record["output_kind"] = kind_name(io.primary);
    if (!origin.isZero(0.0)) record["dataset_origin"] = {origin.x(), origin.y(), origin.z()};
    record["output_points"] = out.points.size();
    if (out.mesh) record["output_mesh_faces"] = out.mesh->num_faces();
    if (out.covariance_mesh)
      record["output_covariance_mesh_faces"] = out.covariance_mesh->num_faces();
    record["phases"] = step.phases;
    record["phases_cpu"] = step.phases_cpu;
    record["total_s"] = total;
  }
  res.summary =
      fmt::format("{}: {} -> {} in {:.3f} s -> {}{}", entry.name, kinds_names(input.kinds()),
                  kind_name(io.primary), total, r.output, extra);
  return res;
}

}  // namespace scanbench::harness
