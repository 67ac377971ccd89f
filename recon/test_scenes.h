#pragma once
// Synthetic two-view scenes with known ground truth for the recon tests (seeded).

#include <Eigen/Geometry>
#include <random>
#include <vector>

namespace mm::test {

// An n x n grid of points on the plane z = 2 seen by a camera with f = 100, c = (50, 50).
inline void MakeGrid(int n, std::vector<Eigen::Vector3d>* points,
                     std::vector<Eigen::Vector2d>* pixels) {
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const Eigen::Vector2d px(10.0 + 80.0 * i / (n - 1), 10.0 + 80.0 * j / (n - 1));
      pixels->push_back(px);
      points->push_back(Eigen::Vector3d((px.x() - 50) / 100 * 2, (px.y() - 50) / 100 * 2, 2.0));
    }
  }
}

// The camera of MakeGrid.
inline Eigen::Matrix3d GridK() {
  Eigen::Matrix3d K;
  K << 100, 0, 50, 0, 100, 50, 0, 0, 1;
  return K;
}

struct SyntheticPair {
  Eigen::Matrix3d k;
  Eigen::Matrix3d rotation;             ///< cam_b_from_cam_a.
  Eigen::Vector3d translation;          ///< cam_b_from_cam_a (not normalized).
  std::vector<Eigen::Vector3d> points;  ///< In camera A (outliers: their true point).
  std::vector<Eigen::Vector2d> pixels_a, pixels_b;
  std::vector<bool> is_outlier;
};

enum class SceneShape { kVolume, kPlane };

/// `count` points 2-6 units in front of A (a volume, or the plane z = 4 - 0.3 x), seen by B =
/// [R | t]; pixel noise (sigma `noise_px`) and a share of outliers (B replaced by a random
/// pixel) from a seeded mt19937.
inline SyntheticPair MakePair(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation,
                              double noise_px, double outlier_share, unsigned seed, int count = 400,
                              SceneShape shape = SceneShape::kVolume) {
  SyntheticPair s;
  s.k << 520, 0, 320, 0, 525, 240, 0, 0, 1;
  s.rotation = rotation;
  s.translation = translation;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> lateral(-2.0, 2.0), depth(2.0, 6.0), px(0, 640),
      py(0, 480);
  std::normal_distribution<double> noise(0.0, noise_px > 0 ? noise_px : 1.0);
  std::bernoulli_distribution outlier(outlier_share);
  int guard = 0;
  while (static_cast<int>(s.pixels_a.size()) < count && ++guard < 1000000) {
    Eigen::Vector3d p(lateral(rng), lateral(rng) * 0.75, depth(rng));
    if (shape == SceneShape::kPlane) p.z() = 4.0 - 0.3 * p.x();
    const Eigen::Vector3d p_b = rotation * p + translation;
    if (p_b.z() < 0.5) continue;
    const Eigen::Vector2d a = (s.k * p).hnormalized();
    const Eigen::Vector2d b = (s.k * p_b).hnormalized();
    if (a.x() < 0 || a.x() > 640 || a.y() < 0 || a.y() > 480) continue;
    if (b.x() < 0 || b.x() > 640 || b.y() < 0 || b.y() > 480) continue;
    const bool out = outlier(rng);
    const double n = noise_px > 0 ? 1.0 : 0.0;
    s.points.push_back(p);
    s.pixels_a.push_back(a + n * Eigen::Vector2d(noise(rng), noise(rng)));
    s.pixels_b.push_back(out ? Eigen::Vector2d(px(rng), py(rng))
                             : b + n * Eigen::Vector2d(noise(rng), noise(rng)));
    s.is_outlier.push_back(out);
  }
  return s;
}

inline Eigen::Matrix3d SmallRotation() {
  return (Eigen::AngleAxisd(0.06, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(-0.03, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

}  // namespace mm::test
