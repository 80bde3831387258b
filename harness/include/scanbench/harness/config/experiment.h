#pragma once
// Experiment configs (JSON, version 1) and their expansion into jobs.
//
// A config names datasets (registered names or mesh paths), scanner presets with overrides,
// algorithm variants (one registered algorithm or a chain, each step with parameters), metrics,
// sweeps over any declared parameter (scanner and dataset parameters included), seeds, timing
// repeats, threads and per-job limits. Every value is validated when the config is loaded:
// unknown keys, wrong types and out-of-range values throw ParamError with the file, the JSON
// path and what was expected ("sweep.json: /variants/0/sweep/resample.clop.alpha/2: expected a
// number in [1, 10], got 11"). The schemas come from the registries (declared parameters), so
// nothing here can drift from the algorithms. The format is documented in README ("Experiments").
//
// Expansion: datasets x scanners x variants x sweep points x seeds, in that (stable) order. A
// sweep is an object {"<target>.<param>": values, ...} whose keys form a Cartesian product;
// "sweep" may also be an array of such objects (their union). <target> is "scanner", "dataset",
// or a chain step (its algorithm name or its "label"). values: a JSON array, or a range
// {"from": a, "to": b, "step": s} (b included when reached within 1e-9 relative), or
// {"from": a, "to": b, "count": n} (n evenly spaced values, ends included).
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "scanbench/core/params.h"

namespace scanbench::harness {

/// Current config format version (key "scanbench_experiment").
inline constexpr int kExperimentVersion = 1;

/// The scanner entry that does not scan: `"scanners": ["ground_truth"]` hands the dataset's
/// ground-truth mesh to the chain as its input (StageData.mesh, no points), e.g. for
/// mesh.decimate -> subdivide.*; the metrics still score the output against that same, untouched
/// ground truth, and the metrics of a scan (surface.input_distance) are skipped. It takes no
/// parameters; its jobs write no scan. Every variant must accept every input its datasets get
/// (a scan's points, or this mesh): the chain type check names the step that does not.
inline constexpr std::string_view kGroundTruthInput = "ground_truth";

/// The scanner entry of a point dataset (DatasetSpec::points): the chain starts from the dataset's
/// points as read (a COLMAP model or a point-cloud file), without a scan. Set by the loader; a
/// config does not name it.
inline constexpr std::string_view kPointsInput = "points";

struct ScannerSpec {
  std::string label;   ///< shown in tables; defaults to the preset name
  std::string preset;  ///< a registered scanner preset
  Json overrides = Json::object();
};

struct DatasetSpec {
  std::string label;  ///< shown in tables; defaults to the name (or the file stem)
  std::string name;   ///< registered dataset name or mesh path
  Json params = Json::object();
  bool optional = false;  ///< a missing mesh file is skipped with a note instead of an error
  std::vector<ScannerSpec> scanners;
  /// A point dataset ("points" in the config): its input instead of a scan, a COLMAP model
  /// folder (sparse .bin/.txt, or a dense workspace with fused.ply; colmap::import_dir) or a
  /// point-cloud file (.ply, .xyz); its one scanner is kPointsInput. The ground truth is then the
  /// mesh `name`, or the point cloud `gt_points` (PLY or .xyz) with an optional 4 x 4
  /// `gt_transform` and crop box `gt_crop` (metrics/point_truth.h: only the point-capable
  /// metrics run). Jobs carry these four in dataset_params under the same keys.
  std::string points, gt_points, gt_transform, gt_crop;
};

struct StepSpec {
  std::string algorithm;  ///< registered algorithm name
  std::string label;      ///< optional name used by sweep keys (defaults to the algorithm)
  Json params = Json::object();
};

/// One sweep: key -> list of values (already expanded from ranges), keys in config order.
using Sweep = std::vector<std::pair<std::string, std::vector<Json>>>;

struct VariantSpec {
  std::string label;
  std::vector<StepSpec> chain;
  std::vector<Sweep> sweeps;   ///< union of Cartesian products; empty = one point
  double timeout_s = 0;        ///< > 0: overrides the experiment's per-job timeout
  double memory_limit_mb = 0;  ///< > 0: overrides the experiment's per-job memory limit
  /// Labels of the datasets this variant runs on ("datasets": [...] in the config); empty = all.
  std::vector<std::string> datasets;
  bool applies_to(const std::string& dataset_label) const {
    return datasets.empty() ||
           std::find(datasets.begin(), datasets.end(), dataset_label) != datasets.end();
  }
};

struct Experiment {
  std::filesystem::path file;  ///< where it was loaded from (for messages)
  std::string name;
  std::string description;
  std::vector<std::uint64_t> seeds{1};
  int repeats = 1;
  int threads = 1;
  double timeout_s = 600.0;
  double memory_limit_mb = 4096.0;
  bool save_outputs = true;
  std::vector<DatasetSpec> datasets;
  std::vector<VariantSpec> variants;
  std::vector<Sweep> sweeps;            ///< global sweeps (keys "scanner.*" / "dataset.*" only)
  std::vector<std::string> metrics;     ///< empty = every registered metric
  Json metric_params = Json::object();  ///< metric name -> effective params
  Json compare = Json::object();        ///< tolerances for `scanbench compare` (see compare.h)
  Json report = Json::object();         ///< plot hints for `scanbench report`
  Json raw;                             ///< the config as read
};

/// The longest label or name a config may give (bytes). Experiment names, dataset, scanner,
/// step and variant labels and claim ids become parts of file and folder names (results/<name>,
/// OUT/tuning-<variant>, DIR/<claim id>) and of table cells.
inline constexpr std::size_t kMaxLabelLength = 100;

/// Throws ParamError "<where>: "<label>" <why>" unless `label` is safe as one component of a
/// path inside a results folder: not empty, at most kMaxLabelLength bytes, no '/' or '\\', not
/// "." or "..", no control character (bytes below 0x20 and 0x7f). Every label and name is checked
/// when a config or claim file is parsed, so no user text can lead a write out of the folder.
void check_label(const std::string& label, const std::string& where);

/// The most jobs one experiment may expand to. The job count (datasets x scanners x variants x
/// sweep points x seeds, each sweep's points counted before duplicates are merged) is computed
/// with saturating arithmetic when the config is parsed, before any job is built, so a sweep
/// product of 1e12 is refused in one line instead of exhausting memory.
inline constexpr std::uint64_t kMaxJobs = 100000;

/// Reads and validates a config file. Throws IoError (unreadable, not JSON, nested deeper than
/// kJsonMaxDepth, core/json_text.h) or ParamError (a duplicate key, an invalid value or label,
/// more than kMaxJobs jobs).
Experiment load_experiment(const std::filesystem::path& file);
/// Validates a parsed config; `where` prefixes messages (usually the file name).
Experiment parse_experiment(const Json& config, const std::string& where);

/// One job: everything a child process needs, with every parameter effective (defaults filled).
struct Job {
  std::string id;   ///< 16 hex digits: hash of the canonical description below
  std::string key;  ///< readable and stable: dataset|scanner|variant|point|seed
  std::string experiment;
  std::string dataset_label, dataset;  ///< dataset: registered name or mesh path
  Json dataset_params = Json::object();
  std::string scanner_label, scanner_preset;
  Json scanner_params = Json::object();  ///< complete effective scanner parameters
  std::string variant;
  Json chain = Json::array();   ///< [{"algorithm", "label", "params"}], params effective
  Json point = Json::object();  ///< the sweep assignments of this job ("key": value)
  std::string point_label;      ///< "alpha=2 levels=4" (empty without sweeps)
  std::uint64_t seed = 1;
  int repeats = 1;
  int threads = 1;
  double timeout_s = 600.0;
  double memory_limit_mb = 4096.0;
  bool save_outputs = true;
  std::vector<std::string> metrics;
  Json metric_params = Json::object();

  Json to_json() const;
  static Job from_json(const Json& j);
  /// Flat effective parameters: "dataset.x", "scanner.x", "<step>.x".
  Json flat_params() const;
};

struct Plan {
  std::vector<Job> jobs;
  std::vector<std::string> notes;  ///< e.g. skipped datasets whose files are absent
};

/// Expands the config into jobs (see the top of this file). Throws ParamError for sweep values
/// that the parameter's declaration rejects, and for duplicate job keys.
Plan expand(const Experiment& e);

/// 16 hex digits of a 64-bit content hash (FNV-1a, then mixed) of `bytes`.
std::string content_hash(std::string_view bytes);

}  // namespace scanbench::harness
