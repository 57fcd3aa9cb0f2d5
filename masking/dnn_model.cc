#include "masking/dnn_model.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <utility>
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "masking/mat_checks.h"

namespace dypho {

Letterbox Letterbox::Make(const cv::Size& image, const cv::Size& input, bool centred) {
  DYPHO_CHECK_INPUT(image.width > 0 && image.height > 0) << "letterbox: empty image";
  DYPHO_CHECK_INPUT(input.width > 0 && input.height > 0) << "letterbox: empty network input";
  Letterbox lb;
  lb.input_width = input.width;
  lb.input_height = input.height;
  lb.scale = std::min(static_cast<double>(input.width) / image.width, static_cast<double>(input.height) / image.height);
  if (centred) {
    const int w = static_cast<int>(std::lround(image.width * lb.scale));
    const int h = static_cast<int>(std::lround(image.height * lb.scale));
    lb.pad_x = (input.width - w) / 2;
    lb.pad_y = (input.height - h) / 2;
  }
  return lb;
}

cv::Mat MakeLetterboxBlob(const cv::Mat& rgb, const Letterbox& lb, bool bgr, double value_scale, double pad_value) {
  CheckMat(rgb, CV_8UC3, cv::Size(), "rgb");
  const int w =
      std::min(lb.input_width - static_cast<int>(lb.pad_x), static_cast<int>(std::lround(rgb.cols * lb.scale)));
  const int h =
      std::min(lb.input_height - static_cast<int>(lb.pad_y), static_cast<int>(std::lround(rgb.rows * lb.scale)));
  cv::Mat canvas(lb.input_height, lb.input_width, CV_8UC3, cv::Scalar::all(pad_value));
  cv::Mat resized;
  cv::resize(rgb, resized, cv::Size(w, h), 0, 0, lb.scale < 1.0 ? cv::INTER_AREA : cv::INTER_LINEAR);
  resized.copyTo(canvas(cv::Rect(static_cast<int>(lb.pad_x), static_cast<int>(lb.pad_y), w, h)));
  // blobFromImage: swapRB turns our RGB into BGR.
  return cv::dnn::blobFromImage(canvas, value_scale, cv::Size(), cv::Scalar(), /*swapRB=*/bgr, /*crop=*/false, CV_32F);
}

OnnxSegmenterModel LoadOnnxSegmenter(const SegmenterOptions& options, const char* kind, int default_input_size) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "SegmenterOptions." << error;
  DYPHO_CHECK_INPUT(!options.model_path.empty())
      << "SegmenterOptions.model_path is empty (" << kind << " needs a model)";
  OnnxSegmenterModel m;
  m.options = options;
  m.class_ids = ClassIds(options.classes);
  m.input_size = options.input_size > 0 ? options.input_size : default_input_size;
  DYPHO_CHECK_INPUT(m.input_size % 32 == 0)
      << "SegmenterOptions.input_size must be a multiple of 32 for " << kind << " (got " << m.input_size << ")";
  m.net = LoadOnnxModel(options.model_path);
  return m;
}

cv::dnn::Net LoadOnnxModel(const std::string& path) {
  DYPHO_CHECK_INPUT(std::filesystem::is_regular_file(path)) << "model file '" << path << "' does not exist";
  cv::dnn::Net net;
  try {
    net = cv::dnn::readNetFromONNX(path);
  } catch (const cv::Exception& e) {
    DYPHO_CHECK_INPUT(false) << "cannot read ONNX model '" << path << "': " << e.what();
  }
  DYPHO_CHECK_INPUT(!net.empty()) << "cannot read ONNX model '" << path << "': OpenCV returned an empty network";
  net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  return net;
}

std::vector<cv::Mat> RunNetwork(cv::dnn::Net& net, const cv::Mat& blob, const std::string& model_path) {
  std::vector<cv::Mat> outputs;
  try {
    net.setInput(blob);
    net.forward(outputs, net.getUnconnectedOutLayersNames());
  } catch (const cv::Exception& e) {
    DYPHO_CHECK_INPUT(false) << "model '" << model_path << "' failed on a " << ShapeText(blob)
                             << " input: " << e.what();
  }
  return outputs;
}

std::string ShapeText(const cv::Mat& blob) {
  if (blob.empty()) return "empty";
  std::string s;
  for (int i = 0; i < blob.dims; ++i) s += (i ? "x" : "") + std::to_string(blob.size[i]);
  return s;
}

bool Letterbox::BoxToImage(double cx, double cy, double w, double h, const cv::Size& image, cv::Rect2f* box) const {
  const cv::Point2d a = ToImage({cx - 0.5 * w, cy - 0.5 * h});
  const cv::Point2d b = ToImage({cx + 0.5 * w, cy + 0.5 * h});
  const double x0 = std::clamp(a.x, 0.0, static_cast<double>(image.width));
  const double y0 = std::clamp(a.y, 0.0, static_cast<double>(image.height));
  const double x1 = std::clamp(b.x, 0.0, static_cast<double>(image.width));
  const double y1 = std::clamp(b.y, 0.0, static_cast<double>(image.height));
  if (!(x1 - x0 >= 1.0 && y1 - y0 >= 1.0)) return false;
  *box = cv::Rect2f(static_cast<float>(x0), static_cast<float>(y0), static_cast<float>(x1 - x0),
                    static_cast<float>(y1 - y0));
  return true;
}

std::vector<int> SuppressPerClass(const std::vector<Detection>& candidates, double score_threshold,
                                  double nms_threshold) {
  std::map<int, std::vector<int>> by_class;
  for (int i = 0; i < static_cast<int>(candidates.size()); ++i) by_class[candidates[i].class_id].push_back(i);
  std::vector<int> kept;
  for (const auto& [class_id, indices] : by_class) {
    std::vector<cv::Rect2d> boxes;
    std::vector<float> scores;
    for (int i : indices) {
      boxes.emplace_back(candidates[i].box);
      scores.push_back(candidates[i].score);
    }
    std::vector<int> keep;
    cv::dnn::NMSBoxes(boxes, scores, static_cast<float>(score_threshold), static_cast<float>(nms_threshold), keep);
    for (int k : keep) kept.push_back(indices[k]);
  }
  std::stable_sort(kept.begin(), kept.end(), [&](int a, int b) { return candidates[a].score > candidates[b].score; });
  return kept;
}

void DropWeakEnclosingBoxes(double score_ratio, double held_fraction, std::vector<Detection>* detections) {
  if (score_ratio <= 0.0) return;
  const std::vector<Detection>& d = *detections;
  std::vector<char> drop(d.size(), 0);
  for (size_t i = 0; i < d.size(); ++i) {
    for (size_t j = 0; j < d.size() && !drop[i]; ++j) {
      if (j == i || d[j].class_id != d[i].class_id || d[i].score > score_ratio * d[j].score) continue;
      const double inner = d[j].box.area();
      drop[i] = inner > 0.0 && inner < d[i].box.area() && (d[i].box & d[j].box).area() >= held_fraction * inner;
    }
  }
  std::vector<Detection> kept;
  for (size_t i = 0; i < d.size(); ++i)
    if (!drop[i]) kept.push_back(d[i]);
  *detections = std::move(kept);
}

cv::Rect BoxPixels(const cv::Rect2f& box, const cv::Size& size) {
  const int x0 = std::max(0, static_cast<int>(std::floor(box.x)));
  const int y0 = std::max(0, static_cast<int>(std::floor(box.y)));
  const int x1 = std::min(size.width, static_cast<int>(std::ceil(box.x + box.width)));
  const int y1 = std::min(size.height, static_cast<int>(std::ceil(box.y + box.height)));
  if (x1 <= x0 || y1 <= y0) return cv::Rect();
  return cv::Rect(x0, y0, x1 - x0, y1 - y0);
}

void DilateMask(cv::Mat& mask, int radius_px) {
  if (radius_px <= 0 || mask.empty()) return;
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius_px + 1, 2 * radius_px + 1));
  cv::dilate(mask, mask, kernel);
}

}  // namespace dypho
