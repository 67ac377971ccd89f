#include "app/pair_job.h"

#include <Eigen/Geometry>
#include <chrono>
#include <opencv2/imgcodecs.hpp>

#include "calib/calib_io.h"
#include "recon/mesh_gltf.h"
#include "recon/mesh_io.h"
#include "render/mesh_eval.h"
#include "render/renderer.h"

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
                         const PairOptions& options, const Features* features_a,
                         std::span<const TrackCorrespondence> tracks,
                         std::span<const KeyframeBTry> tries) {
  PairJobResult out;
  const auto start = std::chrono::steady_clock::now();
  out.recon = features_a != nullptr
                  ? ReconstructPair(*features_a, image_a, image_b, camera, options, tracks)
                  : ReconstructPair(image_a, image_b, camera, options);
  const PairReconstruction& r = out.recon;
  const TwoViewResult& g = r.geometry;

  nlohmann::json& report = out.report;
  report["monomesh_version"] = MM_VERSION;
  report["success"] = r.success;
  report["failure_reason"] = r.failure_reason;
  report["pair_classification"] = {{"kind", PairKindName(g.classification.kind)},
                                   {"explanation", g.classification.explanation},
                                   {"f_inliers", g.classification.f_inliers},
                                   {"h_inliers", g.classification.h_inliers},
                                   {"median_flow_px", g.classification.median_flow_px}};
  report["ransac_f"] = {{"iterations", g.ransac_f.iterations},
                        {"required_iterations", g.ransac_f.required_iterations},
                        {"inliers", g.ransac_f.inliers.size()},
                        {"inlier_rms_px", g.ransac_f.inlier_rms_px}};
  report["bundle_adjustment"] = {{"ran", g.bundle.ran},
                                 {"converged", g.bundle.converged},
                                 {"iterations", g.bundle.iterations},
                                 {"adjusted_points", g.bundle.num_points},
                                 {"initial_rms_px", g.bundle.initial_rms_px},
                                 {"final_rms_px", g.bundle.final_rms_px},
                                 {"message", g.bundle.message}};
  report["keyframe_a_features_precomputed"] = features_a != nullptr;
  if (!tries.empty()) {
    // Every B this capture handed to the reconstruction; the refused ones say why.
    nlohmann::json list = nlohmann::json::array();
    for (const KeyframeBTry& t : tries) {
      const bool is_this = &t == &tries.back();
      list.push_back({{"frame", t.frame_sequence},
                      {"seconds_after_a", t.seconds_after_a},
                      {"gate_parallax_deg", t.gate_parallax_deg},
                      {"tracks", t.tracks},
                      {"accepted", is_this ? r.success : t.accepted},
                      {"failure", TwoViewFailureName(is_this ? g.failure : t.failure)},
                      {"reason", is_this ? r.failure_reason : t.reason}});
    }
    report["keyframe_b_tries"] = list;
  }
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
  report["counts"] = {
      {"features_a", r.features_a},
      {"features_b", r.features_b},
      {"matches", r.matches},
      {"gate_tracks", r.tracks},
      {"gate_tracks_used", r.tracks_used},
      {"gate_track_inliers", r.track_inliers},
      {"inliers", g.num_inliers},
      {"points", g.points_in_cam_a.size()},
      {"mesh_vertices", r.mesh.vertices.size()},
      {"mesh_triangles", r.mesh.triangles.size()},
      {"mesh_dropped_depth_discontinuity", r.mesh_summary.dropped_depth_discontinuity},
      {"mesh_dropped_grazing_angle", r.mesh_summary.dropped_grazing_angle}};
  report["meshing"] = {{"voxel_size", r.mesh_summary.voxel_size},
                       {"occupied_cells", r.mesh_summary.occupied_cells},
                       {"kept_cells", r.mesh_summary.kept_cells},
                       {"delaunay_triangles", r.mesh_summary.delaunay_triangles},
                       {"max_depth_ratio", options.mesh.max_depth_ratio},
                       {"max_grazing_angle_deg", options.mesh.max_grazing_angle_deg},
                       {"min_points_per_cell", options.mesh.min_points_per_cell},
                       {"voxel_vertex", options.mesh.voxel_vertex == VoxelVertex::kCentroid
                                            ? "centroid"
                                            : "cell_centre"}};
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
  std::vector<uchar> jpeg, jpeg_b;
  cv::imencode(".jpg", image_a, jpeg, {cv::IMWRITE_JPEG_QUALITY, 92});
  cv::imencode(".jpg", image_b, jpeg_b, {cv::IMWRITE_JPEG_QUALITY, 92});
  const std::string texture(jpeg.begin(), jpeg.end());
  // mesh.glb is the primary output (one file, texture inside).
  out.files.push_back({"mesh.glb", EncodeGlb(r.mesh, texture)});
  out.files.push_back({"mesh.ply", EncodePly(r.mesh, "monomesh two-view mesh, up to scale")});
  out.files.push_back({"mesh.obj", EncodeObj(r.mesh, "mesh.mtl")});
  out.files.push_back({"mesh.mtl", EncodeMtl("texture.jpg")});
  out.files.push_back({"texture.jpg", texture});
  out.files.push_back({"keyframe_b.jpg", std::string(jpeg_b.begin(), jpeg_b.end())});
  const auto point_colors = SampleColors(image_a, r.point_pixels_a);
  out.files.push_back({"points.ply", EncodePointsPly(g.points_in_cam_a, point_colors,
                                                     "monomesh two-view points, up to scale")});
  // The sparse model for COLMAP / OpenMVS: the entry folder is the model folder.
  ColmapInput colmap;
  colmap.width = image_a.cols;
  colmap.height = image_a.rows;
  colmap.K = camera.K();
  colmap.rotation_b_from_a = g.rotation;
  colmap.translation_b_from_a = g.translation;
  colmap.image_a_name = "texture.jpg";
  colmap.image_b_name = "keyframe_b.jpg";
  colmap.points_in_cam_a = g.points_in_cam_a;
  colmap.pixels_a = r.point_pixels_a;
  colmap.pixels_b = r.point_pixels_b;
  colmap.colors_rgb = point_colors;
  const ColmapText colmap_text = EncodeColmapText(colmap);
  out.files.push_back({"cameras.txt", colmap_text.cameras});
  out.files.push_back({"images.txt", colmap_text.images});
  out.files.push_back({"points3D.txt", colmap_text.points3d});
  out.files.push_back({"calibration.toml", FormatCalibrationToml(camera)});
  // preview.png: the mesh from A beside an oblique view from above (EGL, headless). A
  // machine without EGL still gets its entry; the report says why there is no preview.
  {
    const auto render_start = std::chrono::steady_clock::now();
    Renderer renderer;
    std::string preview_error = renderer.error();
    cv::Mat preview;
    if (renderer.ok()) {
      preview = RenderPreview(renderer, r.mesh, image_a, camera.K(), image_a.cols, image_a.rows,
                              &preview_error);
    }
    std::vector<uchar> png;
    if (!preview.empty() && cv::imencode(".png", preview, png)) {
      out.files.push_back({"preview.png", std::string(png.begin(), png.end())});
      report["preview"] = {{"file", "preview.png"}, {"renderer", renderer.gl_renderer()}};
    } else {
      report["preview"] = {{"error", preview_error.empty() ? "PNG encoding failed" : preview_error}};
    }
    report["timings_s"]["preview"] =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - render_start).count();
  }
  report["timings_s"]["encode"] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() -
      r.times.total_s() - report["timings_s"]["preview"].get<double>();
  // report.json is written last, so a reader that sees it knows the entry's other files.
  out.files.push_back({"report.json", report.dump(2) + "\n"});
  out.ok = true;
  return out;
}

}  // namespace mm
