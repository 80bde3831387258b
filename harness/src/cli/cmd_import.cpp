// scanbench import colmap DIR -o points.ply
#include <fmt/format.h>

#include <memory>
#include <string>

#include "cli/commands.h"
#include "scanbench/core/colmap.h"
#include "scanbench/core/io.h"

namespace scanbench::harness {

void add_import_command(Cli& cli) {
  struct Opts {
    std::string dir;
    std::string output;
  };
  auto opts = std::make_shared<Opts>();
  CLI::App* sub =
      cli.app.add_subcommand("import", "Convert another tool's reconstruction to a scan PLY");
  sub->require_subcommand(1);
  CLI::App* colmap = sub->add_subcommand(
      "colmap",
      "A COLMAP sparse model (cameras, images, points3D as .bin or .txt) or a dense workspace "
      "(DIR/fused.ply with fused.ply.vis, cameras from DIR/sparse): one point per 3-D point, "
      "scan_id = first image seeing it, track_length, reprojection_error (sparse), one sensor per "
      "image at its camera centre");
  colmap->add_option("dir", opts->dir, "Model folder or dense workspace")->required();
  colmap->add_option("-o,--output", opts->output, "Output scan PLY")->required();
  colmap->callback([&cli, opts] {
    cli.action = [opts] {
      const PointCloud cloud = colmap::import_dir(opts->dir);
      write_point_cloud(cloud, opts->output);
      fmt::print("import: {} points seen from {} images -> {}\n", cloud.size(),
                 cloud.sensor_origins.cols(), opts->output);
      return 0;
    };
  });
}

}  // namespace scanbench::harness
