// Flow-motion mask: dense optical flow (OpenCV DIS, Kroeger et al. ECCV 2016)
// between consecutive frames compared with the rigid flow that the current
// depth and the relative camera pose predict. Pixels whose residual exceeds
// a threshold are moving.
//
// For a pixel x of the current frame with depth z (camera z) the point is
// X = z * ray(x); the rigid flow is r(x) = pi(prev_from_cam * X) - x, with pi
// the projection (with the lens distortion). The measured backward flow f(x)
// is DIS from the current image to the previous one. The residual is
// |f(x) - r(x)| and the pixel is moving when
//   |f(x) - r(x)| > residual_threshold_px + noise_factor * |dr/dz| sigma(z)
//                   + relative_threshold * |r(x)|,
//   sigma(z) = depth_noise_abs + depth_noise_rel * z^2,
// i.e. the base threshold plus the flow change a depth error of noise_factor
// standard deviations would cause (Kinect-like noise grows with z^2), plus a
// fraction of the rigid flow itself: errors that grow with the motion (the
// rolling shutter's rows captured at other times, the depth captured before
// the colour image, motion blur) are not taken for movers in fast rotation. Pixels
// without depth, beyond max_depth, or whose flow or rigid flow leaves the
// image are never moving. Disocclusions: where the previous frame's depth is
// given and, at the rigidly predicted pixel, is nearer than the predicted
// point by more than occlusion_margin + 3 sigma, the point was hidden in the
// previous frame (background just uncovered behind a moving object), the flow
// there means nothing, and the pixel is left undecided. The mask is then opened, closed and stripped of
// regions smaller than min_region_px.
//
// Pose: cam_from_prev may be given (ground truth, the tracker's constant-
// velocity prediction) or not. With estimate_pose, the pose is refined (or,
// when none is given, estimated) from the flow itself: pixels on a grid
// (outside an exclusion mask, e.g. the semantic mask) with depth give 3-D
// points in the current frame and their flow-displaced pixels in the previous
// one; PnP (RANSAC with AP3P, then Levenberg-Marquardt on the inliers) fits
// prev_from_cam. A prediction that already explains most samples is only
// refined. Without any pose the flow mask is empty. Measured on the synthetic
// room (640x480, about 1 cm and 0.5 deg between frames): the estimate is
// within 0.1 deg in rotation but only about 1 cm in translation (the
// parallax between near and far points is below a pixel), which costs about
// a quarter of the mask's recall against the true pose; a pose from the
// tracker or ground truth is better when there is one (estimate_pose = false).
// At scale 1 the mask is much better with the true pose (precision/recall
// 0.90/0.62 instead of 0.75/0.34 at 0.5) for about 4x the flow time.
//
// Everything runs at `scale` of the image size (flow, residual, morphology);
// the mask is upsampled to the image size at the end. Thresholds and kernel
// sizes are given in pixels of the full image.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "common/camera.h"
#include "common/rigid3.h"

namespace dypho {

struct FlowMotionOptions {
  double scale = 0.5;                  // flow and residuals at this fraction of the image size, (0, 1]
  int dis_preset = 1;                  // cv::DISOpticalFlow preset: 0 ultrafast, 1 fast, 2 medium
  double residual_threshold_px = 2.0;  // base threshold on |flow - rigid flow| [px of the image], > 0
  double noise_factor = 3.0;           // plus this many depth-noise sigmas, as flow change [unitless], >= 0
  double relative_threshold = 0.0;     // plus this fraction of the rigid flow's length [unitless], >= 0
  double depth_noise_abs = 0.002;      // depth noise sigma(z) = abs + rel * z^2: abs [m], >= 0
  double depth_noise_rel = 0.002;      // ... rel [1/m], >= 0
  double max_depth = 8.0;              // pixels with farther (or no) depth are never moving [m], > 0
  double occlusion_margin = 0.1;       // previous depth nearer than the prediction by this (+3 sigma): hidden [m], > 0
  int open_px = 5;                     // opening kernel that removes specks [px of the image], 0..51 (0 = none)
  int close_px = 9;                    // closing kernel that joins nearby pieces [px of the image], 0..51
  int min_region_px = 600;             // connected regions smaller than this are dropped [px^2 of the image], >= 0
  bool estimate_pose = true;           // refine (or, without a given one, estimate) the pose from the flow
  int pose_grid_px = 20;               // spacing of the pixels sampled for the pose [px of the image], 2..64
  double pose_inlier_px = 1.5;         // PnP inlier reprojection threshold [px of the image], > 0
  int pose_min_inliers = 40;           // an estimate with fewer inliers is rejected, >= 6

  bool IsValid(std::string* error) const;
};

// Dense flow from the current frame back to the previous one.
struct BackwardFlow {
  cv::Mat field;        // CV_32FC2 at the working size: current pixel x was at x + field(x) [working px]
  double scale = 1.0;   // working size / image size
  cv::Size image_size;  // the full image size
  bool empty() const { return field.empty(); }
};

struct FlowMotionResult {
  cv::Mat mask;                 // CV_8UC1, image size, 255 = moving (empty mask without a pose)
  cv::Mat residual_ratio;       // CV_32FC1, working size: residual / threshold (> 1 = moving), 0 = undecided
  bool has_pose = false;        // whether a pose was available (given or estimated)
  Rigid3d cam_from_prev;        // the pose the rigid flow used (x_cur = cam_from_prev * x_prev)
  bool pose_estimated = false;  // the pose was estimated or refined from the flow
  int pose_samples = 0;         // grid pixels used for the pose
  int pose_inliers = 0;         // PnP inliers among them
  int occluded = 0;             // working-scale pixels left undecided as disoccluded
};

class FlowMotion {
 public:
  // Throws InvalidInput naming the field for invalid options or camera.
  FlowMotion(const FlowMotionOptions& options, const Camera& camera);
  ~FlowMotion();
  FlowMotion(const FlowMotion&) = delete;
  FlowMotion& operator=(const FlowMotion&) = delete;

  // DIS flow from `gray` (current frame) back to `prev_gray`; both CV_8UC1 of
  // the camera's size (else InvalidInput naming the argument).
  BackwardFlow ComputeFlow(const cv::Mat& gray, const cv::Mat& prev_gray);
  // The moving-pixel mask of the current frame. `depth`: CV_32FC1 [m] of the
  // camera's size, 0 = invalid. `cam_from_prev`: the relative pose, or
  // nullopt. `exclude`: optional CV_8UC1, nonzero pixels are not sampled for
  // the pose estimate. `prev_depth`: optional CV_32FC1 [m], the previous
  // frame's depth, for the disocclusion test.
  FlowMotionResult Detect(const BackwardFlow& flow, const cv::Mat& depth, const std::optional<Rigid3d>& cam_from_prev,
                          const cv::Mat& exclude = cv::Mat(), const cv::Mat& prev_depth = cv::Mat());

  const FlowMotionOptions& options() const;
  cv::Size working_size() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Carries a mask of the previous frame to the current one along the flow:
// out(x) = prev_mask(x + flow(x)) (bilinear, then >= 128), 0 where the flow
// leaves the image. CV_8UC1 of the flow's image size.
cv::Mat WarpMaskByFlow(const cv::Mat& prev_mask, const BackwardFlow& flow);

// Drops 8-connected regions of a binary mask smaller than `min_area` pixels.
void RemoveSmallRegions(cv::Mat& mask, int min_area);

}  // namespace dypho
