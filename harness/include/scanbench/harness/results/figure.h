#pragma once
// `scanbench figure` (issue 53): a static figure grid for print. Rows are datasets, columns
// variants; each cell is the output of the first ok job (first seed; the first sweep point unless
// `point` names one) of that dataset and variant, splatted by the heatmaps' renderer
// (metrics::render_splats) from one view and coloured by |E| / diagonal, E the point-to-plane
// error (CLOP paper sec. 10.2) computed as the report's viewer does (output_cloud), through
// viridis with one colour scale for the whole figure.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace scanbench::harness {

struct FigureOptions {
  std::filesystem::path dir;          ///< results folder
  std::filesystem::path out;          ///< .png, .svg (cells as base64 PNG) or .pdf (one page)
  std::string metric = "p2plane";     ///< the per-point error; only p2plane for now
  std::vector<std::string> datasets;  ///< rows (default: every dataset, in record order)
  std::vector<std::string> variants;  ///< columns (default: every variant, in record order)
  std::string view = "iso";           ///< front, side, top or iso
  int width = 1200, height = 800;     ///< the whole figure, pixels
  std::string point;                  ///< sweep point label; empty = the first
  double max = 0.0;                   ///< saturation, |E| / diagonal; 0 = 95th percentile
  bool flat = false;                  ///< unshaded: each pixel exactly a colour-map entry
  bool signed_errors = false;         ///< signed E in the cool-warm map, -max..+max
  int splat_radius = 1;               ///< pixels
  std::int64_t budget = 200000;       ///< most points a cell shows (floor(k N / n) subsample)
};

struct FigureSummary {
  std::vector<std::string> rows, cols;
  double saturation = 0.0;        ///< |E| / diagonal at the top of the colour bar
  bool percentile = false;        ///< saturation is the 95th percentile (no --max)
  std::vector<std::string> jobs;  ///< job id of each cell (row-major), "" when none
};

/// Writes the figure (only opts.out, atomically). Throws InputError / ParamError naming the
/// folder or option for bad input (no records, unknown dataset, variant, view, point, metric).
FigureSummary write_figure(const FigureOptions& opts);

}  // namespace scanbench::harness
