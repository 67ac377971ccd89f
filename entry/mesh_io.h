#pragma once
// Mesh encoders. They produce bytes in memory; writing files (atomically) is the spool's job.
//
// Thread-safety: pure functions; reentrant.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <span>
#include <string>

#include "recon/mesh.h"

namespace mm {

/// Binary little-endian PLY: vertices (x y z, red green blue, s t) and faces (vertex_indices).
std::string EncodePly(const Mesh& mesh, const std::string& comment = "");

/// Wavefront OBJ with `v`, `vt` and `f v/vt` lines, using material `material_name` from
/// `mtl_file`.
std::string EncodeObj(const Mesh& mesh, const std::string& mtl_file,
                      const std::string& material_name = "keyframe_a");

/// The MTL that maps `material_name` to the texture image `texture_file`.
std::string EncodeMtl(const std::string& texture_file,
                      const std::string& material_name = "keyframe_a");

/// Binary little-endian PLY of a point cloud: x y z (float) and red green blue (uchar).
/// `colors_rgb` may be empty (no colour properties).
std::string EncodePointsPly(std::span<const Eigen::Vector3d> points,
                            std::span<const Eigen::Matrix<uint8_t, 3, 1>> colors_rgb,
                            const std::string& comment = "");

/// A two-view sparse model in COLMAP's text format (cameras.txt, images.txt, points3D.txt;
/// https://colmap.github.io/format.html). Image 1 is keyframe A at the origin, image 2 is
/// keyframe B at cam_b_from_cam_a. Pixels are OpenCV-style (centre of the first pixel at 0)
/// and are shifted by +0.5 into COLMAP's convention (centre at 0.5).
struct ColmapInput {
  int width = 0;
  int height = 0;
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();  ///< Skew is dropped (PINHOLE has none).
  Eigen::Matrix3d rotation_b_from_a = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation_b_from_a = Eigen::Vector3d::Zero();
  std::string image_a_name = "keyframe_a.jpg";
  std::string image_b_name = "keyframe_b.jpg";
  std::span<const Eigen::Vector3d> points_in_cam_a;
  std::span<const Eigen::Vector2d> pixels_a;                 ///< Per point.
  std::span<const Eigen::Vector2d> pixels_b;                 ///< Per point.
  std::span<const Eigen::Matrix<uint8_t, 3, 1>> colors_rgb;  ///< Per point, or empty.
};

struct ColmapText {
  std::string cameras;
  std::string images;
  std::string points3d;
};

/// A sparse model of any number of images of one PINHOLE camera, for COLMAP's text format.
struct ColmapModel {
  int width = 0;
  int height = 0;
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();  ///< Skew is dropped (PINHOLE has none).
  std::string scale_note;  ///< A comment in images.txt (e.g. the model's unit).
  struct Image {
    std::string name;
    Eigen::Isometry3d cam_from_world = Eigen::Isometry3d::Identity();
  };
  std::vector<Image> images;
  struct Observation {
    int image = 0;          ///< Index into images.
    Eigen::Vector2d pixel;  ///< OpenCV-style (centre of the first pixel at 0).
  };
  struct Point {
    Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< World frame.
    Eigen::Matrix<uint8_t, 3, 1> rgb{128, 128, 128};
    std::vector<Observation> track;
  };
  std::vector<Point> points;
};
ColmapText EncodeColmapModel(const ColmapModel& model);

ColmapText EncodeColmapText(const ColmapInput& in);

/// Per-point RGB sampled (nearest) from a BGR8 image at the given pixels.
std::vector<Eigen::Matrix<uint8_t, 3, 1>> SampleColors(const cv::Mat& image_bgr,
                                                       std::span<const Eigen::Vector2d> pixels);

}  // namespace mm
