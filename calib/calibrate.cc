#include "calib/calibrate.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <chrono>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace mm {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

// Internal intrinsics block: [f, aspect, cc1, cc2, alpha_c, kc1..kc5] with fc1 = f and
// fc2 = f * aspect, so est_aspect_ratio = 0 is a constant entry.
constexpr int kIntr = 10;
constexpr int kPose = 6;  // Rodrigues vector, translation.

// Reprojection residual of one board corner through the Bouguet model (ProjectBouguet).
struct CornerResidual {
  CornerResidual(const cv::Point3f& board_point, const cv::Point2f& observed)
      : X(board_point.x), Y(board_point.y), u(observed.x), v(observed.y) {}

  template <typename T>
  bool operator()(const T* intr, const T* pose, T* residual) const {
    const T p_board[3] = {T(X), T(Y), T(0.0)};
    T p[3];
    ceres::AngleAxisRotatePoint(pose, p_board, p);
    p[0] += pose[3];
    p[1] += pose[4];
    p[2] += pose[5];
    // The model's order (BouguetCamera::Intrinsics()), with fc2 = f * aspect.
    const T intrinsics[BouguetCamera::kNumIntrinsics] = {
        intr[0], intr[0] * intr[1], intr[2], intr[3], intr[4],
        intr[5], intr[6],           intr[7], intr[8], intr[9]};
    T pixel[2];
    ProjectBouguet(intrinsics, p, pixel);
    residual[0] = pixel[0] - T(u);
    residual[1] = pixel[1] - T(v);
    return true;
  }

  double X, Y, u, v;
};

std::vector<cv::Point3f> BoardPoints(const CalibrateOptions& o) {
  std::vector<cv::Point3f> pts;
  for (int r = 0; r < o.board.height; ++r) {
    for (int c = 0; c < o.board.width; ++c) {
      pts.emplace_back(static_cast<float>(c * o.square), static_cast<float>(r * o.square), 0.f);
    }
  }
  return pts;
}

BouguetCamera FromIntr(const double* intr, cv::Size size) {
  BouguetCamera c;
  c.fc = {intr[0], intr[0] * intr[1]};
  c.cc = {intr[2], intr[3]};
  c.alpha_c = intr[4];
  for (size_t i = 0; i < 5; ++i) c.kc[i] = intr[5 + i];
  c.width = size.width;
  c.height = size.height;
  return c;
}

}  // namespace

std::string CalibrateOptions::Check() const {
  if (board.width < 2 || board.height < 2) return "board: needs at least 2x2 inner corners";
  if (!(square > 0) || !std::isfinite(square)) return "square: must be positive";
  for (int e : est_dist) {
    if (e != 0 && e != 1) return "est_dist: entries must be 0 or 1";
  }
  if (max_iterations < 1) return "max_iterations: must be >= 1";
  return {};
}

std::optional<cv::Size> ParseBoardSize(const std::string& text) {
  int cols = 0, rows = 0;
  char x = 0;
  std::istringstream in(text);
  if (!(in >> cols >> x >> rows) || (x != 'x' && x != 'X') || cols < 2 || rows < 2 || cols > 100 ||
      rows > 100 || in.peek() != std::char_traits<char>::eof()) {
    return std::nullopt;
  }
  return cv::Size(cols, rows);
}

std::vector<cv::Point2f> DetectBoard(const cv::Mat& image, cv::Size board, int subpix_half_window,
                                     bool exhaustive) {
  cv::Mat gray = image;
  if (image.channels() == 3) cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  std::vector<cv::Point2f> corners;
  if (!cv::findChessboardCornersSB(gray, board, corners, 0) &&
      !(exhaustive && cv::findChessboardCornersSB(gray, board, corners, cv::CALIB_CB_EXHAUSTIVE))) {
    return {};
  }
  // Sub-pixel refinement by gradient orthogonality in a (2w+1)^2 window: the toolbox's
  // cornerfinder (default wintx = winty = 5), which cv::cornerSubPix implements. Measured on
  // the toolbox's example: SB's own CALIB_CB_ACCURACY corners put kc1 7x the toolbox's 3 sigma
  // away; these land within 1.3x for every parameter.
  if (subpix_half_window > 0) {
    cv::cornerSubPix(gray, corners, cv::Size(subpix_half_window, subpix_half_window),
                     cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-3));
  }
  return corners;
}

CalibrateResult CalibrateFromImages(const std::vector<std::string>& names,
                                    const std::vector<cv::Mat>& images,
                                    const CalibrateOptions& options) {
  CalibrateResult result;
  if (names.size() != images.size() || images.empty()) {
    result.failure_reason = "no images";
    return result;
  }
  const auto start = Clock::now();
  std::vector<BoardView> views;
  const cv::Size size = images[0].size();
  for (size_t i = 0; i < images.size(); ++i) {
    if (images[i].size() != size) {
      result.failure_reason = names[i] + ": image size differs from " + names[0];
      return result;
    }
    views.push_back({names[i], DetectBoard(images[i], options.board, options.subpix_half_window,
                                           options.exhaustive_detection)});
  }
  const double detect_s = Seconds(start);
  result = CalibrateFromViews(views, size, options);
  result.detect_s = detect_s;
  return result;
}

CalibrateResult CalibrateFromViews(const std::vector<BoardView>& views, cv::Size image_size,
                                   const CalibrateOptions& options) {
  CalibrateResult result;
  result.flags.est_alpha = options.est_alpha ? 1 : 0;
  result.flags.est_dist = options.est_dist;
  result.flags.center_optim = options.center_optim ? 1 : 0;
  result.flags.est_aspect_ratio = options.est_aspect_ratio ? 1 : 0;
  if (const std::string problem = options.Check(); !problem.empty()) {
    result.failure_reason = "options: " + problem;
    return result;
  }
  const std::vector<cv::Point3f> board = BoardPoints(options);
  std::vector<std::vector<cv::Point3f>> object_points;
  std::vector<std::vector<cv::Point2f>> image_points;
  std::vector<size_t> used;
  result.images.resize(views.size());
  for (size_t i = 0; i < views.size(); ++i) {
    result.images[i].name = views[i].name;
    if (views[i].corners.size() != board.size()) continue;
    used.push_back(i);
    object_points.push_back(board);
    image_points.push_back(views[i].corners);
  }
  result.views_used = static_cast<int>(used.size());
  if (used.size() < 3) {
    result.failure_reason =
        "board found in " + std::to_string(used.size()) + " images; at least 3 are needed";
    return result;
  }

  // Initial guess: OpenCV with the matching flags (it has no skew: alpha_c starts at 0).
  auto t0 = Clock::now();
  int flags = 0;
  cv::Matx33d K = cv::Matx33d::eye();
  if (!options.center_optim) flags |= cv::CALIB_FIX_PRINCIPAL_POINT;
  if (!options.est_aspect_ratio) flags |= cv::CALIB_FIX_ASPECT_RATIO;
  if (!options.est_dist[0]) flags |= cv::CALIB_FIX_K1;
  if (!options.est_dist[1]) flags |= cv::CALIB_FIX_K2;
  if (!options.est_dist[2] || !options.est_dist[3]) flags |= cv::CALIB_ZERO_TANGENT_DIST;
  if (!options.est_dist[4]) flags |= cv::CALIB_FIX_K3;
  std::vector<double> dist(5, 0.0);
  std::vector<cv::Mat> rvecs, tvecs;
  try {
    cv::calibrateCamera(object_points, image_points, image_size, K, dist, rvecs, tvecs, flags);
  } catch (const cv::Exception& e) {
    result.failure_reason = std::string("initial guess (cv::calibrateCamera) failed: ") + e.what();
    return result;
  }
  result.init_s = Seconds(t0);

  double intr[kIntr] = {K(0, 0), K(1, 1) / K(0, 0), K(0, 2), K(1, 2), 0.0,
                        dist[0], dist[1],           dist[2], dist[3], dist[4]};
  for (int i = 0; i < 5; ++i) {
    if (!options.est_dist[static_cast<size_t>(i)]) intr[5 + i] = 0.0;
  }
  if (!options.est_aspect_ratio) intr[1] = 1.0;
  if (!options.center_optim) {  // The toolbox's centre, 0-based.
    intr[2] = (image_size.width - 1) / 2.0;
    intr[3] = (image_size.height - 1) / 2.0;
  }
  result.initial = FromIntr(intr, image_size);
  std::vector<std::array<double, kPose>> poses(used.size());
  for (size_t k = 0; k < used.size(); ++k) {
    for (int j = 0; j < 3; ++j) {
      poses[k][static_cast<size_t>(j)] = rvecs[k].at<double>(j);
      poses[k][3 + static_cast<size_t>(j)] = tvecs[k].at<double>(j);
    }
  }

  // Refinement of the full model.
  t0 = Clock::now();
  ceres::Problem problem;
  for (size_t k = 0; k < used.size(); ++k) {
    for (size_t j = 0; j < board.size(); ++j) {
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CornerResidual, 2, kIntr, kPose>(
                                   new CornerResidual(board[j], image_points[k][j])),
                               nullptr, intr, poses[k].data());
    }
  }
  std::vector<int> constant;
  if (!options.est_aspect_ratio) constant.push_back(1);
  if (!options.center_optim) constant.insert(constant.end(), {2, 3});
  if (!options.est_alpha) constant.push_back(4);
  for (int i = 0; i < 5; ++i) {
    if (!options.est_dist[static_cast<size_t>(i)]) constant.push_back(5 + i);
  }
  if (!constant.empty()) problem.SetManifold(intr, new ceres::SubsetManifold(kIntr, constant));
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_SCHUR;
  solver.max_num_iterations = options.max_iterations;
  solver.function_tolerance = 1e-12;
  solver.parameter_tolerance = 1e-12;
  solver.gradient_tolerance = 1e-12;
  solver.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  result.optimize_s = Seconds(t0);
  result.iterations = static_cast<int>(summary.iterations.size());
  if (!summary.IsSolutionUsable()) {
    result.failure_reason = "optimization failed: " + summary.message;
    return result;
  }
  result.camera = FromIntr(intr, image_size);
  // What the loaders would refuse is not written (BouguetCamera::Check: the distortion must
  // invert over the image).
  if (const std::string unusable = result.camera.Check(); !unusable.empty()) {
    result.failure_reason = "the fitted camera cannot be used: " + unusable;
    return result;
  }

  // Residuals, per-image and overall errors.
  double sum_sq = 0, sum_x = 0, sum_y = 0, sum_xx = 0, sum_yy = 0;
  size_t count = 0;
  for (size_t k = 0; k < used.size(); ++k) {
    CalibrateImageResult& img = result.images[used[k]];
    img.used = true;
    img.corners = image_points[k];
    img.pose.omc = {poses[k][0], poses[k][1], poses[k][2]};
    img.pose.tc = {poses[k][3], poses[k][4], poses[k][5]};
    img.pose.active = true;
    double view_sq = 0;
    for (size_t j = 0; j < board.size(); ++j) {
      double r[2];
      CornerResidual(board[j], image_points[k][j])(intr, poses[k].data(), r);
      img.residuals.emplace_back(static_cast<float>(-r[0]), static_cast<float>(-r[1]));
      view_sq += r[0] * r[0] + r[1] * r[1];
      sum_x += r[0];
      sum_y += r[1];
      sum_xx += r[0] * r[0];
      sum_yy += r[1] * r[1];
    }
    img.rms_px = std::sqrt(view_sq / static_cast<double>(board.size()));
    sum_sq += view_sq;
    count += board.size();
  }
  const double n = static_cast<double>(count);
  result.rms_px = std::sqrt(sum_sq / n);
  // Sample standard deviations, as Matlab's std().
  result.err_std = {std::sqrt((sum_xx - sum_x * sum_x / n) / (n - 1)),
                    std::sqrt((sum_yy - sum_y * sum_y / n) / (n - 1))};
  const double mean_all = (sum_x + sum_y) / (2 * n);
  const double sigma_x = std::sqrt((sum_xx + sum_yy - 2 * n * mean_all * mean_all) / (2 * n - 1));

  // 3-sigma uncertainties: cov = sigma^2 (J^T J)^-1.
  if (options.compute_covariance) {
    t0 = Clock::now();
    ceres::Covariance::Options copt;
    copt.algorithm_type = ceres::DENSE_SVD;
    copt.null_space_rank = -1;
    ceres::Covariance covariance(copt);
    std::vector<std::pair<const double*, const double*>> blocks{{intr, intr}};
    for (auto& p : poses) blocks.emplace_back(p.data(), p.data());
    if (covariance.Compute(blocks, &problem)) {
      Eigen::Matrix<double, kIntr, kIntr, Eigen::RowMajor> cov;
      covariance.GetCovarianceBlock(intr, intr, cov.data());
      // (f, aspect) -> (fc1, fc2): fc2 = f * aspect.
      Eigen::Matrix<double, kIntr, kIntr> J = Eigen::Matrix<double, kIntr, kIntr>::Identity();
      J(1, 0) = intr[1];
      J(1, 1) = intr[0];
      const Eigen::Matrix<double, kIntr, kIntr> c = J * cov * J.transpose();
      auto err = [&](int i) { return 3.0 * sigma_x * std::sqrt(std::max(0.0, c(i, i))); };
      BouguetCamera::Uncertainty u;
      u.fc = {err(0), err(1)};
      u.cc = {err(2), err(3)};
      u.alpha_c = err(4);
      for (size_t i = 0; i < 5; ++i) u.kc[i] = err(5 + static_cast<int>(i));
      result.camera.error = u;
      for (size_t k = 0; k < used.size(); ++k) {
        Eigen::Matrix<double, kPose, kPose, Eigen::RowMajor> pc;
        covariance.GetCovarianceBlock(poses[k].data(), poses[k].data(), pc.data());
        Eigen::Vector3d eo, et;
        for (int j = 0; j < 3; ++j) {
          eo[j] = 3.0 * sigma_x * std::sqrt(std::max(0.0, pc(j, j)));
          et[j] = 3.0 * sigma_x * std::sqrt(std::max(0.0, pc(3 + j, 3 + j)));
        }
        result.images[used[k]].pose.omc_error = eo;
        result.images[used[k]].pose.tc_error = et;
      }
    }
    result.covariance_s = Seconds(t0);
  }
  result.ok = true;
  return result;
}

CalibResults CalibrateResult::ToCalibResults() const {
  CalibResults r;
  r.camera = camera;
  r.n_ima = static_cast<int>(images.size());
  r.flags = flags;
  for (const CalibrateImageResult& img : images) {
    CalibImagePose p = img.pose;
    p.active = img.used;
    r.images.push_back(p);
  }
  return r;
}

std::string CalibrateResult::Summary() const {
  std::ostringstream s;
  if (!ok) {
    s << "calibration failed: " << failure_reason;
    return s.str();
  }
  const auto e = camera.error.value_or(BouguetCamera::Uncertainty{});
  s.precision(6);
  s << "views " << views_used << "/" << images.size() << ", RMS " << rms_px << " px, err_std ["
    << err_std.x() << " " << err_std.y() << "]\n"
    << "fc = [" << camera.fc.x() << " " << camera.fc.y() << "] +/- [" << e.fc.x() << " " << e.fc.y()
    << "]\n"
    << "cc = [" << camera.cc.x() << " " << camera.cc.y() << "] +/- [" << e.cc.x() << " " << e.cc.y()
    << "]\n"
    << "alpha_c = " << camera.alpha_c << " +/- " << e.alpha_c << "\n"
    << "kc = [" << camera.kc[0] << " " << camera.kc[1] << " " << camera.kc[2] << " " << camera.kc[3]
    << " " << camera.kc[4] << "] +/- [" << e.kc[0] << " " << e.kc[1] << " " << e.kc[2] << " "
    << e.kc[3] << " " << e.kc[4] << "]  (3 sigma)\n"
    << "timings: detect " << detect_s << " s, init " << init_s << " s, optimize " << optimize_s
    << " s (" << iterations << " iterations), covariance " << covariance_s << " s";
  return s.str();
}

cv::Mat RenderCalibrationReport(const CalibrateResult& result) {
  const int w = std::max(result.camera.width, 320);
  const int h = std::max(result.camera.height, 240);
  const int panel = h;  // Square residual scatter, as tall as the image.
  cv::Mat canvas(h + 40, w + panel + 10, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::Mat cover = canvas(cv::Rect(0, 40, w, h));
  cv::Mat scatter = canvas(cv::Rect(w + 10, 40, panel, h));
  cover.setTo(cv::Scalar(235, 235, 235));
  scatter.setTo(cv::Scalar(245, 245, 245));
  double max_res = 0.0;
  for (const auto& img : result.images) {
    for (const auto& r : img.residuals) max_res = std::max<double>(max_res, std::hypot(r.x, r.y));
  }
  const double scatter_range = std::max(0.1, max_res * 1.1);  // px at the panel edge.
  const double arrow_gain = 20.0;
  size_t view_index = 0;
  for (const auto& img : result.images) {
    if (!img.used) continue;
    cv::Mat hue(1, 1, CV_8UC3,
                cv::Scalar(static_cast<double>((view_index++ * 37) % 180), 220, 200));
    cv::cvtColor(hue, hue, cv::COLOR_HSV2BGR);
    const cv::Vec3b c = hue.at<cv::Vec3b>(0, 0);
    const cv::Scalar colour(c[0], c[1], c[2]);
    for (size_t j = 0; j < img.corners.size(); ++j) {
      const cv::Point2f p = img.corners[j];
      const cv::Point2f r = img.residuals[j];
      cv::circle(cover, p, 2, colour, cv::FILLED, cv::LINE_AA);
      cv::line(cover, p, p + r * static_cast<float>(arrow_gain), colour, 1, cv::LINE_AA);
      const cv::Point2f s(static_cast<float>((0.5 + r.x / (2 * scatter_range)) * panel),
                          static_cast<float>((0.5 + r.y / (2 * scatter_range)) * h));
      cv::circle(scatter, s, 1, colour, cv::FILLED);
    }
  }
  cv::line(scatter, {panel / 2, 0}, {panel / 2, h}, cv::Scalar(150, 150, 150));
  cv::line(scatter, {0, h / 2}, {panel, h / 2}, cv::Scalar(150, 150, 150));
  std::ostringstream title;
  title.precision(3);
  title << "coverage + residuals x" << arrow_gain << " (" << result.views_used
        << " views)   |   residuals, +/-" << scatter_range << " px;  RMS " << result.rms_px
        << " px";
  cv::putText(canvas, title.str(), {8, 26}, cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  return canvas;
}

}  // namespace mm
