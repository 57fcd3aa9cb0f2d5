// YOLOX detector (Ge et al., 2021) run by OpenCV DNN, with the mask inside
// each box made from depth (masking/depth_box_mask.h).
//
// Model contract (as ../shared/data/models/yolox_nano.onnx): input 1x3xHxW
// BGR float, the image letterboxed at the top-left with pad value 114, no
// mean or scaling; output 1xNx(5+C) not decoded, N = sum over the strides
// s = 8, 16, 32 of (H/s)(W/s) anchors in that order, each grid row-major.
//
// The input is S wide and high (S = input_size), or, with rect_input, S on
// the image's long side and the other side the smallest multiple of 32 that
// holds the scaled image: 416x320 for 640x480 frames, the same image scale
// and 23 % less work (the minimal-padding letterbox of Ultralytics' YOLO
// inference, `LetterBox(auto=True)`). A model that will not run at that
// shape (a reshape fixed at export) falls back to SxS, once, with a warning. Per
// anchor at grid cell (gx, gy) of stride s:
//   cx = (p0 + gx) s,  cy = (p1 + gy) s,  w = exp(p2) s,  h = exp(p3) s,
// then the objectness p4 and C class scores, already in [0, 1]. The score of
// class c is p4 * p[5 + c]; each anchor keeps its best configured class.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "masking/dnn_model.h"
#include "masking/segmenter.h"

namespace dypho {

// Anchors of a YOLOX output for a WxH input (3549 for 416x416).
int YoloxAnchorCount(const cv::Size& input);

// The rect_input network input for an image: `edge` on the long side, the
// scaled short side rounded up to a multiple of 32 (416x320 for 640x480).
cv::Size YoloxRectInput(const cv::Size& image, int edge);

// Decodes a raw YOLOX output (1xNx(5+C) or NX(5+C), CV_32F) into detections
// in image pixels, keeping the classes in `class_ids` with a score of at
// least `score_threshold`, after per-class NMS. Detections carry no mask.
// Throws InvalidInput when the output shape does not match the input size.
std::vector<Detection> DecodeYoloxOutput(const cv::Mat& output, const cv::Size& input, const Letterbox& letterbox,
                                         const cv::Size& image_size, const std::vector<int>& class_ids,
                                         double score_threshold, double nms_threshold);

class YoloxSegmenter : public Segmenter {
 public:
  // Loads options.model_path and checks its output shape on a blank input.
  // Throws InvalidInput naming the file when it is missing, unreadable or
  // has the wrong output shape.
  explicit YoloxSegmenter(const SegmenterOptions& options);
  ~YoloxSegmenter() override;

  Segmentation Segment(const SegmenterInput& input) override;
  std::string Name() const override { return "yolox"; }
  int input_size() const;
  // The network input of the last Segment call (0x0 before the first).
  cv::Size last_input() const;

 private:
  // The second look of SegmenterOptions::second_look_max_cover at one box and
  // its depth region: the people found, in image coordinates.
  std::vector<Detection> SecondLook(const cv::Mat& rgb, const cv::Rect& box, const BoxMask& region, double max_cover,
                                    const cv::Size& net_input);

  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dypho
