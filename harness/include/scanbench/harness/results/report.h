#pragma once
// `scanbench report DIR`: one HTML page (DIR/index.html) that works offline: no external file,
// plots as inline SVG; the only script is the 3D viewer's, inlined (results/report_viewer.h).
//
// Contents: the run context and status counts; failed jobs with their reasons; comparison
// tables (rows dataset / scanner / sweep point, columns variants) for the main accuracy, regularity
// and timing quantities; sweep plots (for every variant with a numeric sweep: each of the plotted
// metrics against the first swept parameter, one line per value of the other swept parameters,
// e.g. error and regularity against alpha per HEM level, or against h); error against compression
// (scan points / mixture components) when the variant produces a mixture (CLOP paper Fig. 13);
// heatmaps of a metric over two swept parameters; time per phase (stacked bars, medians); error
// histograms per dataset and variant; a 3D viewer of the outputs coloured by their error; the
// verdicts of DIR/compare.json when present (nightly); and per job the links to its scan,
// sidecar, outputs, log and any .vdb/.png artifacts.
// "report" in the experiment config may set {"metrics": [keys to plot], "x": "<sweep key>"}.
//
// Nothing is pooled silently: every table and section states what a value aggregates (seeds,
// repeats; sweep points separate). The first screen, "What was compared and what won", compares
// each variant at its best sweep point (the argmin or argmax in the metric's direction, named
// with the point: "CLOP (h=0.04)"; table.h best_points); on keys that score mesh and point
// outputs differently (the Chamfer / F-score family) a row that mixes them gets a winner per kind,
// marked not comparable. Histograms: one line per sweep point of a swept variant, labelled with
// the point; sweep plots carry the unswept variants of the same data as dashed reference lines.
// A name in "report" (a metric no record holds, an "x" that is no swept key) is a ParamError
// naming DIR/config.json and the field, with a "did you mean" suggestion.
#include <filesystem>

namespace scanbench::harness {

/// Writes the page; returns its path (`out`, default DIR/index.html). Throws IoError, ParamError
/// (an unknown name in the config's "report"). With a
/// `history_db` (history.h) the page gains a History section: per (dataset, variant) the
/// headline metrics and time.total over the commits of the database, the baseline's commit and
/// the change points marked.
std::filesystem::path write_report(const std::filesystem::path& dir,
                                   const std::filesystem::path& out = {},
                                   const std::filesystem::path& history_db = {});

}  // namespace scanbench::harness
