#pragma once
// Tuning under a parameter protocol (docs/claims.md, "Parameter protocol"): each tuned variant's
// parameters chosen from the records of a tuning run on the tuning data, boundary optima extended
// or marked inconclusive, and the records at the protocol's values. The protocol itself (its
// schema, its checks, the configs it writes) is config/protocol.h; the runs go through a
// RecordsRunner (exec/runner.h: local_records_runner), so the choice depends on records only.
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "scanbench/harness/config/protocol.h"

namespace scanbench::harness {

/// The best point of tuning records by `objective` over `tuned` keys (records not "ok" or without
/// the quantity are skipped; a point with none is not a candidate). Fills `curve` with
/// "<key>=<v> ..." -> statistic. Throws Error when no point has a value.
Json choose_point(const std::vector<Json>& tuning_records,
                  const std::vector<const ProtocolParam*>& tuned,
                  const ProtocolObjective& objective, Json& curve);

/// Runs an experiment config into a folder and returns its records.
using RecordsRunner =
    std::function<std::vector<Json>(const Json& config, const std::filesystem::path& out)>;
/// Tunes every variant with tuned parameters (tuning_config, run into out/tuning-<variant>) and
/// returns the protocol with each tuned value chosen: h0_multiples ranges resolved first from
/// the tuning scans' size (one probe run into out/scan-sizes), boundary optima extended or marked
/// (config/protocol.h, "Boundary optima"; extension rounds in out/tuning-<variant>.ext<k>). Throws Error
/// when the probe finds no point count.
Protocol resolve_protocol(const Json& config, Protocol p, const std::filesystem::path& out,
                          const RecordsRunner& run);

/// The records at the protocol's values: records of a protocol variant swept over a range keep
/// only those at the value (`vary`, when given, is the one parameter taken at `at` instead).
std::vector<Json> records_at_protocol(const std::vector<Json>& records, const Protocol& p,
                                      const ProtocolParam* vary = nullptr, const Json& at = {});

}  // namespace scanbench::harness
