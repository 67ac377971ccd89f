#pragma once
// Clean-up of a dense inverse-depth map (recon/dense.h) after the winner-take-all: each filter
// works on a map of A's (shrunk) pixels, CV_32FC1 inverse depth with 0 = none, and its
// confidence (same size, set to 0 where a depth is dropped). Two inverse depths lie on two
// surfaces when they differ by more than 5 % of depth plus two plane steps (IsDepthEdge), so
// that the sweep's quantization does not read as an edge.
//
// Thread-safety: pure functions; reentrant.

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace mm {

/// True when inverse depths `near` > `far` lie on two surfaces rather than one.
bool IsDepthEdge(float near, float far, double rho_step);

/// Median of the valid 3x3 neighbours of each valid pixel (removes single-pixel spikes of the
/// winner-take-all without moving edges).
cv::Mat MedianOfValid(const cv::Mat& rho);

/// Foreground fattening at outlines (Scharstein & Szeliski 2002, sec. 5): where a window
/// straddles an object's outline its cost follows the stronger texture, usually the
/// foreground's, so the foreground's depth reaches up to the window radius past the outline
/// onto the background. The outline is where A's grey level (`gray_a`, 8-bit, the map's size)
/// steps. For a pixel p with a pixel on a farther surface at s_0 = p + k d (k <= `band_px`, d
/// one of the eight directions; farther than p's surface extended with its slope at p, so that
/// a surface seen at a grazing angle is not an edge), the line s_j = p + (k - j) d runs from that surface through p
/// (s_k) `band_px` further into the near one; when the largest step |A(s_j) - A(s_j+1)| on it
/// is at least `min_step` and lies at or behind p (j >= k), p lies outside the outline and is
/// dropped. Checked on the map before any drop. Returns the pixels dropped.
int CutDepthEdgesToOutlines(const cv::Mat& gray_a, int band_px, int min_step, double rho_step,
                            cv::Mat* rho, cv::Mat* confidence);

/// Fills the holes (8-connected pixels without depth) of at most `max_pixels` that do not touch
/// the image border and whose border lies on one plane: a plane's inverse depth is affine in
/// the pixel, rho = a x + b y + c, fitted to the hole's valid 8-neighbours by least squares;
/// when each of them lies on the fit's surface (not IsDepthEdge), the hole's pixels get the
/// plane's inverse depth and `filled_confidence`. A hole between two surfaces stays a hole.
/// Returns the pixels filled.
int FillPlanarHoles(int max_pixels, float filled_confidence, double rho_step, cv::Mat* rho,
                    cv::Mat* confidence);

/// Foreground fattening where B does not see A's background (Scharstein & Szeliski 2002,
/// sec. 5): next to the far side of a depth edge, A's background is hidden in B behind the
/// foreground and A's window there is dominated by the foreground's texture, so both the cost
/// and SGM give it the foreground's depth. The band lies on the side of the foreground
/// towards which nearer points move in B: along the epipolar direction
/// d(x) = d pi(R x + rho t) / d rho in A's image, i.e. away from the epipole. A pixel is
/// dropped when a pixel at most `band_px` along +d has a depth on another, farther surface
/// (checked on the map before any drop, so bands do not grow). `K_inv`: the map's inverse
/// camera matrix; `center_b_in_a`: B's centre in A's frame. Returns the pixels dropped.
int DropOcclusionBands(const Eigen::Matrix3d& K_inv, const Eigen::Vector3d& center_b_in_a,
                       int band_px, double rho_step, cv::Mat* rho, cv::Mat* confidence);

}  // namespace mm
