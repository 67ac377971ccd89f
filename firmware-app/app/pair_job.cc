#include "app/pair_job.h"

#include <Eigen/Geometry>
#include <chrono>
#include <opencv2/imgcodecs.hpp>

#include "calib/calib_io.h"
#include "recon/mesh_io.h"

namespace mm {
namespace {

nlohmann::json KeyframeJson(const KeyframeInfo& k) {
  return {{"sequence", k.sequence},
          {"source_time_s", k.source_time_s},
          {"capture_time_ns", k.capture_time_ns},
          {"source", k.source}};
}

}  // namespace

PairJobResult RunPairJob(const cv::Mat& image_a, const cv::Mat& image_b, const KeyframeInfo& a,
                         const KeyframeInfo& b, const BouguetCamera& camera,
                         const PairOptions& options) {
  PairJobResult out;
  const auto start = std::chrono::steady_clock::now();
  out.recon = ReconstructPair(image_a, image_b, camera, options);
  const PairReconstruction& r = out.recon;
  const TwoViewResult& g = r.geometry;

  nlohmann::json& report = out.report;
  report["monomesh_version"] = MM_VERSION;
  report["success"] = r.success;
  report["failure_reason"] = r.failure_reason;
  report["keyframes"] = {{"a", KeyframeJson(a)}, {"b", KeyframeJson(b)}};
  report["camera"] = {{"image_size", {camera.width, camera.height}},
                      {"fc", {camera.fc.x(), camera.fc.y()}},
                      {"cc", {camera.cc.x(), camera.cc.y()}},
                      {"alpha_c", camera.alpha_c},
                      {"kc", camera.kc}};
  const Eigen::Quaterniond q(g.rotation);
  report["relative_pose"] = {
      {"convention", "cam_b_from_cam_a: X_b = R X_a + t"},
      {"rotation", {{g.rotation(0, 0), g.rotation(0, 1), g.rotation(0, 2)},
                    {g.rotation(1, 0), g.rotation(1, 1), g.rotation(1, 2)},
                    {g.rotation(2, 0), g.rotation(2, 1), g.rotation(2, 2)}}},
      {"quaternion_wxyz", {q.w(), q.x(), q.y(), q.z()}},
      {"translation", {g.translation.x(), g.translation.y(), g.translation.z()}}};
  report["scale"] =
      "up to scale: a monocular pair fixes no metric scale; |t| = 1 (the baseline) is the unit";
  report["counts"] = {{"features_a", r.features_a},
                      {"features_b", r.features_b},
                      {"matches", r.matches},
                      {"inliers", g.num_inliers},
                      {"points", g.points_in_cam_a.size()},
                      {"mesh_vertices", r.mesh.vertices.size()},
                      {"mesh_triangles", r.mesh.triangles.size()},
                      {"mesh_dropped_depth_discontinuity",
                       r.mesh_summary.dropped_depth_discontinuity}};
  report["quality"] = {{"median_triangulation_angle_deg", g.median_triangulation_angle_deg},
                       {"reprojection_rms_px", g.reprojection_rms_px}};
  report["timings_s"] = {{"features_a", r.times.features_a_s},
                         {"features_b", r.times.features_b_s},
                         {"matching", r.times.matching_s},
                         {"geometry", r.times.geometry_s},
                         {"meshing", r.times.meshing_s},
                         {"total_recon", r.times.total_s()}};

  if (!r.success) {
    out.error = r.failure_reason;
    return out;
  }
  std::vector<uchar> jpeg;
  cv::imencode(".jpg", image_a, jpeg, {cv::IMWRITE_JPEG_QUALITY, 92});
  out.files.push_back({"mesh.ply", EncodePly(r.mesh, "monomesh two-view mesh, up to scale")});
  out.files.push_back({"mesh.obj", EncodeObj(r.mesh, "mesh.mtl")});
  out.files.push_back({"mesh.mtl", EncodeMtl("texture.jpg")});
  out.files.push_back({"texture.jpg", std::string(jpeg.begin(), jpeg.end())});
  out.files.push_back({"calibration.toml", FormatCalibrationToml(camera)});
  report["timings_s"]["encode"] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() -
      r.times.total_s();
  // report.json is written last, so a reader that sees it knows the entry's other files.
  out.files.push_back({"report.json", report.dump(2) + "\n"});
  out.ok = true;
  return out;
}

}  // namespace mm
