// YOLOX detector (Ge et al., 2021) run by OpenCV DNN, with the mask inside
// each box made from depth (masking/depth_box_mask.h).
//
// Model contract (as ../shared/data/models/yolox_nano.onnx): input 1x3xSxS
// BGR float, the image letterboxed at the top-left with pad value 114, no
// mean or scaling; output 1xNx(5+C) not decoded, N = sum over the strides
// s = 8, 16, 32 of (S/s)^2 anchors in that order, each grid row-major. Per
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

// Anchors of a YOLOX output for an SxS input (3549 for 416).
int YoloxAnchorCount(int input_size);

// Decodes a raw YOLOX output (1xNx(5+C) or NX(5+C), CV_32F) into detections
// in image pixels, keeping the classes in `class_ids` with a score of at
// least `score_threshold`, after per-class NMS. Detections carry no mask.
// Throws InvalidInput when the output shape does not match the input size.
std::vector<Detection> DecodeYoloxOutput(const cv::Mat& output, int input_size, const Letterbox& letterbox,
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

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dypho
