#pragma once
// `scanbench report DIR`: one static HTML page (DIR/index.html) that works offline: no script,
// no external file, plots as inline SVG.
//
// Contents: the run context and status counts; failed jobs with their reasons; comparison
// tables (rows dataset / scanner / sweep point, columns variants) for the main accuracy, regularity
// and timing quantities; sweep plots (for every variant with a numeric sweep: each of the plotted
// metrics against the first swept parameter, one line per value of the other swept parameters,
// e.g. error and regularity against alpha per HEM level, or against h); error against compression
// (scan points / mixture components) when the variant produces a mixture (CLOP paper Fig. 13);
// heatmaps of a metric over two swept parameters; time per phase (stacked bars, medians); error
// histograms per dataset and variant; the verdicts of DIR/compare.json when present (nightly);
// and per job the links to its scan, sidecar, outputs, log and any .vdb/.png artifacts.
// "report" in the experiment config may set {"metrics": [keys to plot], "x": "<sweep key>"}.
#include <filesystem>

namespace scanbench::harness {

/// Writes the page; returns its path (`out`, default DIR/index.html). Throws IoError. With a
/// `history_db` (history.h) the page gains a History section: per (dataset, variant) the
/// headline metrics and time.total over the commits of the database, the baseline's commit and
/// the change points marked.
std::filesystem::path write_report(const std::filesystem::path& dir,
                                   const std::filesystem::path& out = {},
                                   const std::filesystem::path& history_db = {});

}  // namespace scanbench::harness
