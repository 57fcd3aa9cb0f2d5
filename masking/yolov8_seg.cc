#include "masking/yolov8_seg.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "masking/mat_checks.h"

namespace dypho {
namespace {

constexpr double kPadValue = 114.0;
constexpr int kDefaultInputSize = 640;
constexpr int kCocoClasses = 80;

// Which of the two outputs holds the prototypes (4-D) and which the detections (3-D).
void SplitOutputs(const std::vector<cv::Mat>& outputs, const std::string& model_path, cv::Mat* detections,
                  cv::Mat* prototypes) {
  DYPHO_CHECK_INPUT(outputs.size() == 2)
      << "model '" << model_path << "' has " << outputs.size()
      << " outputs; YOLOv8-seg has two (detections 1x(4+C+M)xN and prototypes 1xMxHxW)";
  const int proto_index = outputs[0].dims == 4 ? 0 : 1;
  *prototypes = outputs[proto_index];
  *detections = outputs[1 - proto_index];
  DYPHO_CHECK_INPUT(prototypes->dims == 4 && detections->dims == 3)
      << "model '" << model_path << "' has outputs " << ShapeText(outputs[0]) << " and " << ShapeText(outputs[1])
      << "; YOLOv8-seg gives detections 1x(4+C+M)xN and prototypes 1xMxHxW";
}

}  // namespace

std::vector<Detection> DecodeYolov8SegOutput(const cv::Mat& detections, const cv::Mat& prototypes,
                                             const Letterbox& letterbox, const cv::Size& image_size,
                                             const std::vector<int>& class_ids, double score_threshold,
                                             double nms_threshold, double mask_threshold) {
  DYPHO_CHECK_INPUT(prototypes.type() == CV_32F && prototypes.dims == 4 && prototypes.size[0] == 1)
      << "YOLOv8-seg prototypes must be a float 1xMxHxW tensor (got " << ShapeText(prototypes) << ")";
  DYPHO_CHECK_INPUT(detections.type() == CV_32F && detections.dims == 3 && detections.size[0] == 1)
      << "YOLOv8-seg detections must be a float 1x(4+C+M)xN tensor (got " << ShapeText(detections) << ")";
  const int m = prototypes.size[1], proto_h = prototypes.size[2], proto_w = prototypes.size[3];
  const int d1 = detections.size[1], d2 = detections.size[2];
  bool channels_first;
  if (d1 == 4 + kCocoClasses + m)
    channels_first = true;
  else if (d2 == 4 + kCocoClasses + m)
    channels_first = false;
  else
    channels_first = d1 <= d2;
  const int channels = channels_first ? d1 : d2;
  const int anchors = channels_first ? d2 : d1;
  const int num_classes = channels - 4 - m;
  DYPHO_CHECK_INPUT(num_classes >= 1) << "YOLOv8-seg detections " << ShapeText(detections) << " do not fit prototypes "
                                      << ShapeText(prototypes) << ": need 4 + classes + " << m << " channels";
  for (int c : class_ids)
    DYPHO_CHECK_INPUT(c >= 0 && c < num_classes)
        << "class id " << c << " is not in the model's " << num_classes << " classes";
  const float* data = detections.ptr<float>();
  auto at = [&](int channel, int anchor) {
    return channels_first ? data[static_cast<size_t>(channel) * anchors + anchor]
                          : data[static_cast<size_t>(anchor) * channels + channel];
  };

  // Candidates and their anchors.
  std::vector<Detection> candidates;
  std::vector<int> candidate_anchor;
  for (int a = 0; a < anchors; ++a) {
    int best_class = -1;
    float best_score = 0.0f;
    for (int c : class_ids) {
      const float s = at(4 + c, a);
      if (s > best_score) best_score = s, best_class = c;
    }
    if (best_class < 0 || best_score < score_threshold) continue;
    Detection d;
    if (!letterbox.BoxToImage(at(0, a), at(1, a), at(2, a), at(3, a), image_size, &d.box)) continue;
    d.class_id = best_class;
    d.score = best_score;
    candidates.push_back(d);
    candidate_anchor.push_back(a);
  }
  std::vector<Detection> kept;
  std::vector<int> kept_anchor;
  for (int i : SuppressPerClass(candidates, score_threshold, nms_threshold)) {
    kept.push_back(candidates[i]);
    kept_anchor.push_back(candidate_anchor[i]);
  }

  // Masks: sigmoid(coefficients . prototypes), resampled into the box.
  const cv::Mat protos(m, proto_h * proto_w, CV_32F, const_cast<float*>(prototypes.ptr<float>()));
  // Prototype pixel per input pixel, and the affine map image pixel -> prototype pixel (centres at integers).
  const double kx = static_cast<double>(proto_w) / letterbox.input_width;
  const double ky = static_cast<double>(proto_h) / letterbox.input_height;
  for (size_t i = 0; i < kept.size(); ++i) {
    Detection& d = kept[i];
    const int anchor = kept_anchor[i];
    cv::Mat coefficients(1, m, CV_32F);
    for (int k = 0; k < m; ++k) coefficients.at<float>(0, k) = at(4 + num_classes + k, anchor);
    cv::Mat logits = coefficients * protos;  // 1 x (Hm Wm)
    cv::Mat prob;
    cv::exp(-logits, prob);
    prob = 1.0 / (1.0 + prob);
    prob = prob.reshape(1, proto_h);
    d.mask_roi = BoxPixels(d.box, image_size);
    if (d.mask_roi.empty()) continue;
    // image pixel u (centre u + 0.5 in edge coordinates) -> input x = (u + 0.5) s + pad
    // -> prototype centre coordinate x kx - 0.5.
    const double ax = letterbox.scale * kx, ay = letterbox.scale * ky;
    const double bx = ((d.mask_roi.x + 0.5) * letterbox.scale + letterbox.pad_x) * kx - 0.5;
    const double by = ((d.mask_roi.y + 0.5) * letterbox.scale + letterbox.pad_y) * ky - 0.5;
    const cv::Matx23d roi_to_proto(ax, 0, bx, 0, ay, by);
    cv::Mat sampled;
    cv::warpAffine(prob, sampled, roi_to_proto, d.mask_roi.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                   cv::BORDER_REPLICATE);
    d.mask = sampled > mask_threshold;
  }
  return kept;
}

struct Yolov8SegSegmenter::Impl : OnnxSegmenterModel {
  explicit Impl(OnnxSegmenterModel m) : OnnxSegmenterModel(std::move(m)) {}
};

Yolov8SegSegmenter::Yolov8SegSegmenter(const SegmenterOptions& options)
    : impl_(std::make_unique<Impl>(LoadOnnxSegmenter(options, "YOLOv8-seg", kDefaultInputSize))) {
  const cv::Mat blank(1, 1, CV_8UC3, cv::Scalar::all(kPadValue));
  const Letterbox lb = Letterbox::Make(blank.size(), {impl_->input_size, impl_->input_size}, true);
  cv::Mat detections, prototypes;
  SplitOutputs(RunNetwork(impl_->net, MakeLetterboxBlob(blank, lb, false, 1.0 / 255.0, kPadValue), options.model_path),
               options.model_path, &detections, &prototypes);
  // Decoding a blank frame validates the shapes (throws naming the problem).
  try {
    DecodeYolov8SegOutput(detections, prototypes, lb, blank.size(), impl_->class_ids, 1.0, 0.5, 0.5);
  } catch (const InvalidInput& e) {
    DYPHO_CHECK_INPUT(false) << "model '" << options.model_path << "': " << e.what();
  }
}

Yolov8SegSegmenter::~Yolov8SegSegmenter() = default;

Segmentation Yolov8SegSegmenter::Segment(const SegmenterInput& input) {
  CheckSegmenterInput(input);
  const SegmenterOptions& o = impl_->options;
  const cv::Size image_size = input.rgb.size();
  const Letterbox lb = Letterbox::Make(image_size, {impl_->input_size, impl_->input_size}, true);
  cv::Mat detections, prototypes;
  SplitOutputs(RunNetwork(impl_->net, MakeLetterboxBlob(input.rgb, lb, false, 1.0 / 255.0, kPadValue), o.model_path),
               o.model_path, &detections, &prototypes);
  Segmentation result;
  result.detections = DecodeYolov8SegOutput(detections, prototypes, lb, image_size, impl_->class_ids, o.score_threshold,
                                            o.nms_threshold, o.mask_threshold);
  result.mask = cv::Mat(image_size, CV_8UC1, cv::Scalar(0));
  for (const Detection& d : result.detections)
    if (!d.mask_roi.empty()) result.mask(d.mask_roi) |= d.mask;
  DilateMask(result.mask, o.dilation_px);
  return result;
}

}  // namespace dypho
