// The spool entry's encoders (entry/mesh_io.h, entry/mesh_gltf.h) on small Delaunay meshes.

#include "entry/mesh_io.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "entry/mesh_gltf.h"
#include "recon/test_scenes.h"

namespace mm {
namespace {

using test::GridK;
using test::MakeGrid;

TEST(MeshIo, PlyHeaderAndSizeMatchContent) {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  MakeGrid(4, &points, &pixels);
  Mesh mesh = BuildDelaunayMesh(points, pixels, 100, 100, MeshOptions{});
  ColorVerticesFromTexture(cv::Mat(100, 100, CV_8UC3, cv::Scalar(10, 20, 30)), &mesh);
  ASSERT_EQ(mesh.colors.size(), mesh.vertices.size());
  EXPECT_EQ(mesh.colors[0][0], 30);  // RGB from BGR.
  const std::string ply = EncodePly(mesh, "test");
  const auto end = ply.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  EXPECT_NE(ply.find("element vertex 16\n"), std::string::npos);
  EXPECT_NE(ply.find("element face " + std::to_string(mesh.triangles.size()) + "\n"),
            std::string::npos);
  const size_t body = ply.size() - (end + 11);
  EXPECT_EQ(body, 16u * (12 + 3 + 8) + mesh.triangles.size() * 13);
}

TEST(MeshIo, ObjReferencesMaterialAndTexCoords) {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  MakeGrid(3, &points, &pixels);
  const Mesh mesh = BuildDelaunayMesh(points, pixels, 100, 100, MeshOptions{});
  const std::string obj = EncodeObj(mesh, "mesh.mtl");
  std::istringstream in(obj);
  std::string line;
  int v = 0, vt = 0, f = 0;
  while (std::getline(in, line)) {
    v += line.rfind("v ", 0) == 0;
    vt += line.rfind("vt ", 0) == 0;
    f += line.rfind("f ", 0) == 0;
  }
  EXPECT_EQ(v, 9);
  EXPECT_EQ(vt, 9);
  EXPECT_EQ(f, static_cast<int>(mesh.triangles.size()));
  EXPECT_NE(obj.find("mtllib mesh.mtl"), std::string::npos);
  EXPECT_NE(EncodeMtl("texture.jpg").find("map_Kd texture.jpg"), std::string::npos);
}

TEST(MeshIo, GlbRoundTripsGeometryUvsAndTexture) {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  MakeGrid(5, &points, &pixels);
  const Mesh mesh = BuildDelaunayMesh(points, GridK(), 100, 100, MeshOptions{});
  cv::Mat texture(100, 100, CV_8UC3, cv::Scalar(10, 200, 30));
  std::vector<uchar> jpeg;
  cv::imencode(".jpg", texture, jpeg);
  const std::string glb = EncodeGlb(mesh, std::string(jpeg.begin(), jpeg.end()));
  ASSERT_GE(glb.size(), 12u);
  EXPECT_EQ(glb.substr(0, 4), "glTF");
  EXPECT_NE(glb.find("up to scale"), std::string::npos);
  Mesh back;
  cv::Mat back_texture;
  ASSERT_EQ(DecodeGlb(glb, &back, &back_texture), "");
  ASSERT_EQ(back.vertices.size(), mesh.vertices.size());
  ASSERT_EQ(back.triangles.size(), mesh.triangles.size());
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    EXPECT_TRUE(back.vertices[i].isApprox(mesh.vertices[i])) << i;
    EXPECT_TRUE(back.uvs[i].isApprox(mesh.uvs[i])) << i;
  }
  EXPECT_EQ(back.triangles, mesh.triangles);
  ASSERT_EQ(back_texture.size(), texture.size());
  EXPECT_NEAR(back_texture.at<cv::Vec3b>(50, 50)[1], 200, 3);
  EXPECT_NE(DecodeGlb("not a glb", &back, &back_texture), "");
}

// What glTF forbids and the encoder never writes is refused, not read as an empty mesh (the
// fuzzer found a GLB of no vertices and two indices that decoded to one the encoder could not
// write readably).
TEST(MeshIo, GlbWithoutVerticesOrWithPartTrianglesIsRefused) {
  Mesh mesh;
  mesh.vertices = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}};
  mesh.triangles = {{0, 1, 2}, {1, 3, 2}};
  std::string glb = EncodeGlb(mesh, "");
  Mesh back;
  cv::Mat texture;
  ASSERT_EQ(DecodeGlb(glb, &back, &texture), "");
  // The JSON chunk names the index count: 6 -> 5 keeps the byte length and leaves a part
  // triangle; the POSITION count 4 -> 0 leaves no vertices.
  const auto edited = [&glb](const std::string& from, const std::string& to) {
    std::string copy = glb;
    const size_t at = copy.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) copy.replace(at, from.size(), to);
    return copy;
  };
  Mesh part;
  EXPECT_NE(DecodeGlb(edited("\"count\":6", "\"count\":5"), &part, &texture)
                .find("not a whole number of triangles"),
            std::string::npos);
  Mesh none;
  EXPECT_NE(DecodeGlb(edited("\"count\":4", "\"count\":0"), &none, &texture).find("no vertices"),
            std::string::npos);
}

TEST(MeshIo, PointsPlyHasOneVertexPerPointAndNoFaces) {
  const std::vector<Eigen::Vector3d> points{{0, 0, 1}, {1, 2, 3}};
  const std::vector<Eigen::Matrix<uint8_t, 3, 1>> colors{{1, 2, 3}, {4, 5, 6}};
  const std::string ply = EncodePointsPly(points, colors, "points");
  const auto end = ply.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  EXPECT_NE(ply.find("element vertex 2\n"), std::string::npos);
  EXPECT_EQ(ply.find("element face"), std::string::npos);
  ASSERT_EQ(ply.size() - (end + 11), 2u * 15);
  float y = 0;
  std::memcpy(&y, ply.data() + end + 11 + 15 + 4, 4);
  EXPECT_EQ(y, 2.0f);
  EXPECT_EQ(static_cast<uint8_t>(ply[end + 11 + 15 + 12]), 4);
}

// A reader for the COLMAP text files, independent of the writer: it parses what
// https://colmap.github.io/format.html specifies and checks the model is consistent.
TEST(MeshIo, ColmapTextReadsBackConsistently) {
  Eigen::Matrix3d K;
  K << 500, 0, 319.5, 0, 510, 239.5, 0, 0, 1;
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.1, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  const Eigen::Vector3d t = Eigen::Vector3d(-1, 0.1, 0.05).normalized();
  std::vector<Eigen::Vector3d> points{{0.1, 0.2, 4}, {-0.5, 0.3, 5}, {0.7, -0.4, 6}};
  std::vector<Eigen::Vector2d> pa, pb;
  for (const auto& p : points) {
    pa.push_back((K * p).hnormalized());
    pb.push_back((K * (R * p + t)).hnormalized());
  }
  ColmapInput in;
  in.width = 640;
  in.height = 480;
  in.K = K;
  in.rotation_b_from_a = R;
  in.translation_b_from_a = t;
  in.points_in_cam_a = points;
  in.pixels_a = pa;
  in.pixels_b = pb;
  const ColmapText text = EncodeColmapText(in);

  auto data_lines = [](const std::string& s) {
    std::vector<std::string> out;
    std::istringstream is(s);
    std::string line;
    while (std::getline(is, line)) {
      if (!line.empty() && line[0] != '#') out.push_back(line);
    }
    return out;
  };
  const auto cams = data_lines(text.cameras);
  ASSERT_EQ(cams.size(), 1u);
  std::istringstream cam(cams[0]);
  int cam_id, w, h;
  std::string model;
  double fx, fy, cx, cy;
  cam >> cam_id >> model >> w >> h >> fx >> fy >> cx >> cy;
  EXPECT_EQ(model, "PINHOLE");
  EXPECT_EQ(w, 640);
  EXPECT_DOUBLE_EQ(cx, 320.0);  // COLMAP's pixel centres are at +0.5.

  const auto images = data_lines(text.images);
  ASSERT_EQ(images.size(), 4u);  // Two lines per image.
  std::istringstream img2(images[2]);
  int id;
  double qw, qx, qy, qz, tx, ty, tz;
  img2 >> id >> qw >> qx >> qy >> qz >> tx >> ty >> tz;
  EXPECT_EQ(id, 2);
  const Eigen::Matrix3d R2 = Eigen::Quaterniond(qw, qx, qy, qz).toRotationMatrix();
  EXPECT_TRUE(R2.isApprox(R, 1e-9));

  const auto pts = data_lines(text.points3d);
  ASSERT_EQ(pts.size(), points.size());
  for (size_t i = 0; i < pts.size(); ++i) {
    std::istringstream p(pts[i]);
    int pid, r, g, b, im_a, idx_a, im_b, idx_b;
    double x, y, z, err;
    p >> pid >> x >> y >> z >> r >> g >> b >> err >> im_a >> idx_a >> im_b >> idx_b;
    ASSERT_TRUE(p) << pts[i];
    EXPECT_EQ(im_a, 1);
    EXPECT_EQ(im_b, 2);
    EXPECT_LT(err, 1e-6);
    // The track's POINT2D in image 2 is the point projected with the image's pose.
    std::istringstream obs(images[3]);
    double u = 0, v = 0;
    long p3d = 0;
    for (int k = 0; k <= idx_b; ++k) obs >> u >> v >> p3d;
    EXPECT_EQ(p3d, pid);
    const Eigen::Vector3d X(x, y, z);
    const Eigen::Vector3d Xc = R2 * X + Eigen::Vector3d(tx, ty, tz);
    EXPECT_NEAR(fx * Xc.x() / Xc.z() + cx, u, 1e-5);
    EXPECT_NEAR(fy * Xc.y() / Xc.z() + cy, v, 1e-5);
  }
}

}  // namespace
}  // namespace mm
