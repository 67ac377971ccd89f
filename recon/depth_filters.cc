#include "recon/depth_filters.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace mm {

cv::Mat MedianOfValid(const cv::Mat& rho) {
  cv::Mat out = rho.clone();
  float values[9];
  for (int y = 0; y < rho.rows; ++y) {
    for (int x = 0; x < rho.cols; ++x) {
      if (!(rho.at<float>(y, x) > 0)) continue;
      int n = 0;
      for (int yy = std::max(0, y - 1); yy <= std::min(rho.rows - 1, y + 1); ++yy) {
        for (int xx = std::max(0, x - 1); xx <= std::min(rho.cols - 1, x + 1); ++xx) {
          const float v = rho.at<float>(yy, xx);
          if (v > 0) values[n++] = v;
        }
      }
      std::nth_element(values, values + n / 2, values + n);
      out.at<float>(y, x) = values[n / 2];
    }
  }
  return out;
}

bool IsDepthEdge(float near, float far, double rho_step) {
  return far < near - (0.05 * near + 2 * rho_step);
}

int CutDepthEdgesToOutlines(const cv::Mat& gray_a, int band_px, int min_step, double rho_step,
                            cv::Mat* rho, cv::Mat* confidence) {
  if (band_px <= 0 || min_step <= 0) return 0;
  CV_Assert(gray_a.type() == CV_8UC1 && gray_a.size() == rho->size());
  const cv::Mat before = rho->clone();
  int dropped = 0;
  constexpr int kDirections[8][2] = {{1, 0}, {-1, 0},  {0, 1},  {0, -1},
                                     {1, 1}, {-1, -1}, {1, -1}, {-1, 1}};
  const cv::Rect image(0, 0, before.cols, before.rows);
  for (int y = 0; y < before.rows; ++y) {
    for (int x = 0; x < before.cols; ++x) {
      const float near = before.at<float>(y, x);
      if (!(near > 0)) continue;
      bool outside = false;
      for (const auto& [dx, dy] : kDirections) {
        // The nearest farther surface along d within the band: a depth edge against p's own
        // surface extended along d with its slope at p (from the neighbour behind p, when that
        // lies on the same surface), so that a slanted surface, steep in the image, does not
        // read as one.
        const cv::Point behind(x - dx, y - dy);
        const float back = image.contains(behind) ? before.at<float>(behind) : 0.0f;
        const float slope =
            back > 0 && !IsDepthEdge(back, near, rho_step) && !IsDepthEdge(near, back, rho_step)
                ? near - back
                : 0.0f;
        int k = 0;
        for (int i = 1; i <= band_px; ++i) {
          const cv::Point s(x + i * dx, y + i * dy);
          if (!image.contains(s)) break;
          const float far = before.at<float>(s);
          if (far > 0 && IsDepthEdge(near + static_cast<float>(i) * slope, far, rho_step)) {
            k = i;
            break;
          }
        }
        if (k == 0) continue;
        int outline = -1, largest = 0;
        for (int j = 0; j < k + band_px; ++j) {
          const cv::Point s0(x + (k - j) * dx, y + (k - j) * dy), s1(s0.x - dx, s0.y - dy);
          if (!image.contains(s1)) break;
          const int step = std::abs(static_cast<int>(gray_a.at<uint8_t>(s0)) -
                                    static_cast<int>(gray_a.at<uint8_t>(s1)));
          if (step > largest) {
            largest = step;
            outline = j;
          }
        }
        if (outline >= k && largest >= min_step) {
          outside = true;
          break;
        }
      }
      if (outside) {
        rho->at<float>(y, x) = 0;
        confidence->at<float>(y, x) = 0;
        ++dropped;
      }
    }
  }
  return dropped;
}

int FillPlanarHoles(int max_pixels, float filled_confidence, double rho_step, cv::Mat* rho,
                    cv::Mat* confidence) {
  if (max_pixels <= 0) return 0;
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(*rho <= 0, labels, stats, centroids, 8, CV_32S);
  std::vector<uint8_t> candidate(static_cast<size_t>(n), 0);
  for (int i = 1; i < n; ++i) {
    const int x = stats.at<int>(i, cv::CC_STAT_LEFT), y = stats.at<int>(i, cv::CC_STAT_TOP);
    const int w = stats.at<int>(i, cv::CC_STAT_WIDTH), h = stats.at<int>(i, cv::CC_STAT_HEIGHT);
    const bool inside = x > 0 && y > 0 && x + w < rho->cols && y + h < rho->rows;
    candidate[static_cast<size_t>(i)] = inside && stats.at<int>(i, cv::CC_STAT_AREA) <= max_pixels;
  }
  // Each hole's border pixels, once per hole.
  std::vector<std::vector<cv::Point>> border(static_cast<size_t>(n));
  cv::Mat listed_for(rho->size(), CV_32S, cv::Scalar(0));
  const cv::Rect image(0, 0, rho->cols, rho->rows);
  for (int y = 0; y < rho->rows; ++y) {
    for (int x = 0; x < rho->cols; ++x) {
      const int label = labels.at<int>(y, x);
      if (label <= 0 || !candidate[static_cast<size_t>(label)]) continue;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const cv::Point q(x + dx, y + dy);
          if (!image.contains(q) || !(rho->at<float>(q) > 0) || listed_for.at<int>(q) == label) {
            continue;
          }
          listed_for.at<int>(q) = label;
          border[static_cast<size_t>(label)].push_back(q);
        }
      }
    }
  }
  std::vector<Eigen::Vector3d> plane_of(static_cast<size_t>(n), Eigen::Vector3d::Zero());
  std::vector<uint8_t> fill(static_cast<size_t>(n), 0);
  for (int i = 1; i < n; ++i) {
    const std::vector<cv::Point>& around = border[static_cast<size_t>(i)];
    if (around.size() < 3) continue;
    const double cx = centroids.at<double>(i, 0), cy = centroids.at<double>(i, 1);
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    for (const cv::Point& q : around) {
      const Eigen::Vector3d row(q.x - cx, q.y - cy, 1.0);
      normal += row * row.transpose();
      rhs += row * static_cast<double>(rho->at<float>(q));
    }
    // Relative to the hole's centroid, so the normal equations stay well conditioned.
    const Eigen::FullPivLU<Eigen::Matrix3d> lu(normal);
    if (lu.rank() < 3) continue;  // A border on one line fixes no plane.
    const Eigen::Vector3d abc = lu.solve(rhs);
    const bool on_plane = std::all_of(around.begin(), around.end(), [&](const cv::Point& q) {
      const auto fit = static_cast<float>(abc.x() * (q.x - cx) + abc.y() * (q.y - cy) + abc.z());
      const float value = rho->at<float>(q);
      return !IsDepthEdge(std::max(value, fit), std::min(value, fit), rho_step);
    });
    if (!on_plane) continue;
    plane_of[static_cast<size_t>(i)] =
        Eigen::Vector3d(abc.x(), abc.y(), abc.z() - abc.x() * cx - abc.y() * cy);
    fill[static_cast<size_t>(i)] = 1;
  }
  int filled = 0;
  for (int y = 0; y < rho->rows; ++y) {
    for (int x = 0; x < rho->cols; ++x) {
      const int label = labels.at<int>(y, x);
      if (label <= 0 || !fill[static_cast<size_t>(label)]) continue;
      const Eigen::Vector3d& abc = plane_of[static_cast<size_t>(label)];
      const double value = abc.x() * x + abc.y() * y + abc.z();
      if (value > 0) {
        rho->at<float>(y, x) = static_cast<float>(value);
        confidence->at<float>(y, x) = filled_confidence;
        ++filled;
      }
    }
  }
  return filled;
}

int DropOcclusionBands(const Eigen::Matrix3d& K_inv, const Eigen::Vector3d& center_b_in_a,
                       int band_px, double rho_step, cv::Mat* rho, cv::Mat* confidence) {
  if (band_px <= 0) return 0;
  const cv::Mat before = rho->clone();
  const Eigen::Vector3d& c = center_b_in_a;
  int dropped = 0;
  for (int y = 0; y < before.rows; ++y) {
    for (int x = 0; x < before.cols; ++x) {
      const float near = before.at<float>(y, x);
      if (!(near > 0)) continue;
      // The ray's point at inverse depth rho is x_n / rho; seen from B's centre c its image
      // moves, as rho grows, along -(c_xy - x_n,xy c_z) (the epipole is c's image).
      const Eigen::Vector3d xn = K_inv * Eigen::Vector3d(x, y, 1);
      const Eigen::Vector2d d(-(c.x() - xn.x() * c.z()) / K_inv(0, 0),
                              -(c.y() - xn.y() * c.z()) / K_inv(1, 1));
      const double length = d.norm();
      if (!(length > 1e-12)) continue;
      for (int k = 1; k <= band_px; ++k) {
        const int xs = static_cast<int>(std::lround(x + k * d.x() / length));
        const int ys = static_cast<int>(std::lround(y + k * d.y() / length));
        if (xs < 0 || ys < 0 || xs >= before.cols || ys >= before.rows) break;
        const float far = before.at<float>(ys, xs);
        if (far > 0 && IsDepthEdge(near, far, rho_step)) {
          rho->at<float>(y, x) = 0;
          confidence->at<float>(y, x) = 0;
          ++dropped;
          break;
        }
      }
    }
  }
  return dropped;
}

}  // namespace mm
