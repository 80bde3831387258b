#pragma once
// COLMAP's reconstruction files (COLMAP documentation, "Output Format"): a sparse model is a
// folder with cameras, images and points3D, either as .bin or as .txt; a dense reconstruction is
// fused.ply (stereo_fusion) with fused.ply.vis. Readers are strict: a malformed, truncated or
// inconsistent file throws IoError("<path>: <record>: <what>"), e.g.
// "sparse/points3D.bin: point 12 (id 57): track image 9 is not in images.bin".
//
// Mapping to a scan (the layout of docs/formats.md, "Point clouds"): one sensor per registered
// image, at the camera centre C = -R^T t (R the world-to-camera rotation of the quaternion qvec);
// scan_id = the sensor of the image with the smallest id in the point's track (the first image
// seeing the point); float properties `track_length` (number of observations; for a fused point,
// the number of images in its visibility list) and, for a sparse point, `reprojection_error`
// (COLMAP's mean reprojection error, pixels).
//
// Hand-written: COLMAP ships no library of its readers in Debian (only the colmap program), and the
// formats are a few fixed records.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "scanbench/core/point_cloud.h"

namespace scanbench::colmap {

struct Camera {
  std::uint32_t id = 0;
  std::string model;  ///< COLMAP's model name, e.g. "PINHOLE", "SIMPLE_RADIAL"
  std::uint64_t width = 0;
  std::uint64_t height = 0;
  std::vector<double> params;  ///< as many as the model has (e.g. PINHOLE: fx fy cx cy)
};

struct Image {
  std::uint32_t id = 0;
  Eigen::Quaterniond rotation{1, 0, 0, 0};  ///< world to camera (qw qx qy qz)
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  std::uint32_t camera_id = 0;
  std::string name;
  std::vector<Eigen::Vector2d> xy;        ///< 2-D observations (pixels)
  std::vector<std::int64_t> point3d_ids;  ///< one per observation, -1 when not triangulated
  /// The camera centre in world coordinates, -R^T t.
  Eigen::Vector3d centre() const;
};

struct Point {
  std::uint64_t id = 0;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  std::array<std::uint8_t, 3> rgb{0, 0, 0};
  double error = 0.0;                                          ///< mean reprojection error, pixels
  std::vector<std::pair<std::uint32_t, std::uint32_t>> track;  ///< (image id, point2D index)
};

struct Model {
  std::vector<Camera> cameras;
  std::vector<Image> images;  ///< in file order (the order fused.ply.vis indexes)
  std::vector<Point> points;
};

/// Number of parameters of a COLMAP camera model name; -1 when the name is unknown.
int camera_model_params(const std::string& model);

/// The sparse model in `dir`: cameras.bin, images.bin, points3D.bin when cameras.bin exists, else
/// the .txt files. Checks ids (unique, cameras and track images exist, point2D indices in range).
Model read_model(const std::filesystem::path& dir);
/// Writes cameras.txt, images.txt and points3D.txt (COLMAP's text format, 17 significant digits).
/// Images may have no observations (an empty second line), as point_triangulator expects for a
/// model of known poses.
void write_model_text(const Model& model, const std::filesystem::path& dir);

/// The scan of a sparse model (mapping above). Throws IoError naming `name` when it has no points.
PointCloud model_to_cloud(const Model& model, const std::string& name);

/// fused.ply (read as a point cloud: positions, normals, colours kept as float properties) with its
/// visibility file `<fused>.vis` (uint64 count, then per point uint32 n and n uint32 image indices
/// into `model.images`), mapped as above.
PointCloud read_fused(const std::filesystem::path& fused, const Model& model);

/// `scanbench import colmap DIR`: a dense workspace when DIR/fused.ply exists (its model in
/// DIR/sparse, as image_undistorter lays it out), else DIR is a sparse model folder.
PointCloud import_dir(const std::filesystem::path& dir);

}  // namespace scanbench::colmap
