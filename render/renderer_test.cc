// The renderer on Mesa (llvmpipe here): real pixels of a synthetic textured plane, checked
// against what the camera model says they must be.
#include "render/renderer.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "entry/preview.h"
#include "eval/mesh_checks.h"

namespace mm {
namespace {

constexpr int kW = 160, kH = 120;

Eigen::Matrix3d TestK() {
  Eigen::Matrix3d K;
  K << 150, 3, 79.5, 0, 140, 59.5, 0, 0, 1;  // With skew.
  return K;
}

// A checkerboard texture (8 px squares) with a gradient, so that misplaced UVs show.
cv::Mat Texture() {
  cv::Mat t(kH, kW, CV_8UC3);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      const bool on = ((x / 8) + (y / 8)) % 2 == 0;
      t.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<uint8_t>(on ? 220 : 30),
                                        static_cast<uint8_t>(x), static_cast<uint8_t>(y * 2));
    }
  }
  return t;
}

// Two triangles on the plane z = depth whose projections are pixel rectangle [u0,u1]x[v0,v1]
// through K, with UVs = their own projections (texture = the camera's image).
Mesh Quad(const Eigen::Matrix3d& K, double depth, double u0, double v0, double u1, double v1) {
  Mesh mesh;
  const Eigen::Matrix3d Kinv = K.inverse();
  for (const auto& [u, v] : {std::pair{u0, v0}, {u1, v0}, {u1, v1}, {u0, v1}}) {
    mesh.vertices.push_back((Kinv * Eigen::Vector3d(u, v, 1) * depth).cast<float>());
    mesh.uvs.emplace_back(static_cast<float>((u + 0.5) / kW),
                          static_cast<float>(1.0 - (v + 0.5) / kH));
  }
  mesh.triangles = {{0, 2, 1}, {0, 3, 2}};
  return mesh;
}

TEST(GlProjection, MapsPixelCentresToFramebufferPixelCentres) {
  const Eigen::Matrix3d K = TestK();
  const Eigen::Matrix4f P = GlProjectionFromK(K, kW, kH, 0.1, 100.0);
  const Eigen::Vector3d x(0.3, -0.2, 2.5);
  const Eigen::Vector2d px = (K * x).hnormalized();
  const Eigen::Vector4f clip = P * Eigen::Vector4f(x.x(), x.y(), x.z(), 1);
  const Eigen::Vector3f ndc = clip.head<3>() / clip.w();
  EXPECT_NEAR((ndc.x() + 1) / 2 * kW, px.x() + 0.5, 1e-4);
  EXPECT_NEAR((ndc.y() + 1) / 2 * kH, px.y() + 0.5, 1e-4);
  for (double z : {0.1, 100.0}) {
    const Eigen::Vector4f c = P * Eigen::Vector4f(0, 0, static_cast<float>(z), 1);
    EXPECT_NEAR(c.z() / c.w(), z < 1 ? -1.0 : 1.0, 1e-5);
  }
}

class RendererTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { renderer_ = new Renderer(); }
  static void TearDownTestSuite() {
    delete renderer_;
    renderer_ = nullptr;
  }
  static Renderer* renderer_;
};
Renderer* RendererTest::renderer_ = nullptr;

TEST_F(RendererTest, DrawsTexturedPlaneWhereTheCameraModelSays) {
  ASSERT_TRUE(renderer_->ok()) << renderer_->error();
  std::cout << "GL_RENDERER: " << renderer_->gl_renderer() << "\n";
  const Eigen::Matrix3d K = TestK();
  const cv::Mat texture = Texture();
  const Mesh mesh = Quad(K, 2.0, 20, 10, 139, 99);  // Corner pixel centres.
  RenderCamera cam;
  cam.K = K;
  cam.width = kW;
  cam.height = kH;
  cam.far_plane = 10;
  const RenderResult r = renderer_->Render(mesh, texture, cam);
  ASSERT_TRUE(r.success) << r.failure_reason;
  // Pixels whose centres are inside the rectangle are drawn: 120 x 90.
  EXPECT_NEAR(r.covered_pixels, 120 * 90, 120 + 90);
  EXPECT_EQ(r.mask.at<uint8_t>(10 + 1, 20 + 1), 255);
  EXPECT_EQ(r.mask.at<uint8_t>(5, 5), 0);
  EXPECT_EQ(r.mask.at<uint8_t>(110, 150), 0);
  // Depth in scene units: the plane is at z = 2 (24-bit packing over far = 10: 6e-7 steps).
  EXPECT_NEAR(r.depth.at<float>(50, 80), 2.0f, 1e-4);
  EXPECT_EQ(r.depth.at<float>(5, 5), 0.0f);
  // Seen from the texture's own camera, the texture comes back in place: exact up to the
  // filtering at texel edges.
  cv::Mat inner = cv::Mat::zeros(kH, kW, CV_8UC1);
  cv::rectangle(inner, cv::Rect(22, 12, 116, 86), cv::Scalar(255), cv::FILLED);
  EXPECT_GT(MaskedNcc(r.rgb, texture, inner), 0.99);
  cv::Mat diff;
  cv::absdiff(r.rgb, texture, diff);
  EXPECT_LT(cv::mean(diff, inner)[0], 3.0);  // Blue: the checkerboard.
}

TEST_F(RendererTest, DepthFollowsThePoseAndTheNearestSurfaceWins) {
  ASSERT_TRUE(renderer_->ok()) << renderer_->error();
  const Eigen::Matrix3d K = TestK();
  Mesh far_plane = Quad(K, 4.0, 0, 0, kW - 1, kH - 1);
  const Mesh near_plane = Quad(K, 2.0, 40, 30, 119, 89);
  // Merge the two quads; the near one must occlude the far one whatever the draw order.
  const int offset = static_cast<int>(far_plane.vertices.size());
  for (size_t i = 0; i < near_plane.vertices.size(); ++i) {
    far_plane.vertices.push_back(near_plane.vertices[i]);
    far_plane.uvs.push_back(near_plane.uvs[i]);
  }
  for (const Eigen::Vector3i& t : near_plane.triangles) {
    far_plane.triangles.push_back(t + Eigen::Vector3i::Constant(offset));
  }
  RenderCamera cam;
  cam.K = K;
  cam.width = kW;
  cam.height = kH;
  cam.far_plane = 20;
  // The camera moved 0.5 forward: cam_from_world translation (0, 0, -0.5).
  cam.cam_from_world.translation() = Eigen::Vector3d(0, 0, -0.5);
  const RenderResult r = renderer_->Render(far_plane, cv::Mat(), cam);
  ASSERT_TRUE(r.success) << r.failure_reason;
  EXPECT_NEAR(r.depth.at<float>(60, 80), 1.5f, 1e-4);  // Near plane.
  EXPECT_NEAR(r.depth.at<float>(3, 3), 3.5f, 1e-4);    // Far plane around it.
  // Untextured: the default grey.
  EXPECT_NEAR(r.rgb.at<cv::Vec3b>(60, 80)[1], 153, 2);
}

TEST_F(RendererTest, MeshDepthEvaluationRecoversScaleAndError) {
  ASSERT_TRUE(renderer_->ok()) << renderer_->error();
  const Eigen::Matrix3d K = TestK();
  const Mesh mesh = Quad(K, 2.0, 0, 0, 79, kH - 1);  // Left half only.
  RenderCamera cam;
  cam.K = K;
  cam.width = kW;
  cam.height = kH;
  // Ground truth: the plane at 3 m over the whole image except a missing band.
  cv::Mat gt(kH, kW, CV_32FC1, cv::Scalar(3.0f));
  gt.rowRange(0, 12).setTo(0);
  const std::vector<Eigen::Vector3d> points{{0, 0, 2}, {0.1, 0.1, 2}, {-0.2, 0.1, 2}};
  std::vector<Eigen::Vector2d> pixels;
  for (const Eigen::Vector3d& p : points) pixels.push_back((K * p).hnormalized());
  const double scale = ScaleFromPoints(points, pixels, gt);
  EXPECT_NEAR(scale, 1.5, 1e-6);
  const MeshDepthEval e = EvaluateMeshDepth(*renderer_, mesh, cam, gt, scale);
  ASSERT_TRUE(e.success) << e.failure_reason;
  EXPECT_EQ(e.gt_pixels, kW * (kH - 12));
  // Columns whose pixel centres lie inside [0, 79] (edges on centres count half): 79-80 of
  // 160; measured 0.489.
  EXPECT_NEAR(e.coverage, 79.5 / 160, 0.01);
  EXPECT_LT(e.median_rel_err, 1e-4);
  EXPECT_NEAR(e.median_ratio, 1.0, 1e-4);
  // A wrong scale shows as error, and as a bias with its sign.
  const MeshDepthEval wrong = EvaluateMeshDepth(*renderer_, mesh, cam, gt, scale * 1.1);
  EXPECT_NEAR(wrong.median_rel_err, 0.1, 1e-3);
  EXPECT_NEAR(wrong.median_ratio, 1.1, 1e-3);
  const MeshDepthEval near = EvaluateMeshDepth(*renderer_, mesh, cam, gt, scale * 0.9);
  EXPECT_NEAR(near.median_ratio, 0.9, 1e-3);
}

TEST_F(RendererTest, PreviewHasBothViews) {
  ASSERT_TRUE(renderer_->ok()) << renderer_->error();
  const Eigen::Matrix3d K = TestK();
  const Mesh mesh = Quad(K, 2.0, 10, 10, 149, 109);
  std::string error;
  const cv::Mat preview = RenderPreview(*renderer_, mesh, Texture(), K, kW, kH, &error);
  ASSERT_FALSE(preview.empty()) << error;
  EXPECT_EQ(preview.cols, 3 * kW);
  cv::Mat gray;
  cv::cvtColor(preview, gray, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(gray.colRange(0, kW)), kW * kH / 2);
  // The oblique view sees the plane too, foreshortened.
  const int oblique = cv::countNonZero(gray.colRange(kW, 2 * kW));
  EXPECT_GT(oblique, kW * kH / 10);
  EXPECT_LT(oblique, cv::countNonZero(gray.colRange(0, kW)));
  // The shaded view covers the same pixels as the textured oblique one, in one flat grey (a
  // plane: one normal), not the texture's pattern; the cues (coloured, never grey) aside.
  const cv::Mat shaded = gray.colRange(2 * kW, 3 * kW);
  EXPECT_NEAR(cv::countNonZero(shaded), oblique, oblique / 20);
  std::vector<cv::Mat> bgr;
  cv::split(preview.colRange(2 * kW, 3 * kW), bgr);
  cv::Mat grey_pixels = (bgr[0] == bgr[1]) & (bgr[1] == bgr[2]) & (shaded > 0);
  cv::erode(grey_pixels, grey_pixels, cv::Mat());  // The interior: edges blend with black.
  cv::Scalar mean, stddev;
  cv::meanStdDev(shaded, mean, stddev, grey_pixels);
  EXPECT_GT(mean[0], 40);
  EXPECT_LT(stddev[0], 3.0);
}

// Pixels of `image` within a few levels of `color`.
int PixelsOf(const cv::Mat& image, const cv::Scalar& color) {
  cv::Mat near;
  cv::inRange(image, color - cv::Scalar::all(8), color + cv::Scalar::all(8), near);
  return cv::countNonZero(near);
}

// The oblique views draw camera A's and B's frusta and the ground grid (only beside the mesh,
// never over it); without B, only A's frustum.
TEST_F(RendererTest, PreviewDrawsBothCamerasAndAGroundGrid) {
  ASSERT_TRUE(renderer_->ok()) << renderer_->error();
  const Eigen::Matrix3d K = TestK();
  const Mesh mesh = Quad(K, 2.0, 10, 10, 149, 109);
  Eigen::Isometry3d cam_b_from_cam_a = Eigen::Isometry3d::Identity();
  cam_b_from_cam_a.translation() = Eigen::Vector3d(-0.4, 0.0, 0.0);  // B 0.4 to the right.
  std::string error;
  const cv::Mat preview =
      RenderPreview(*renderer_, mesh, Texture(), K, kW, kH, &error, &cam_b_from_cam_a);
  ASSERT_FALSE(preview.empty()) << error;
  for (const int panel : {1, 2}) {
    const cv::Mat view = preview.colRange(panel * kW, (panel + 1) * kW);
    EXPECT_GT(PixelsOf(view, kPreviewCameraAColor), 30) << "panel " << panel;
    EXPECT_GT(PixelsOf(view, kPreviewCameraBColor), 30) << "panel " << panel;
    EXPECT_GT(PixelsOf(view, kPreviewGridColor), 30) << "panel " << panel;
  }
  // Camera A's panel has no cues.
  const cv::Mat from_a = preview.colRange(0, kW);
  EXPECT_EQ(PixelsOf(from_a, kPreviewCameraAColor) + PixelsOf(from_a, kPreviewCameraBColor), 0);
  const cv::Mat only_a = RenderPreview(*renderer_, mesh, Texture(), K, kW, kH, &error);
  ASSERT_FALSE(only_a.empty()) << error;
  EXPECT_GT(PixelsOf(only_a.colRange(kW, 2 * kW), kPreviewCameraAColor), 30);
  EXPECT_EQ(PixelsOf(only_a.colRange(kW, 2 * kW), kPreviewCameraBColor), 0);
}

// A mesh uploaded once and drawn from many cameras (synthetic sequences): each draw equals a
// one-shot Render from the same camera; frame sizes may change between draws; released handles
// are refused.
TEST_F(RendererTest, UploadedMeshDrawsLikeOneShotRenders) {
  ASSERT_TRUE(renderer_->ok()) << renderer_->error();
  const Eigen::Matrix3d K = TestK();
  const Mesh mesh = Quad(K, 2.0, 20, 10, 139, 99);
  std::string error;
  const int id = renderer_->Upload(mesh, Texture(), UploadOptions{}, &error);
  ASSERT_GE(id, 0) << error;
  for (int i = 0; i < 3; ++i) {
    RenderCamera cam;
    cam.K = K;
    cam.width = kW - 16 * i;  // A new framebuffer size each time.
    cam.height = kH;
    cam.far_plane = 10;
    cam.cam_from_world.translation() = Eigen::Vector3d(0.05 * i, 0, 0.1 * i);
    const RenderResult drawn = renderer_->Draw(id, cam);
    const RenderResult once = renderer_->Render(mesh, Texture(), cam);
    ASSERT_TRUE(drawn.success) << drawn.failure_reason;
    EXPECT_EQ(drawn.rgb.cols, cam.width);
    EXPECT_EQ(cv::norm(drawn.rgb, once.rgb, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(drawn.depth, once.depth, cv::NORM_INF), 0.0);
  }
  // Mipmaps: the same picture where the texture is seen about 1:1 (trilinear at level 0).
  UploadOptions mip;
  mip.mipmaps = true;
  const int mip_id = renderer_->Upload(mesh, Texture(), mip, &error);
  ASSERT_GE(mip_id, 0) << error;
  RenderCamera cam;
  cam.K = K;
  cam.width = kW;
  cam.height = kH;
  const RenderResult plain = renderer_->Draw(id, cam), mipmapped = renderer_->Draw(mip_id, cam);
  cv::Mat inner = cv::Mat::zeros(kH, kW, CV_8UC1);
  cv::rectangle(inner, cv::Rect(22, 12, 116, 86), cv::Scalar(255), cv::FILLED);
  EXPECT_GT(MaskedNcc(plain.rgb, mipmapped.rgb, inner), 0.97);
  renderer_->Release(id);
  renderer_->Release(mip_id);
  EXPECT_FALSE(renderer_->Draw(id, cam).success);
}

// A second Renderer on the same thread (the daemon's preview next to an evaluation) takes the
// current context and, when it goes, must neither terminate the shared display nor leave the
// first renderer without its context.
TEST_F(RendererTest, SurvivesAnotherRendererComingAndGoing) {
  ASSERT_TRUE(renderer_->ok()) << renderer_->error();
  const Eigen::Matrix3d K = TestK();
  const Mesh mesh = Quad(K, 2.0, 20, 10, 139, 99);
  RenderCamera cam;
  cam.K = K;
  cam.width = kW;
  cam.height = kH;
  {
    Renderer other;
    ASSERT_TRUE(other.ok()) << other.error();
    EXPECT_EQ(other.Render(mesh, Texture(), cam).covered_pixels,
              renderer_->Render(mesh, Texture(), cam).covered_pixels);
  }
  const RenderResult r = renderer_->Render(mesh, Texture(), cam);
  ASSERT_TRUE(r.success) << r.failure_reason;
  EXPECT_NEAR(r.covered_pixels, 120 * 90, 120 + 90);
  EXPECT_NEAR(r.depth.at<float>(50, 80), 2.0f, 1e-4);
}

TEST(RenderCamera, CheckNamesTheBadField) {
  RenderCamera cam;
  EXPECT_NE(cam.Check().find("width"), std::string::npos);
  cam.width = cam.height = 10;
  cam.near_plane = 0;
  EXPECT_NE(cam.Check().find("near"), std::string::npos);
}

}  // namespace
}  // namespace mm
