#include "scanbench/harness/test_algorithms.h"

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <thread>
#include <vector>

namespace scanbench::harness {

namespace {

struct CrashParams {
  double delay_s = 0.0;
  static void declare(ParamDeclarer<CrashParams>& d) {
    d.real("delay_s", &CrashParams::delay_s, Range::closed(0, 60), "s", "wait before crashing");
  }
};

struct HangParams {
  static void declare(ParamDeclarer<HangParams>&) {}
};

struct OomParams {
  int chunk_mb = 64;
  static void declare(ParamDeclarer<OomParams>& d) {
    d.integer("chunk_mb", &OomParams::chunk_mb, Range::closed(1, 4096), "MB", "allocation step");
  }
};

struct SubsampleParams {
  int stride = 2;
  double work_ms = 0.0;
  static void declare(ParamDeclarer<SubsampleParams>& d) {
    d.integer("stride", &SubsampleParams::stride, Range::closed(1, 1000), "",
              "keep points 0, stride, 2 stride, ...");
    d.real("work_ms", &SubsampleParams::work_ms, Range::closed(0, 10000), "ms",
           "busy wait per call (phase \"work\"), for timing tests");
  }
};

using algorithms::AlgorithmOutput;

AlgorithmOutput only(PointCloud pc) {
  AlgorithmOutput out;
  out.points = std::move(pc);
  return out;
}

AlgorithmOutput crash(const PointCloud&, const CrashParams& p, RunContext&) {
  std::this_thread::sleep_for(std::chrono::duration<double>(p.delay_s));
  std::raise(SIGSEGV);
  return only({});
}

AlgorithmOutput hang(const PointCloud&, const HangParams&, RunContext&) {
  for (;;)
    std::this_thread::sleep_for(std::chrono::seconds(1));
}

AlgorithmOutput oom(const PointCloud&, const OomParams& p, RunContext&) {
  std::vector<std::unique_ptr<char[]>> blocks;
  const std::size_t chunk = static_cast<std::size_t>(p.chunk_mb) << 20;
  for (;;) {
    blocks.emplace_back(new char[chunk]);  // throws std::bad_alloc at the limit
    std::memset(blocks.back().get(), 1, chunk);
  }
}

AlgorithmOutput subsample(const PointCloud& in, const SubsampleParams& p, RunContext& ctx) {
  std::vector<Eigen::Index> keep;
  {
    auto t = ctx.phase("select");
    for (Eigen::Index i = 0; i < in.size(); i += p.stride)
      keep.push_back(i);
  }
  if (p.work_ms > 0) {
    auto t = ctx.phase("work");
    const auto until =
        std::chrono::steady_clock::now() + std::chrono::duration<double, std::milli>(p.work_ms);
    while (std::chrono::steady_clock::now() < until) {
    }
  }
  return only(in.subset(keep));
}

}  // namespace

bool test_algorithms_enabled() {
  const char* v = std::getenv("SCANBENCH_TEST_ALGORITHMS");
  return v != nullptr && std::strcmp(v, "1") == 0;
}

const algorithms::AlgorithmRegistry& test_algorithms() {
  static const algorithms::AlgorithmRegistry r = [] {
    algorithms::AlgorithmRegistry reg("test algorithm");
    reg.add(algorithms::make_entry<CrashParams>("test.crash", "raises SIGSEGV (isolation tests)",
                                                crash));
    reg.add(algorithms::make_entry<HangParams>("test.hang", "never returns (timeout tests)", hang));
    reg.add(algorithms::make_entry<OomParams>(
        "test.oom", "allocates until allocation fails (memory-limit tests)", oom));
    reg.add(algorithms::make_entry<SubsampleParams>(
        "test.subsample", "keeps every stride-th point; optional busy work (harness tests)",
        subsample));
    return reg;
  }();
  return r;
}

const algorithms::AlgorithmRegistry::Entry& algorithm_entry(std::string_view name) {
  if (const auto* e = algorithms::registry().find(name)) return *e;
  if (test_algorithms_enabled()) {
    if (const auto* e = test_algorithms().find(name)) return *e;
  }
  return algorithms::registry().at(name);  // throws with the known names
}

}  // namespace scanbench::harness
