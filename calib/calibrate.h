#pragma once
// Camera calibration from views of a planar chessboard, in the Bouguet toolbox's model and with
// its estimation flags (est_alpha, est_dist, center_optim, est_aspect_ratio).
//
// 1. Corners: cv::findChessboardCornersSB (Duda & Frese, BMVC 2018) refined by cv::cornerSubPix
//    (the toolbox's cornerfinder); images where the board is not found are listed and skipped.
// 2. Initial guess: cv::calibrateCamera (Zhang 2000 closed form + LM) with the matching flags.
// 3. Refinement: Ceres Levenberg-Marquardt on the full Bouguet model (skew included) over all
//    intrinsics and board poses; parameters the flags hold fixed are constant (SubsetManifold).
// 4. Uncertainties: 3 sigma from ceres::Covariance (inverse of J^T J) scaled by the residual
//    variance, as the toolbox computes fc_error ... (go_calib_optim_iter.m: 3*sqrt(diag)*sigma_x).
//
// Thread-safety: reentrant (no shared state).

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calib/calib_results_m.h"
#include "calib/camera_model.h"

namespace mm {

struct CalibrateOptions {
  cv::Size board{9, 6};                        ///< Inner corners per row x per column.
  double square = 30.0;                        ///< Square size in board units (mm).
  bool est_alpha = false;                      ///< Estimate the skew (toolbox default: no).
  std::array<int, 5> est_dist{1, 1, 1, 1, 0};  ///< Which of kc1..kc5 to estimate.
  bool center_optim = true;                    ///< Estimate cc (else the image centre).
  bool est_aspect_ratio = true;                ///< Estimate fc2/fc1 (else fc2 = fc1).
  int max_iterations = 100;                    ///< Ceres LM iterations.
  bool compute_covariance = true;              ///< The *_error fields.
  int subpix_half_window = 5;                  ///< cornerSubPix half window (toolbox: wintx = 5).
  bool exhaustive_detection = true;            ///< Retry undetected boards with EXHAUSTIVE (slow).

  /// "" when valid, else "field: problem".
  [[nodiscard]] std::string Check() const;
};

/// One calibration image's detected corners (row-major over the board, like OpenCV).
struct BoardView {
  std::string name;
  std::vector<cv::Point2f> corners;  ///< Empty when the board was not found.
};

struct CalibrateImageResult {
  std::string name;
  bool used = false;  ///< Board found and used.
  double rms_px = 0;  ///< RMS reprojection error of this view.
  CalibImagePose pose;
  std::vector<cv::Point2f> corners;
  std::vector<cv::Point2f> residuals;  ///< Detected minus projected, per corner.
};

struct CalibrateResult {
  bool ok = false;
  std::string failure_reason;
  BouguetCamera camera;  ///< With 3-sigma `error` when the covariance was computed.
  std::vector<CalibrateImageResult> images;  ///< One per input view, in order.
  CalibEstimationFlags flags;
  double rms_px = 0;              ///< sqrt(mean squared reprojection distance).
  Eigen::Vector2d err_std{0, 0};  ///< Std of the x / y residuals (the toolbox's err_std).
  BouguetCamera initial;          ///< The OpenCV initial guess.
  int views_used = 0;
  int iterations = 0;
  double detect_s = 0, init_s = 0, optimize_s = 0, covariance_s = 0;

  /// The same, as a toolbox Calib_Results (unused images inactive, i.e. NaN).
  [[nodiscard]] CalibResults ToCalibResults() const;
  /// A one-paragraph human summary.
  [[nodiscard]] std::string Summary() const;
};

/// A board's inner corners written COLSxROWS ("9x6"); nullopt for anything else.
std::optional<cv::Size> ParseBoardSize(const std::string& text);

/// Finds the inner corners of `board` in a gray or colour image (findChessboardCornersSB, then
/// cornerSubPix with a (2w+1)^2 window when w > 0; CALIB_CB_EXHAUSTIVE retry when `exhaustive`).
/// Empty when not found.
std::vector<cv::Point2f> DetectBoard(const cv::Mat& image, cv::Size board,
                                     int subpix_half_window = 5, bool exhaustive = true);

/// Calibrates from detected corners of images of `image_size`.
CalibrateResult CalibrateFromViews(const std::vector<BoardView>& views, cv::Size image_size,
                                   const CalibrateOptions& options);

/// Detects the board in every image (named) and calibrates. All images must have one size.
CalibrateResult CalibrateFromImages(const std::vector<std::string>& names,
                                    const std::vector<cv::Mat>& images,
                                    const CalibrateOptions& options);

/// A picture for people: left, the board corners of every used view over the image frame
/// (coverage) with residual vectors magnified; right, the scatter of all residuals (px).
cv::Mat RenderCalibrationReport(const CalibrateResult& result);

}  // namespace mm
