// Host side of tests/kernel: decodes the first frames of a TUM dataset into binary PPM files
// (0.ppm, 1.ppm, ...) so that the guest needs no image codecs.
// Usage: kernel_prepare <dataset dir> <out dir> [count]

#include <cstdio>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "dataset/tum.h"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: kernel_prepare <dataset> <out> [count]\n");
    return 2;
  }
  const std::filesystem::path dataset = argv[1];
  const size_t count = argc > 3 ? std::stoul(argv[3]) : 6;
  const auto frames = mm::ReadTumList(dataset / "rgb.txt");
  size_t i = 0;
  for (; i < frames.size() && i < count; ++i) {
    cv::Mat bgr = cv::imread((dataset / frames[i].path).string(), cv::IMREAD_COLOR);
    if (bgr.empty()) return 1;
    std::ofstream out(std::string(argv[2]) + "/" + std::to_string(i) + ".ppm", std::ios::binary);
    out << "P6\n" << bgr.cols << " " << bgr.rows << "\n255\n";
    for (int y = 0; y < bgr.rows; ++y) {
      for (int x = 0; x < bgr.cols; ++x) {
        const auto p = bgr.at<cv::Vec3b>(y, x);
        out.put(static_cast<char>(p[2])).put(static_cast<char>(p[1])).put(static_cast<char>(p[0]));
      }
    }
  }
  std::printf("%zu frames\n", i);
  return 0;
}
