// Shared pieces of the ONNX segmenters: the letterbox transform between an
// image and a square network input, the input blob, loading a model with
// clear errors, and non-maximum suppression per class.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>
#include <string>
#include <vector>

#include "masking/segmenter.h"

namespace dypho {

// The image scaled by `scale` (aspect kept) and placed at (pad_x, pad_y) in
// an input_width x input_height canvas filled with a pad value.
struct Letterbox {
  double scale = 1.0;    // input pixels per image pixel
  double pad_x = 0.0;    // [input px] left offset of the scaled image
  double pad_y = 0.0;    // [input px] top offset
  int input_width = 0;   // [px]
  int input_height = 0;  // [px]

  // `centred`: pad equally on both sides (YOLOv8/ultralytics); else at the
  // right and bottom only (YOLOX's preprocessing).
  static Letterbox Make(const cv::Size& image, const cv::Size& input, bool centred);
  // Input pixel -> image pixel (both with pixel-edge coordinates: the top-left
  // corner of pixel (0, 0) is (0, 0)).
  cv::Point2d ToImage(const cv::Point2d& input_px) const {
    return {(input_px.x - pad_x) / scale, (input_px.y - pad_y) / scale};
  }
  // A box given by its centre and size in input pixels -> the image box,
  // clipped to `image`. False when less than a pixel wide or high remains.
  bool BoxToImage(double cx, double cy, double w, double h, const cv::Size& image, cv::Rect2f* box) const;
};

// A 1x3xHxW CV_32F blob of the letterboxed image. `rgb` is CV_8UC3 RGB;
// `bgr` selects the channel order the network wants; values are pixel
// values times `value_scale`; the pad is `pad_value` (before scaling).
cv::Mat MakeLetterboxBlob(const cv::Mat& rgb, const Letterbox& letterbox, bool bgr, double value_scale,
                          double pad_value);

// What both ONNX segmenters hold: the checked options, the class ids, the
// network input size and the loaded network.
struct OnnxSegmenterModel {
  SegmenterOptions options;
  std::vector<int> class_ids;
  int input_size = 0;  // [px] square network input
  cv::dnn::Net net;
};
// Checks `options` (a model path is required; the input size, default
// `default_input_size`, must be a multiple of 32) and loads the model.
// `kind` ("YOLOX", "YOLOv8") names the model in errors.
OnnxSegmenterModel LoadOnnxSegmenter(const SegmenterOptions& options, const char* kind, int default_input_size);

// Reads an ONNX model. Throws InvalidInput naming the file when it is
// missing or OpenCV cannot read it.
cv::dnn::Net LoadOnnxModel(const std::string& path);
// Runs the network on `blob`, returning every unconnected output in the
// order of Net::getUnconnectedOutLayersNames. Throws InvalidInput naming
// `model_path` when OpenCV fails (e.g. an input of the wrong size).
std::vector<cv::Mat> RunNetwork(cv::dnn::Net& net, const cv::Mat& blob, const std::string& model_path);
// "1x3549x85"
std::string ShapeText(const cv::Mat& blob);

// Greedy non-maximum suppression run per class (cv::dnn::NMSBoxes); returns
// the indices of the kept candidates, highest score first.
std::vector<int> SuppressPerClass(const std::vector<Detection>& candidates, double score_threshold,
                                  double nms_threshold);

// Drops each detection that holds (by `held_fraction` of its area, e.g. 0.8)
// a smaller detection of the same class scoring at least 1 / score_ratio
// times its own score (score_ratio 0.5: twice). A weak box around a
// confident one (a group, or the person with the desk and monitor beside
// them) would mask the scene around the person it holds. score_ratio 0 =
// off. Detections keep their order.
void DropWeakEnclosingBoxes(double score_ratio, double held_fraction, std::vector<Detection>* detections);
// Box (image pixels) -> the integer pixel rectangle it covers, clipped to `size`.
cv::Rect BoxPixels(const cv::Rect2f& box, const cv::Size& size);
// Dilates a mask by a disc of radius `radius_px` (no-op for 0).
void DilateMask(cv::Mat& mask, int radius_px);

}  // namespace dypho
