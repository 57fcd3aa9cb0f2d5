// Background depth model and mask refinement (after DyPho-SLAM, Liu et al.
// 2025; the formulas below are ours).
//
// The model keeps a background depth image B: the depth of the static scene
// as seen from the current (predicted) camera. For each frame:
//
// 1. Prior P. The map's depth rendered at the constant-velocity predicted
//    pose (an input image R), and the previous background warped to that
//    pose (W: every valid pixel of the previous B is unprojected, moved by
//    predicted_from_previous and splatted with a z-buffer; one-pixel cracks
//    are filled from their neighbours). P = R where R is valid, else W.
// 2. Fusion with the observation O = the current depth outside the raw mask.
//    With tol(z) = tolerance_abs + tolerance_rel * z^2 [m]:
//      - P and O valid, |O - P| <= tol(P):  B = (w_p P + w_o O) / (w_p + w_o)
//        with w_p = prior_weight and w_o = observation_weight;
//      - O nearer than P - tol(P): O is an occluder (e.g. a person the
//        detector missed), B = P;
//      - O farther than P + tol(P): what the prior held has gone (a person
//        who left, a hole in the map), B = O;
//      - only P valid: B = P; only O valid: B = O; neither: no background.
//    Each background pixel carries a support count S: the frames in a row
//    it was observed in agreement (carried along by the warp; the map's
//    rendering counts as fully supported, 255). S grows by one when O agrees
//    with P, stays when O is an occluder or missing, and restarts at 1 when
//    O replaces P or fills an empty pixel.
// 3. Refinement by neighbourhood depth consistency. To tolerate a small
//    misregistration of B (pose error, or the RGB-depth time offset of
//    Kinect data in fast motion), D(q) is compared with the nearest and the
//    farthest background depth within alignment_px of q, B-(q) and B+(q)
//    (min and max filters over a disc; alignment_px = 0: both are B(q)).
//    For every pixel, over its (2 r + 1)^2 neighbours q (r = window_radius_px)
//    with D(q) and B(q) valid (n_valid of them):
//      agree(q): B-(q) - tol(B-(q)) <= D(q) <= B+(q) + tol(B+(q)) and
//                S(q) >= min_support (a background seen only once or twice,
//                e.g. a person the detector missed in the first frames and
//                that has not moved yet, cannot clear a detection). 3 by
//                default: with 1, a walker the masks missed for a frame or
//                two became "background" and then cleared its own detection
//                (the walkers sequences of TUM fr1/rpy, YOLOX every 5th
//                frame, flow mask on, `dypho masks --every 5`, 120 frames:
//                recall 0.50/0.77/0.69 with 1, 0.74/0.91/0.88 with 3, IoU
//                0.260/0.572/0.355 -> 0.310/0.588/0.370 on seeds 23/11/7;
//                one threaded run followed a walker, 23 cm ATE, with 1).
//                Earlier, on 60 frames of one composite without the flow
//                mask, 2 had lowered the IoU (0.685 -> 0.631). Map pixels
//                are always supported, so with a map it matters only where
//                the map has no depth;
//      front(q): D(q) < B-(q) - front_factor * tol(B-(q)) ("clearly in front").
//    With n_valid >= min_valid_fraction (2 r + 1)^2, the pixel is
//      dynamic when n_front >= dynamic_fraction n_valid (add_dynamic): this
//        repairs missed detections (a person in front of the background);
//      static when n_agree >= static_fraction n_valid (remove_static): this
//        repairs false detections (a chair inside a person's box that did not
//        move, the margin of a dilated mask);
//    otherwise (too few valid neighbours, or mixed) it keeps its raw label.
//    The added pixels are opened with a disc of added_open_px (a small
//    misalignment of B, e.g. from pose error or RGB-depth time offset in fast
//    motion, leaves thin "in front" strips along the depth edges of static
//    objects; people and vehicles are wide) and added regions smaller than
//    min_region_px are dropped.
//
// Limitation: where the background was never seen (P invalid) nothing is
// decided, and an object the detector missed from the first frame on, in a
// region the map does not cover yet, enters B (it is absorbed until it
// moves away and the farther observation replaces it).
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "common/camera.h"
#include "common/rigid3.h"
#include "masking/pixel_rays.h"

namespace dypho {

struct BackgroundOptions {
  double prior_weight = 1.0;        // w_p: trust in the prior (rendered map depth, else warped background), > 0
  double observation_weight = 1.0;  // w_o: trust in the current depth observation, > 0
  double tolerance_abs = 0.03;      // depth agreement tol(z) = abs + rel * z^2: abs [m], > 0
  double tolerance_rel = 0.01;      // ... rel [1/m], >= 0
  double front_factor = 2.0;        // "clearly in front": nearer than B by front_factor * tol(B) [unitless], >= 1
  int window_radius_px = 3;         // neighbourhood half-size r [px], 1..15
  int alignment_px = 2;             // B is compared within this radius (misregistration tolerance) [px], 0..15
  int min_support = 3;              // consistent observations before B can clear a detection [frames], 1..255
  double min_valid_fraction = 0.3;  // a decision needs this fraction of the window with D and B valid, (0, 1]
  double static_fraction = 0.7;     // static when this fraction of the valid neighbours agree, (0, 1]
  double dynamic_fraction = 0.5;    // dynamic when this fraction of the valid neighbours are in front, (0, 1]
  bool add_dynamic = true;          // pixels clearly in front of B become dynamic (missed detections)
  bool remove_static = true;        // masked pixels agreeing with B become static (false detections)
  int added_open_px = 9;            // opening of the added pixels: strips thinner than this go [px], 0..51
  int min_region_px = 300;          // added dynamic regions smaller than this are dropped [px^2], >= 0
  double max_depth = 8.0;           // depths beyond this (or <= 0) are invalid [m], > 0

  bool IsValid(std::string* error) const;
};

struct BackgroundInput {
  cv::Mat depth;           // CV_32FC1 [m], 0 = invalid: the current depth (required)
  cv::Mat raw_mask;        // CV_8UC1, nonzero = dynamic: the raw mask (required)
  cv::Mat rendered_depth;  // CV_32FC1 [m] the map's depth at the predicted pose; empty = no map yet
  // Pose of the camera of the previous background relative to the predicted
  // camera (x_pred = predicted_from_previous * x_prev). nullopt: the previous
  // background is not used.
  std::optional<Rigid3d> predicted_from_previous;
};

struct BackgroundOutput {
  cv::Mat refined_mask;           // CV_8UC1, 255 = dynamic
  cv::Mat background_depth;       // CV_32FC1 [m], 0 = unknown: the new B
  cv::Mat prior_depth;            // CV_32FC1 [m], 0 = none: P
  cv::Mat support;                // CV_8UC1: S, consistent observations of B (255 = the map's)
  int added_pixels = 0;           // raw-static pixels made dynamic
  int removed_pixels = 0;         // raw-dynamic pixels made static
  double decided_fraction = 0.0;  // fraction of pixels with enough valid neighbours
};

// Step 3 of the header comment on its own: `raw_mask` refined against a
// background B (`background`, CV_32FC1 [m], 0 = unknown) with its support
// S (`support`, CV_8UC1), all of `depth`'s size. BackgroundModel::Update
// runs it on its new B; a mask made later for the same frame (a keyframe's
// fresh detection, engine/pipeline/keyframe_detection.h) can be refined
// against that frame's B again. Throws InvalidInput naming the argument for
// a missing, wrongly typed or wrongly sized image.
struct BackgroundRefinement {
  cv::Mat refined_mask;           // CV_8UC1, 255 = dynamic
  int added_pixels = 0;           // raw-static pixels made dynamic
  int removed_pixels = 0;         // raw-dynamic pixels made static
  double decided_fraction = 0.0;  // fraction of pixels with enough valid neighbours
};
BackgroundRefinement RefineMask(const cv::Mat& depth, const cv::Mat& raw_mask, const cv::Mat& background,
                                const cv::Mat& support, const BackgroundOptions& options);

class BackgroundModel {
 public:
  // Throws InvalidInput naming the field for invalid options or camera.
  BackgroundModel(const BackgroundOptions& options, const Camera& camera);

  // One frame (see the header comment). Throws InvalidInput naming the
  // argument for a missing, wrongly typed or wrongly sized image.
  BackgroundOutput Update(const BackgroundInput& input);
  // Forgets the background.
  void Reset() {
    background_.release();
    support_.release();
  }
  // The current B (empty before the first Update).
  const cv::Mat& background() const { return background_; }
  const BackgroundOptions& options() const { return options_; }

  // W: `depth` (CV_32FC1 of the camera's size) seen from a camera at
  // target_from_source, by z-buffered splatting plus crack filling.
  cv::Mat WarpDepth(const cv::Mat& depth, const Rigid3d& target_from_source) const;

 private:
  // WarpDepth that also carries a CV_8UC1 value per pixel (the support).
  cv::Mat Warp(const cv::Mat& depth, const cv::Mat& values, const Rigid3d& target_from_source,
               cv::Mat* warped_values) const;

  BackgroundOptions options_;
  PixelRays rays_;
  cv::Mat background_;
  cv::Mat support_;
};

}  // namespace dypho
