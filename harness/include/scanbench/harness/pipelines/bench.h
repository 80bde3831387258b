#pragma once
// The paper-case benchmarks behind `scanbench bench resample|filter|subdivide`: library code that
// runs the methods through the registry (harness/chain.h, as every job does) in interleaved
// rounds (harness/paired.h) and returns the benchmark's JSON. The cases that a claim also times
// are read from that claim's file (configs/claims/<claim>.json: scanner, variants and their
// parameters), so a bench and its claim measure the same case:
//   resample  <- clop-fig9-speed (CLOP Fig. 9, the Camel case)
//   filter    <- gpf-table1-timing (GPF Table 1, the Block)
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "scanbench/core/point_cloud.h"
#include "scanbench/core/triangle_mesh.h"
#include "scanbench/harness/exec/chain.h"
#include "scanbench/harness/pipelines/paired.h"
#include "scanbench/harness/results/records.h"

namespace scanbench::harness {

/// Options every paper-case bench takes.
struct BenchOptions {
  int rounds = 5;  ///< kept interleaved rounds (each gives one ratio per pair of cases)
  int warmup = 1;  ///< rounds run first and discarded
  int threads = 0;
  std::uint64_t seed = 1;
  bool quick = false;  ///< the claim's quick scan, a smaller size, fewer rounds: a smoke run
};

/// A paper case of a claim: one dataset's effective scanner parameters and variant chains, the
/// mesh and its scan (local frame, as a job sees it).
struct PaperCase {
  std::string claim;
  std::string dataset;
  TriangleMesh mesh;
  PointCloud scan;
  Json scanner_params;
  std::map<std::string, Json> chains;  ///< variant label -> [{"algorithm","label","params"}]
  std::vector<std::string> metrics;    ///< the claim's metrics
  Json metric_params = Json::object();
};

/// Loads `configs/claims/<claim>.json` (its quick patch when `quick`), expands it, and takes the
/// jobs of `dataset` (empty: the claim's first dataset; a dataset the claim does not name gets the
/// claim's first scanner and variants). `target_points` > 0 rescales the scanner's resolution
/// from a probe scan so the scan holds about that many points. Throws IoError / ParamError naming
/// the claim file, InputError when the scan hits nothing.
PaperCase load_paper_case(const std::string& claim, const std::string& dataset, bool quick,
                          long target_points, std::uint64_t seed);

/// One effective chain for a single registered algorithm: its declared defaults overridden by the
/// keys of `given` that it declares (the others are dropped), validated.
Json single_step_chain(const std::string& algorithm, const Json& given);

/// One case of a bench's rounds: `chain` on `*input` with `threads`, its last run kept for the
/// accuracy table and every run's phases (ChainRun::phases) for per-round phase figures.
struct ChainCase {
  std::string name;
  Json chain;
  const PointCloud* input = nullptr;
  int threads = 0;
  ChainRun last;
  std::vector<std::map<std::string, double>> run_phases;  ///< per run, warm-up rounds first
};
/// The timing loop's closure of a case (paired.h run_rounds): runs the chain once through the
/// registry (run_chain) on a copy of its input, keeps the run in c.last and its phases in
/// c.run_phases, returns its wall and CPU seconds. `c` must outlive the rounds.
TimedCase timed_case(ChainCase& c, std::uint64_t seed);
/// The rounds' progress line: "  round 3", "  round warm-up 1".
void print_round(int round);

/// 1 vs 2 threads: each (name, chain) of `methods` on `scan` with 1 and 2 threads, all in one
/// set of interleaved rounds (o.rounds after o.warmup); appends `<name>_threads_2_over_1`
/// (target >= 1.8) per method to `ratios` and prints it. Returns the rounds' JSON.
Json thread_scaling(const std::vector<std::pair<std::string, Json>>& methods,
                    const PointCloud& scan, const BenchOptions& o,
                    std::vector<PairedRatio>& ratios);

/// The head of a paper-case bench's JSON: benchmark, claim, context, dataset, scan_points,
/// scanner_params, threads, seed.
Json paper_case_json(const std::string& benchmark, const PaperCase& pc, const BenchOptions& o);

/// The fixed-width text table a bench prints row by row (method, medians, sizes, metrics).
struct BenchTable {
  struct Column {
    std::string header;
    int width = 10;
    int decimals = -1;  ///< a number in fixed notation with this many decimals; < 0: as it is
  };
  std::vector<Column> columns;
  void print_header() const;
  /// One cell per column: a string right-aligned as it is, a number as its column says.
  void print_row(const std::vector<Json>& cells) const;
};

struct ResampleBenchOptions : BenchOptions {
  std::string dataset;   ///< empty: the claim's (camel)
  long points = 0;       ///< 0: the claim's scan; else rescaled to about this many points
  bool no_cgal = false;  ///< skip CGAL's WLOP
  bool scaling = false;  ///< 1 vs 2 threads, CLOP's growth over `sizes`, peak memory
  std::vector<long> sizes{10000, 100000, 1000000};
};
/// CLOP Fig. 9's Camel case: the claim's CLOP and WLOP, CGAL's WLOP with WLOP's kernel,
/// iterations and particles, and CLOP with density = kernel. Prints as it goes; returns the JSON.
Json bench_resample(const ResampleBenchOptions& o);

struct FilterBenchOptions : BenchOptions {
  std::string dataset;  ///< empty: the claim's (fandisk_block)
  long points = 0;
  bool scaling = false;  ///< also GPF's chain on 1 vs 2 threads (gpf_threads_2_over_1)
};
/// GPF Table 1's Block case: the claim's GPF chain (normals timed as their own case and counted in
/// GPF's total, as Table 1 counts them), WLOP, CLOP and the EAR chain.
Json bench_filter(const FilterBenchOptions& o);

struct SubdivideBenchOptions : BenchOptions {
  int resolution = 16;
  double sigma_0 = 0.01;
};
/// GP-Loop (GPS sec. 4-5) against linear Loop on the same control mesh, levels 1-4, and both limit
/// surfaces' distance to the smooth originals of coarse sphere and torus control meshes.
Json bench_subdivide(const SubdivideBenchOptions& o);

}  // namespace scanbench::harness
