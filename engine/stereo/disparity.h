// Dense disparity for a rectified stereo pair: one interface, two methods
// (the ELAS-style matcher of engine/stereo/elas*.cc and OpenCV's StereoSGBM).
// The energy and every parameter are documented in engine/stereo/README.md.
#pragma once

#include <string>

#include <opencv2/core.hpp>

namespace dypho::stereo {

enum class DisparityMethod { kElas, kSgbm };

// "elas" or "sgbm"; throws InvalidInput naming the value otherwise.
DisparityMethod ParseDisparityMethod(const std::string& name);
const char* DisparityMethodName(DisparityMethod method);

// Parameters of the ELAS-style matcher (Geiger, Roser, Urtasun, ACCV 2010).
// Disparities are in pixels of the left image: x_right = x_left - d.
struct ElasOptions {
  int min_disparity = 0;            // smallest disparity searched [px], >= 0
  int max_disparity = 128;          // largest disparity searched [px], < 256
  // Support points (robust sparse matches on a grid).
  int candidate_step = 5;           // grid spacing of support point candidates [px]
  float support_ratio = 0.9f;       // best cost must be < ratio x second best (|d-d1| > 1)
  int support_texture = 10;         // minimum descriptor texture (sum |f-128|) of a candidate
  int support_lr_threshold = 1;     // left-right consistency of support matches [px]
  int incon_window = 5;             // neighbourhood (in candidate cells) for the consistency vote
  int incon_threshold = 5;          // a neighbour supports a point if |d - d_n| <= this [px]
  int incon_min_support = 5;        // neighbours needed to keep a support point
  int redundant_window = 5;         // drop points matched within 1 px on both sides within this many cells (0: keep all)
  bool add_border_points = true;    // extrapolate support points to the image border (coverage)
  // Dense matching (per-pixel MAP over the prior neighbourhood + grid candidates).
  float beta = 0.02f;               // likelihood weight on the L1 descriptor distance
  float gamma = 3.0f;               // uniform part of the prior (robustness to wrong planes)
  float sigma = 1.0f;               // std. dev. of the Gaussian plane prior [px]
  int plane_radius = 2;             // disparities within +-radius of the plane value are tried
  int grid_size = 20;               // cell size of the support-disparity grid [px]
  int grid_radius = 1;              // a support point's disparities join its cell and this many around
  int match_texture = 1;            // minimum descriptor texture of a pixel to be matched
  // Post-processing.
  int lr_threshold = 2;             // dense left-right consistency [px]
  int speckle_size = 200;           // segments smaller than this many pixels are removed
  float speckle_threshold = 1.0f;   // disparity step that separates segments [px]
  int gap_width = 5000;             // gaps up to this width are interpolated [px] (0: none)
  float gap_smooth_threshold = 3.0f;  // gap ends closer than this are averaged, else min taken
  bool extrapolate_borders = true;  // fill gaps that touch the image border from one side
  bool subpixel = true;             // parabola fit on the matching costs at d-1, d, d+1
  int threads = 0;                  // cv::parallel_for_ threads (0: OpenCV's default)

  // False with a message naming the field and the violated constraint.
  bool IsValid(std::string* error) const;
};

// Parameters of the StereoSGBM baseline (OpenCV 4, MODE_SGBM_3WAY).
struct SgbmOptions {
  int min_disparity = 0;     // [px]
  int max_disparity = 128;   // [px]; the range is rounded up to a multiple of 16
  int block_size = 5;        // matched block size [px], odd
  int p1_per_pixel = 8;      // P1 = p1_per_pixel x channels x block_size^2
  int p2_per_pixel = 32;     // P2 = p2_per_pixel x channels x block_size^2
  int disp12_max_diff = 1;   // left-right check [px]
  int uniqueness_ratio = 10; // [%]
  int speckle_window = 100;  // [px]
  int speckle_range = 2;     // [px]
  bool IsValid(std::string* error) const;
};

struct DisparityOptions {
  DisparityMethod method = DisparityMethod::kElas;
  ElasOptions elas;
  SgbmOptions sgbm;
  // Sets max_disparity of both methods.
  void SetMaxDisparity(int max_disparity);
};

struct DisparityResult {
  cv::Mat disparity;   // CV_32F [px] of the left image; 0 where !valid
  cv::Mat valid;       // CV_8U, 255 where the disparity is an estimate (matched or interpolated)
  cv::Mat confidence;  // CV_32F in [0, 1]; 0 where invalid or interpolated
  double seconds = 0;  // wall time of the computation
};

// Disparity of the rectified pair (8-bit grey or BGR, same size). Throws
// InvalidInput on empty or mismatched images and invalid options.
DisparityResult ComputeDisparity(const cv::Mat& left, const cv::Mat& right,
                                 const DisparityOptions& options);

// depth = focal_px x baseline_m / d where valid and d > min_disparity; 0 elsewhere.
// Returns CV_32F metres.
cv::Mat DisparityToDepth(const cv::Mat& disparity, const cv::Mat& valid, double focal_px,
                         double baseline_m, double min_disparity = 0.5);

// KITTI convention: CV_16U, value = round(d x 256), 0 = no estimate.
cv::Mat DisparityToKitti16(const cv::Mat& disparity, const cv::Mat& valid);
// A colour picture (BGR, jet-like map, black = no estimate), scaled to max_disparity.
cv::Mat DisparityToColour(const cv::Mat& disparity, const cv::Mat& valid, float max_disparity);

}  // namespace dypho::stereo
