#pragma once
// Private entry points of the COLMAP readers (scanbench/core/colmap.h) on data already in memory,
// shared by the path-based functions and the fuzz target (tests/fuzz/fuzz_readers.cpp). Each throws
// IoError("<name>: <record>: <what>") for malformed input and touches no file.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "scanbench/core/colmap.h"

namespace scanbench::colmap::detail {

std::vector<Camera> parse_cameras_bin(std::string_view data, const std::string& name);
std::vector<Camera> parse_cameras_txt(std::string_view text, const std::string& name);
std::vector<Image> parse_images_bin(std::string_view data, const std::string& name);
std::vector<Image> parse_images_txt(std::string_view text, const std::string& name);
std::vector<Point> parse_points_bin(std::string_view data, const std::string& name);
std::vector<Point> parse_points_txt(std::string_view text, const std::string& name);
/// fused.ply.vis: per point, the indices of the images that see it.
std::vector<std::vector<std::uint32_t>> parse_vis(std::string_view data, const std::string& name);

/// Cross-file checks: unique ids, every image's camera and every track's image exist, point2D
/// indices within the image's observations (when the images list them). `names` are the three
/// file names used in messages (cameras, images, points3D).
void check_model(const Model& model, const std::array<std::string, 3>& names);

}  // namespace scanbench::colmap::detail
