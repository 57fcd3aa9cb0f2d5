// ORB features (oriented FAST corners with rotated BRIEF descriptors, Rublee
// et al., ICCV 2011) on an image pyramid, spread over a grid of cells, kept
// out of a dynamic mask, with a FAST threshold that relaxes where the mask
// removed support (the adaptive feature extraction of DyPho-SLAM, Liu et al.
// 2025; the formula below is ours).
//
// Per pyramid level l (image scaled by 1 / scale_factor^l, built by chained
// bilinear resizes):
//  1. FAST-9/16 corners with non-maximum suppression at least `kBorder` px
//     from the level's border (room for the orientation disc and the
//     descriptor pattern), scored by OpenCV's FAST score.
//  2. The level is cut into cells of about `cell_size` px. A cell keeps its
//     corners with score >= t_init; when it has fewer than
//     `min_corners_per_cell` of those it keeps the corners with score
//     >= t_fallback instead (20 and 7 by default, as ORB-SLAM does). One FAST
//     pass over the level at the fully static cells' t_init serves most
//     cells; cells that need a lower threshold are detected again alone.
//  3. Each cell keeps its strongest corners up to its quota, so the features
//     spread over the image. The level's budget n_l follows a geometric series
//     over the levels, n_l ∝ scale_factor^-l with sum_l n_l = num_features.
//  4. Orientation by the intensity centroid of a disc of radius 15 px;
//     a 256-bit rotated BRIEF descriptor on the level blurred by a 7x7
//     Gaussian (sigma 2). The 256 point pairs are our own: drawn once from an
//     isotropic Gaussian (sigma 31/5 px, the BRIEF paper's G II sampling,
//     clipped to a disc of radius 13.5 px) with a fixed seed; the pattern is
//     rotated by the keypoint angle before sampling.
//  5. Keypoint positions go back to level-0 pixels (pixel centres at integers:
//     x0 = (x_l + 0.5) * s - 0.5) and are undistorted with the camera's
//     distortion (cv::undistortPoints).
//
// Dynamic mask. No feature lies on a mask pixel (after dilating the mask by
// `mask_dilation` px). With s_c the static fraction of cell c (its pixels
// outside the dilated mask) and s_g the static fraction of the level's
// detection area (the mean of s_c), the adaptive mode:
//  - spreads the whole budget over the static area: every cell with
//    s_c >= min_static_fraction gets the quota q = n_l / sum_c s_c (the same
//    per-bin count as the unmasked image, raised by 1 / s_g so that the total
//    stays n_l); cells below min_static_fraction get nothing;
//  - relaxes both thresholds of a cell by the static support it lost:
//        t_c = max(min_fast_threshold, round(t * (s_g * s_c)^alpha)),
//    with alpha = `adaptive_exponent` the control factor (0 = no relaxation,
//    1 = thresholds proportional to the remaining support) and
//    min_fast_threshold the lower bound below which FAST fires on image
//    noise;
//  - keeps at most n_l features per level (strongest first) and, when cells
//    could not fill their quota, fills the level up with the strongest
//    remaining corners that passed their cell's threshold.
// Without a mask (s_c = s_g = 1) the adaptive mode is the fixed mode plus the
// fill-up. The fixed mode (adaptive_threshold = false) keeps thresholds 20/7
// and the unmasked per-cell quota n_l / (number of cells), so masking a
// fraction of the image removes about that fraction of the features.
// Measured on five TUM fr1/rpy frames with 40% masked in four layouts
// (tests/tracker_orb_extractor_test.cc): adaptive keeps 98-100% of the
// features, fixed 50-73%. On well-textured frames the re-spread budget does
// most of the work; where corners are scarce (the same frames at half
// contrast) the relaxation is what keeps the count: alpha = 1 keeps 92%,
// alpha = 0 only 76%.
//
// Soft mask: an optional static weight image (1 = surely static, 0 = surely
// dynamic) gives every feature the weight at its pixel, for the optimiser.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "common/camera.h"

namespace dypho {

struct OrbExtractorOptions {
  int num_features = 1000;           // target features per frame over all levels (about 1000 for 640x480), >= 1
  int num_levels = 8;                // pyramid levels, 1..16
  double scale_factor = 1.2;         // scale between consecutive levels, (1, 2]
  int cell_size = 30;                // grid cell edge at every level [px], >= 8
  int initial_fast_threshold = 20;   // FAST threshold t_init [intensity levels], 1..255
  int fallback_fast_threshold = 7;   // FAST threshold t_fallback for cells with too few corners, 1..t_init
  int min_corners_per_cell = 1;      // fewer corners than this at t_init -> the cell uses t_fallback, >= 1
  bool adaptive_threshold = true;    // relax thresholds and re-spread the budget where the mask removed support
  double adaptive_exponent = 1.0;    // alpha, control factor of the relaxation, [0, 4]
  int min_fast_threshold = 5;        // lower bound of the relaxed thresholds, 1..fallback_fast_threshold
  double min_static_fraction = 0.05; // cells with a smaller static fraction yield no feature, [0, 1)
  int mask_dilation = 3;             // the dynamic mask grows by this many pixels before use [px], 0..50
  bool undistort = true;             // undistort keypoints with the camera's distortion
  // Pyramid levels on OpenCV's worker threads (cv::parallel_for_); false:
  // one after the other on the calling thread. The features are the same
  // either way (OrbEquivalence test). On the busy 2-core machine neither was
  // measurably faster (BENCHMARKS.md, issue 20).
  bool parallel_levels = true;

  bool IsValid(std::string* error) const;
};

// Features of one image, in level order. Index i refers to the same feature
// in every vector and descriptor row.
struct OrbFeatures {
  // As detected, in level-0 pixels of the input (distorted) image: octave =
  // pyramid level, angle [deg] in [0, 360), response = FAST score, size =
  // 31 * scale_factor^level.
  std::vector<cv::KeyPoint> keypoints;
  std::vector<cv::Point2f> points;  // undistorted (ideal pinhole) positions [px]
  std::vector<float> weights;       // static weight in [0, 1] (1 without a soft mask)
  cv::Mat descriptors;              // [N, 32] CV_8UC1, 256-bit rotated BRIEF

  size_t size() const { return keypoints.size(); }
};

// Time per stage of one Extract call [ms]: CPU time of the thread that ran
// the stage (less sensitive to a busy machine than wall time). The per-level
// stages run on several threads at once: their figures are sums over the
// levels. The pyramid and the masks of the cheap levels may run inside
// OpenCV's own worker threads, which these figures do not count.
struct OrbStageTimes {
  double pyramid_ms = 0.0;      // the image pyramid
  double masks_ms = 0.0;        // dilated mask, level masks and their integrals
  double fast_ms = 0.0;         // FAST corners, per-cell re-detection included
  double grid_ms = 0.0;         // thresholds, quotas, per-cell selection
  double orientation_ms = 0.0;  // intensity-centroid angles
  double blur_ms = 0.0;         // the Gaussian blur before the descriptors
  double descriptor_ms = 0.0;   // rotated BRIEF
  double gather_ms = 0.0;       // levels merged, undistortion, soft-mask weights
  double total_ms = 0.0;        // the whole call (wall time)
};

// The part of Extract that does not depend on the masks, made ahead (e.g. on
// another thread while the masks of the same frame are computed): the
// pyramid, each level's blurred copy for the descriptors, and the level's
// main FAST pass at a threshold of its own (OrbExtractor::PrepareThresholds).
// Extract with it gives exactly the features Extract gives without it: with
// non-maximum suppression the corners of a pass at t are the corners scoring
// >= t of a pass at a lower threshold (OpenCV's FAST score does not depend on
// the detection threshold), and a level whose masks call for a main pass
// below the prepared threshold is detected again.
struct OrbPrepared {
  cv::Mat gray;                                 // the image (level 0), as given to Prepare
  std::vector<cv::Mat> pyramid;                 // per level; pyramid[0] shares gray's pixels
  std::vector<cv::Mat> blurred;                 // per level, for the descriptors
  std::vector<int> thresholds;                  // per level: the FAST threshold of `corners`
  std::vector<std::vector<cv::Vec3f>> corners;  // per level: x, y [level px], FAST score, in FAST's order
};

struct OrbExtractionStats {
  std::vector<int> features_per_level;    // kept features per level
  std::vector<int> candidates_per_level;  // FAST corners (outside the mask) per level
  double static_fraction = 1.0;           // s_g at level 0 (1 without a mask)
  int min_threshold_used = 0;             // lowest relaxed threshold over the cells of level 0
  int prepared_levels = 0;                // levels whose main FAST pass came from an OrbPrepared
  int redetected_levels = 0;              // levels of an OrbPrepared detected again (threshold too high)
  OrbStageTimes times;
};

class OrbExtractor {
 public:
  // Throws InvalidInput naming the field for invalid options or camera.
  OrbExtractor(const OrbExtractorOptions& options, const Camera& camera);
  ~OrbExtractor();
  OrbExtractor(OrbExtractor&&) noexcept;
  OrbExtractor& operator=(OrbExtractor&&) noexcept;

  // Extracts features from `gray` (CV_8UC1, camera size). `dynamic_mask`
  // (optional, CV_8UC1, camera size): non-zero = dynamic, no features there.
  // `static_weight` (optional, CV_32FC1, camera size): per-pixel weight in
  // [0, 1] (values are clamped; non-finite reads as 0). Throws InvalidInput
  // naming the argument for a wrong type or size. Not thread-safe (reuses
  // its pyramid buffers); levels run in parallel under cv::parallel_for_
  // with options.parallel_levels.
  // `prepared` (optional): Prepare's result for this `gray` (the same pixels);
  // the features are the same with or without it.
  OrbFeatures Extract(const cv::Mat& gray, const cv::Mat& dynamic_mask = cv::Mat(),
                      const cv::Mat& static_weight = cv::Mat(), OrbExtractionStats* stats = nullptr,
                      const OrbPrepared* prepared = nullptr);

  // Thresholds for Prepare: each level's main-pass threshold in the last
  // Extract less `margin` (masks change little from frame to frame; a lower
  // threshold costs FAST time but is less often detected again), at least
  // min_fast_threshold. Before any Extract: initial_fast_threshold - margin.
  std::vector<int> PrepareThresholds(int margin = 3) const;
  // The mask-independent work of Extract for `gray` (CV_8UC1, camera size),
  // one threshold per level. Reads only the options: may run on another
  // thread while this extractor extracts another frame. Throws InvalidInput
  // naming the argument for a wrong image or threshold count.
  std::shared_ptr<const OrbPrepared> Prepare(const cv::Mat& gray, const std::vector<int>& thresholds) const;

  const OrbExtractorOptions& options() const;
  // Scale of level l relative to level 0 (scale_factor^l).
  double LevelScale(int level) const;
  // Feature budget n_l of level l.
  int LevelBudget(int level) const;

  // The relaxed threshold t_c of the header comment.
  static int AdaptiveThreshold(int threshold, double global_static_fraction, double cell_static_fraction,
                               double exponent, int min_threshold);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dypho
