// `monomesh render MESH.glb --camera CALIB.toml --out PNG [--pose qw qx qy qz tx ty tz]
//  [--preview] [--depth-out DEPTH.png]`: draws a mesh headless (EGL, render/renderer.h).

#include <array>
#include <iostream>
#include <opencv2/imgcodecs.hpp>

#include "calib/calib_io.h"
#include "cli/commands.h"
#include "entry/mesh_gltf.h"
#include "entry/preview.h"
#include "render/renderer.h"

namespace mm::cli {
namespace {

struct RenderArgs {
  std::string mesh, camera, out, depth_out;
  std::vector<double> pose;  ///< qw qx qy qz tx ty tz, cam_from_world (world = camera A).
  bool preview = false;
  double depth_scale = 1000.0;
};

int RunRender(const RenderArgs& args) {
  Mesh mesh;
  cv::Mat texture;
  if (const std::string err = ReadGlbFile(args.mesh, &mesh, &texture); !err.empty()) {
    std::cerr << "monomesh render: " << err << "\n";
    return kExitDataError;
  }
  const BouguetCamera camera = LoadCalibration(args.camera);
  const int width = camera.width > 0 ? camera.width : texture.cols;
  const int height = camera.height > 0 ? camera.height : texture.rows;
  Renderer renderer;
  if (!renderer.ok()) {
    std::cerr << "monomesh render: " << renderer.error() << "\n";
    return 1;
  }
  cv::Mat image;
  cv::Mat depth;
  if (args.preview) {
    std::string error;
    image = RenderPreview(renderer, mesh, texture, camera.K(), width, height, &error);
    if (image.empty()) {
      std::cerr << "monomesh render: " << error << "\n";
      return 1;
    }
  } else {
    RenderCamera cam;
    cam.K = camera.K();
    cam.width = width;
    cam.height = height;
    if (args.pose.size() == 7) {
      const Eigen::Quaterniond q(args.pose[0], args.pose[1], args.pose[2], args.pose[3]);
      cam.cam_from_world.linear() = q.normalized().toRotationMatrix();
      cam.cam_from_world.translation() = Eigen::Vector3d(args.pose[4], args.pose[5], args.pose[6]);
    }
    double far_plane = 1.0;
    for (const Eigen::Vector3f& v : mesh.vertices) {
      far_plane = std::max(far_plane, (cam.cam_from_world * v.cast<double>()).norm());
    }
    cam.far_plane = 2 * far_plane;
    cam.near_plane = cam.far_plane * 1e-4;
    const RenderResult r = renderer.Render(mesh, texture, cam);
    if (!r.success) {
      std::cerr << "monomesh render: " << r.failure_reason << "\n";
      return 1;
    }
    image = r.rgb;
    depth = r.depth;
    std::cout << "covered " << r.covered_pixels << " of " << width * height << " pixels\n";
  }
  if (!cv::imwrite(args.out, image)) {
    std::cerr << "monomesh render: cannot write " << args.out << "\n";
    return 1;
  }
  if (!args.depth_out.empty() && !depth.empty()) {
    cv::Mat depth16;
    depth.convertTo(depth16, CV_16UC1, args.depth_scale);
    if (!cv::imwrite(args.depth_out, depth16)) {
      std::cerr << "monomesh render: cannot write " << args.depth_out << "\n";
      return 1;
    }
  }
  std::cout << "rendered " << mesh.triangles.size() << " triangles with " << renderer.gl_renderer()
            << " to " << args.out << "\n";
  return 0;
}

}  // namespace

Runner AddRenderCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("render", "Render a mesh (GLB) from a camera to a PNG");
  auto args = std::make_shared<RenderArgs>();
  cmd->add_option("MESH", args->mesh, "Mesh (GLB, as written by monomesh)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--camera", args->camera,
                  "Calibration (TOML; undistorted: distortion is ignored) giving K and size")
      ->required()
      ->check(CLI::ExistingFile);
  auto* pose =
      cmd->add_option("--pose", args->pose,
                      "cam_from_world as qw qx qy qz tx ty tz (world = camera A; default identity)")
          ->expected(7);
  // The preview has its own views and no depth: --pose and --depth-out would be ignored.
  auto* depth_out = cmd->add_option(
      "--depth-out", args->depth_out,
      "Also write the depth as a 16-bit PNG (value = z * --depth-scale, 0 = empty)");
  cmd->add_flag("--preview", args->preview,
                "The spool's preview: the view from A beside an oblique view from above")
      ->excludes(pose)
      ->excludes(depth_out);
  cmd->add_option("--out", args->out, "Output PNG")->required();
  cmd->add_option("--depth-scale", args->depth_scale, "Depth PNG units per scene unit")
      ->capture_default_str()
      ->needs(depth_out);
  return [cmd, args]() -> int {
    if (!cmd->parsed()) return -1;
    return RunRender(*args);
  };
}

}  // namespace mm::cli
