#pragma once
// Error heatmaps and histogram images (PNG, OpenImageIO; OIIO stays private to this module).
//
// Heatmap layout (pixels): a title bar of 40 rows on top; below it four orthographic views of
// width x height each, side by side, in the fixed order front (camera on +z looking to -z, x
// right, y up), right (camera on +x), back (camera on -z) and top (camera on +y, x right, -z up);
// then a colour bar 110 columns wide. Total size: (4 * width + 110) x (height + 40). The views
// frame the given bounding box (its diagonal spans 95% of the shorter view side).
// Each point is splatted as a disc of splat_radius pixels with a depth test (the point nearest
// to the camera wins a pixel; ties keep the lower index) and coloured by t = clamp(|E| / (range x
// diagonal), 0, 1) through the viridis map (viridis_color; perceptually uniform, sequential):
// t = 0 is dark purple, t = 1 yellow; errors above the range saturate. The background is white. The colour bar shows the map from 0 (bottom) to
// the stated range (top) with labels in DejaVuSans.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "scanbench/core/bbox.h"
#include "scanbench/core/params.h"
#include "scanbench/core/point_cloud.h"

namespace scanbench::metrics {

struct HeatmapParams {
  int width = 400;       ///< pixels per view
  int height = 400;      ///< pixels per view
  double range = 0.005;  ///< colour scale [0, range], fraction of the diagonal
  int splat_radius = 1;  ///< disc radius in pixels (0 = one pixel)
  static void declare(ParamDeclarer<HeatmapParams>& d) {
    d.integer("width", &HeatmapParams::width, Range::closed(64, 4096), "px", "width of a view");
    d.integer("height", &HeatmapParams::height, Range::closed(64, 4096), "px", "height of a view");
    d.real("range", &HeatmapParams::range, Range::above(0.0), "diag",
           "fixed colour range: |E| = range is the top of the viridis map");
    d.integer("splat_radius", &HeatmapParams::splat_radius, Range::closed(0, 16), "px",
              "point splat radius");
  }
};

/// Columns and rows of the heatmap image for these parameters.
Eigen::Vector2i heatmap_size(const HeatmapParams& p);

/// Writes the heatmap of `errors` (one per point, lengths in mesh units; the absolute value is
/// used) to `png`. `frame` fixes the views (normally the ground truth's box) and `diagonal` the
/// unit of `range`. Throws InputError for mismatched sizes or non-finite errors, IoError when the
/// file or the font cannot be written or found.
void write_heatmap(const PointCloud& points, const Eigen::VectorXf& errors,
                   const BoundingBox& frame, float diagonal, const HeatmapParams& p,
                   const std::filesystem::path& png, const std::string& title);

/// One view of the heatmap's splat renderer as an RGB image (0..1 floats, row-major, 3 a
/// pixel; background white) with its coverage mask.
struct SplatImage {
  int width = 0, height = 0;
  std::vector<float> rgb;
  std::vector<std::uint8_t> covered;
};

/// Views of render_splats: the heatmap's four (0 front, 1 right, 2 back, 3 top, as above) and
/// 4 iso (camera on +(1, 1, 1), y up).
inline constexpr int kViewIso = 4;

/// How errors map to colours: Magnitude, viridis at t = min(|e| / range, 1) (sequential; the
/// heatmaps and the viewer's default); Signed, the cool-warm diverging map at
/// t = (1 + clamp(e / range, -1, 1)) / 2 (negative blue, 0 grey, positive red).
enum class ErrorScale { Magnitude, Signed };

/// The colour of error e under `scale` with saturation `range` (> 0).
Eigen::Vector3f error_color(float e, float range, ErrorScale scale);

/// The colour at t in [0, 1] of `scale`'s map (viridis_color or diverging_color): a colour
/// bar's row at fraction t of its height.
Eigen::Vector3f map_color(float t, ErrorScale scale);

/// The value a colour bar that saturates at `top` shows at fraction f of its height (0 bottom,
/// 1 top): f x top, or for Signed (2 f - 1) x top.
double bar_value(double f, double top, ErrorScale scale);

/// Splats `positions` (errors per point, their colour error_color(e, range, colours)) into one
/// width x height view
/// framing `frame` exactly as write_heatmap does (same projection, disc splats, depth test, ties
/// keep the lower index). Unshaded (`shaded` false): each covered pixel is the error's colour.
/// Shaded: that colour x s, with s = 0.35 + 0.65 |n . c| (Lambert, light at the camera c)
/// when `normals` has a column per point, else s = 1 - 0.5 (z - z_min) / (z_max - z_min) over
/// the frame's depth range (nearer is brighter). Throws InputError for mismatched sizes.
SplatImage render_splats(const Eigen::Matrix3Xf& positions, const Eigen::Matrix3Xf& normals,
                         const Eigen::VectorXf& errors, const BoundingBox& frame, int view,
                         int width, int height, int splat_radius, float range, bool shaded,
                         ErrorScale colours = ErrorScale::Magnitude);

/// Layout of a figure grid (write_figure_png): total width x height pixels; a title band of
/// `top` rows, then a column-label band of 24 rows; row labels in the `left` columns; cells of
/// cell_w x cell_h; the colour bar from column bar_x on.
struct FigureLayout {
  int left = 0, top = 0, cell_w = 0, cell_h = 0, bar_x = 0;
};
/// Throws InputError naming the size when the cells would be smaller than 16 x 16 pixels.
FigureLayout figure_layout(int width, int height, int rows, int cols);

/// A grid of cells (row-major, rows x cols, each cell_w x cell_h of figure_layout) with row and
/// column labels, a title and a colour bar labelled `unit` (Magnitude: viridis from 0 to
/// `saturation`; Signed: cool-warm from -saturation to +saturation), as a width x height PNG
/// written atomically. Throws IoError.
void write_figure_png(const std::vector<SplatImage>& cells, const std::vector<std::string>& rows,
                      const std::vector<std::string>& cols, const std::string& title,
                      double saturation, const std::string& unit, int width, int height,
                      const std::filesystem::path& png, ErrorScale scale = ErrorScale::Magnitude);

/// The PNG bytes of one image (for embedding). Throws IoError.
std::string encode_png(const SplatImage& img);

/// Bar chart of a histogram record (stats histogram JSON: counts, min, max, unit, overflow) as
/// a width x height PNG with a title, the axis range and the overflow count. Throws IoError.
void write_histogram_image(const Json& histogram, const std::filesystem::path& png,
                           const std::string& title, int width = 640, int height = 400);

/// The RGB colour (0..1, sRGB) of viridis at t: matplotlib's 256-entry table (van der Walt,
/// Smith and Firing, CC0), entry min(255, floor(256 t)) as matplotlib looks it up; t is clamped
/// to [0, 1], NaN maps to 0. The report's 3D viewer colours by the same table.
Eigen::Vector3f viridis_color(float t);

/// The 256 entries of viridis_color, in order (row i: t in [i/256, (i+1)/256)).
const float (&viridis_table())[256][3];

/// Moreland's smooth cool-warm diverging map at t in [0, 1] (K. Moreland, "Diverging Color Maps
/// for Scientific Visualization", ISVC 2009, sec. 4-5): linear interpolation in his Msh space
/// (polar CIELAB, D65) from blue (M, s, h) = (80, 1.08, -1.1) through an unsaturated white
/// M = 88 at t = 1/2 to red (80, 1.08, 0.5), with the hue spin of his adjust-hue rule; sRGB out,
/// each channel clamped to [0, 1]. Lightness rises then falls linearly in t: perceptually even
/// on each side and symmetric about 0, which viridis' monotone ramp is not.
Eigen::Vector3f cool_warm(double t);

/// The diverging map as the viewer and figures use it: entry min(255, floor(256 t)) of a
/// 256-entry table whose row i is cool_warm(i / 255); t clamped, NaN maps to 1/2 (zero error).
Eigen::Vector3f diverging_color(float t);

/// The 256 entries of diverging_color, in order.
const float (&diverging_table())[256][3];

}  // namespace scanbench::metrics
