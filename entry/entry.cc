#include "entry/entry.h"

#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "base/text_file.h"
#include "calib/calib_io.h"
#include "entry/mesh_gltf.h"
#include "entry/mesh_io.h"
#include "entry/preview.h"
#include "render/renderer.h"

namespace mm {

EncodedEntry EncodeEntry(const PairReconstruction& r, const cv::Mat& image_a,
                         const cv::Mat& image_b, const BouguetCamera& camera,
                         std::chrono::steady_clock::time_point started, EntryReport* report) {
  const TwoViewResult& g = r.geometry;
  EncodedEntry out;
  std::vector<uchar> jpeg, jpeg_b;
  cv::imencode(".jpg", image_a, jpeg, {cv::IMWRITE_JPEG_QUALITY, 92});
  cv::imencode(".jpg", image_b, jpeg_b, {cv::IMWRITE_JPEG_QUALITY, 92});
  const std::string texture(jpeg.begin(), jpeg.end());
  // mesh.glb is the primary output (one file, texture inside).
  const bool metric = report->scale.units == "metres";
  GlbInfo glb;
  if (metric) {
    glb.scale_note = "metres (scale from " + report->scale.source + ", " +
                     std::to_string(report->scale.metres_per_unit) + " m per baseline unit)";
  }
  const std::string units = metric ? "in metres" : "up to scale";
  out.files.push_back({"mesh.glb", EncodeGlb(r.mesh, texture, glb)});
  out.files.push_back({"mesh.ply", EncodePly(r.mesh, "monomesh two-view mesh, " + units)});
  out.files.push_back({"mesh.obj", EncodeObj(r.mesh, "mesh.mtl")});
  out.files.push_back({"mesh.mtl", EncodeMtl("texture.jpg")});
  out.files.push_back({"texture.jpg", texture});
  out.files.push_back({"keyframe_b.jpg", std::string(jpeg_b.begin(), jpeg_b.end())});
  const auto point_colors = SampleColors(image_a, r.point_pixels_a);
  out.files.push_back({"points.ply", EncodePointsPly(g.points_in_cam_a, point_colors,
                                                     "monomesh two-view points, " + units)});
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
      Eigen::Isometry3d cam_b_from_cam_a = Eigen::Isometry3d::Identity();
      cam_b_from_cam_a.linear() = r.geometry.rotation;
      cam_b_from_cam_a.translation() = r.geometry.translation;
      preview = RenderPreview(renderer, r.mesh, image_a, camera.K(), image_a.cols, image_a.rows,
                              &preview_error, &cam_b_from_cam_a);
    }
    std::vector<uchar> png;
    if (!preview.empty() && cv::imencode(".png", preview, png)) {
      out.files.push_back({"preview.png", std::string(png.begin(), png.end())});
      report->preview = EntryReport::Preview{
          .file = "preview.png", .renderer = renderer.gl_renderer(), .error = {}};
    } else {
      EntryReport::Preview none;
      none.error = preview_error.empty() ? "PNG encoding failed" : preview_error;
      report->preview = none;
    }
    report->timings_s.preview =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - render_start).count();
  }
  report->timings_s.encode =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count() -
      r.times.total_s() - *report->timings_s.preview;
  // report.json is written last, so a reader that sees it knows the entry's other files.
  out.files.push_back({"report.json", FormatEntryReport(*report)});
  return out;
}

SpoolCommit WriteEntry(Spool& spool, const EncodedEntry& entry, std::time_t when) {
  return spool.Commit(entry.files, when);
}

std::string ReadReportJson(const std::filesystem::path& entry_dir, nlohmann::json* report) {
  const std::filesystem::path file = entry_dir / "report.json";
  std::string error;
  const std::optional<std::string> text = ReadTextFile(file, kMaxDataFileBytes, &error);
  if (!text) return error;
  try {
    *report = nlohmann::json::parse(*text);
  } catch (const nlohmann::json::exception& e) {
    return file.string() + ": " + e.what();
  }
  return {};
}

std::string ReadEntryReport(const std::filesystem::path& entry_dir, EntryReport* report) {
  nlohmann::json j;
  if (std::string error = ReadReportJson(entry_dir, &j); !error.empty()) return error;
  if (std::string problem = FromJson(j, report); !problem.empty()) {
    return (entry_dir / "report.json").string() + ": " + problem;
  }
  return {};
}

}  // namespace mm
