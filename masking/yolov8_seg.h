// YOLOv8-seg instance segmentation (Ultralytics) run by OpenCV DNN, for users
// who export such a model to ONNX (`yolo export model=yolov8n-seg.pt format=onnx`).
//
// Model contract: input 1x3xSxS RGB float in [0, 1] (pixel / 255), the image
// letterboxed centred with pad value 114; two outputs:
//  - detections 1x(4+C+M)xN (the export's layout; 1xNx(4+C+M) is accepted
//    too): per anchor the box centre, width and height in input pixels
//    (already decoded), C class scores in [0, 1] and M mask coefficients;
//  - prototypes 1xMxHmxWm (M = 32 and Hm = Wm = S/4 for the usual export).
// The mask of a detection is sigmoid(coefficients . prototypes) at prototype
// resolution, resampled bilinearly to image pixels inside the detection's
// box (outside it the mask is 0) and thresholded at `mask_threshold`.
// C is found from the shapes: 80 (COCO) when one dimension is 84+M, else
// the smaller dimension minus 4+M.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "masking/dnn_model.h"
#include "masking/segmenter.h"

namespace dypho {

// Decodes YOLOv8-seg outputs into detections with masks (mask_roi = the box
// in image pixels). Throws InvalidInput when the shapes do not fit together.
std::vector<Detection> DecodeYolov8SegOutput(const cv::Mat& detections, const cv::Mat& prototypes,
                                             const Letterbox& letterbox, const cv::Size& image_size,
                                             const std::vector<int>& class_ids, double score_threshold,
                                             double nms_threshold, double mask_threshold);

class Yolov8SegSegmenter : public Segmenter {
 public:
  // Loads options.model_path and checks its outputs on a blank input; throws
  // InvalidInput naming the file when it is missing, unreadable or its
  // outputs are not a detection tensor and a prototype tensor.
  explicit Yolov8SegSegmenter(const SegmenterOptions& options);
  ~Yolov8SegSegmenter() override;

  Segmentation Segment(const SegmenterInput& input) override;
  std::string Name() const override { return "yolov8-seg"; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dypho
