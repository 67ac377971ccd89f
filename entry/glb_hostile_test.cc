// DecodeGlb / ReadGlbFile (entry/mesh_gltf.h) on hostile GLBs: each field that sizes a read
// (accessor count, byteOffset, byteStride, buffer view ranges, buffer index, the texture's
// header) edited in a valid file; each is refused with a message naming the field, never read.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "entry/mesh_gltf.h"

namespace mm {
namespace {

using json = nlohmann::json;

uint32_t U32(const std::string& s, size_t at) {
  uint32_t v;
  std::memcpy(&v, s.data() + at, sizeof(v));
  return v;
}

void PutU32(std::string* s, uint32_t v) { s->append(reinterpret_cast<const char*>(&v), 4); }

// A GLB's JSON chunk, parsed.
json JsonOf(const std::string& glb) { return json::parse(glb.substr(20, U32(glb, 12))); }

// The GLB with its JSON chunk replaced (padded to 4 bytes) and its lengths rewritten.
std::string WithJson(const std::string& glb, const json& j) {
  std::string text = j.dump();
  while (text.size() % 4 != 0) text += ' ';
  const std::string bin = glb.substr(20 + U32(glb, 12));
  std::string out = "glTF";
  PutU32(&out, 2);
  PutU32(&out, static_cast<uint32_t>(12 + 8 + text.size() + bin.size()));
  PutU32(&out, static_cast<uint32_t>(text.size()));
  out += "JSON";
  out += text;
  out += bin;
  return out;
}

Mesh Quad() {
  Mesh mesh;
  mesh.vertices = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}};
  mesh.uvs = {{0, 0}, {1, 0}, {0, 1}, {1, 1}};
  mesh.triangles = {{0, 1, 2}, {1, 3, 2}};
  return mesh;
}

std::string Decoded(const std::string& glb) {
  Mesh mesh;
  cv::Mat texture;
  return DecodeGlb(glb, &mesh, &texture);
}

// Accessors of Quad's GLB: 0 POSITION, 1 TEXCOORD_0, 2 indices; one buffer view each.
class HostileGlb : public ::testing::Test {
 protected:
  const std::string glb_ = EncodeGlb(Quad(), "");
  json j_ = JsonOf(glb_);
};

TEST_F(HostileGlb, TheUneditedFileDecodes) { EXPECT_EQ(Decoded(glb_), ""); }

// The case: 2^62 + 1 vertices at stride 12 wrap a 64-bit size to 12 bytes.
TEST_F(HostileGlb, ACountWhoseSizeWrapsIsRefused) {
  j_["accessors"][0]["count"] = (uint64_t{1} << 62) + 1;
  EXPECT_EQ(Decoded(WithJson(glb_, j_)),
            "POSITION: accessors[0].count 4611686018427387905 (12-byte elements 12 apart from "
            "byteOffset 0) overruns bufferViews[0].byteLength 48");
  j_["accessors"][0]["count"] = std::numeric_limits<uint64_t>::max();
  EXPECT_NE(Decoded(WithJson(glb_, j_)).find("POSITION: accessors[0].count"), std::string::npos);
}

TEST_F(HostileGlb, ACountOneTooManyIsRefused) {
  j_["accessors"][0]["count"] = 5;
  EXPECT_NE(Decoded(WithJson(glb_, j_)).find("accessors[0].count 5"), std::string::npos);
  j_ = JsonOf(glb_);
  j_["accessors"][2]["count"] = 9;
  EXPECT_NE(Decoded(WithJson(glb_, j_)).find("indices: accessors[2].count 9"), std::string::npos);
  j_ = JsonOf(glb_);
  j_["accessors"][1]["count"] = 3;
  EXPECT_NE(Decoded(WithJson(glb_, j_)).find("TEXCOORD_0: accessors[1].count 3 is not"),
            std::string::npos);
}

TEST_F(HostileGlb, AnAccessorOffsetThatWrapsIsRefused) {
  j_["accessors"][0]["byteOffset"] = std::numeric_limits<uint64_t>::max() - 3;
  const std::string error = Decoded(WithJson(glb_, j_));
  // tinygltf may refuse the number itself; either way the file is refused, not read.
  EXPECT_NE(error, "");
}

TEST_F(HostileGlb, ABufferViewBeyondItsBufferIsRefused) {
  j_["bufferViews"][0]["byteOffset"] = 1u << 30;
  EXPECT_NE(Decoded(WithJson(glb_, j_)), "");
  j_ = JsonOf(glb_);
  j_["bufferViews"][0]["byteLength"] = 1u << 30;
  EXPECT_NE(Decoded(WithJson(glb_, j_)), "");
}

TEST_F(HostileGlb, AStrideBelowTheElementOrAboveGltfsMaximumIsRefused) {
  j_["bufferViews"][0]["byteStride"] = 4;
  EXPECT_NE(Decoded(WithJson(glb_, j_)).find("POSITION: bufferViews[0].byteStride 4"),
            std::string::npos);
  j_["bufferViews"][0]["byteStride"] = 256;
  EXPECT_NE(Decoded(WithJson(glb_, j_)), "");
}

TEST_F(HostileGlb, MissingIndexesAreNamed) {
  j_["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 17;
  EXPECT_EQ(Decoded(WithJson(glb_, j_)), "POSITION: accessor 17 does not exist (3 accessors)");
  j_ = JsonOf(glb_);
  j_["accessors"][2]["bufferView"] = 9;
  EXPECT_NE(Decoded(WithJson(glb_, j_)), "");
}

TEST_F(HostileGlb, AnAccessorOfTheWrongTypeIsRefused) {
  j_["accessors"][0]["componentType"] = 5121;  // UNSIGNED_BYTE positions.
  EXPECT_NE(Decoded(WithJson(glb_, j_)).find("POSITION: accessors[0].componentType 5121"),
            std::string::npos);
}

TEST_F(HostileGlb, ANonFiniteVertexIsRefused) {
  std::string glb = glb_;
  const size_t bin = 20 + U32(glb, 12) + 8;  // The BIN chunk's data: POSITION first.
  const float inf = std::numeric_limits<float>::infinity();
  std::memcpy(glb.data() + bin + 4, &inf, sizeof(inf));
  EXPECT_EQ(Decoded(glb), "POSITION: vertex 0 is not finite");
}

// A texture header claiming 65535 x 65535 px: refused before OpenCV allocates it.
TEST(HostileGlbTexture, AHugeOrUnknownTextureIsRefusedBeforeDecoding) {
  const std::string sof(
      "\xff\xd8\xff\xc0\x00\x11\x08\xff\xff\xff\xff\x03\x01\x22\x00\x02\x11\x01\x03\x11\x01", 21);
  EXPECT_NE(Decoded(EncodeGlb(Quad(), sof)).find("a 65535x65535 texture"), std::string::npos);
  EXPECT_NE(Decoded(EncodeGlb(Quad(), "GIF89a....")).find("not a PNG or JPEG"), std::string::npos);
  cv::Mat image(8, 8, CV_8UC3, cv::Scalar(1, 2, 3));
  std::vector<uchar> png;
  cv::imencode(".png", image, png);
  Mesh mesh;
  cv::Mat texture;
  ASSERT_EQ(DecodeGlb(EncodeGlb(Quad(), std::string(png.begin(), png.end())), &mesh, &texture), "");
  EXPECT_EQ(texture.size(), image.size());
}

TEST(HostileGlbFile, ReadGlbFileNamesThePathAndRefusesWhatIsNotAFile) {
  const std::filesystem::path dir = ::testing::TempDir();
  const std::filesystem::path path = dir / "hostile.glb";
  json j = JsonOf(EncodeGlb(Quad(), ""));
  j["accessors"][0]["count"] = (uint64_t{1} << 62) + 1;
  std::ofstream(path, std::ios::binary) << WithJson(EncodeGlb(Quad(), ""), j);
  Mesh mesh;
  cv::Mat texture;
  EXPECT_EQ(ReadGlbFile(path, &mesh, &texture).rfind(path.string() + ": POSITION: ", 0), 0u);
  EXPECT_TRUE(mesh.vertices.empty());
  EXPECT_NE(ReadGlbFile("/dev/zero", &mesh, &texture).find("not a regular file"),
            std::string::npos);
}

}  // namespace
}  // namespace mm
