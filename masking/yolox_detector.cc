#include "masking/yolox_detector.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "common/check.h"
#include "common/logging.h"
#include "masking/mat_checks.h"

namespace dypho {
namespace {

constexpr int kStrides[3] = {8, 16, 32};
constexpr double kPadValue = 114.0;
constexpr int kDefaultInputSize = 416;
constexpr float kSecondLookScore = 0.5f;    // a person found by the second look scores at least this
constexpr float kSecondLookMaxGap = 0.8f;   // [m] and stands at most this far behind the near person

// The share of a box mask's box its object covers.
double Cover(const BoxMask& m) { return static_cast<double>(cv::countNonZero(m.mask)) / m.roi.area(); }

// A detection takes a box mask as its region, and the frame's mask gains it.
void TakeRegion(const BoxMask& bm, Detection* d, cv::Mat* mask) {
  d->mask_roi = bm.roi;
  d->mask = bm.mask;
  d->depth = bm.depth;
  if (!bm.roi.empty()) (*mask)(bm.roi) |= bm.mask;
}

}  // namespace

int YoloxAnchorCount(const cv::Size& input) {
  int n = 0;
  for (int s : kStrides) n += (input.width / s) * (input.height / s);
  return n;
}

cv::Size YoloxRectInput(const cv::Size& image, int edge) {
  DYPHO_CHECK_INPUT(image.width > 0 && image.height > 0 && edge > 0 && edge % 32 == 0)
      << "YOLOX input for a " << image.width << "x" << image.height << " image at edge " << edge;
  const double scale = static_cast<double>(edge) / std::max(image.width, image.height);
  const auto fit = [&](int side) {
    const int scaled = static_cast<int>(std::lround(side * scale));
    return std::min(edge, std::max(32, (scaled + 31) / 32 * 32));
  };
  return {fit(image.width), fit(image.height)};
}

std::vector<Detection> DecodeYoloxOutput(const cv::Mat& output, const cv::Size& input, const Letterbox& letterbox,
                                         const cv::Size& image_size, const std::vector<int>& class_ids,
                                         double score_threshold, double nms_threshold) {
  const int anchors = YoloxAnchorCount(input);
  DYPHO_CHECK_INPUT(output.type() == CV_32F && (output.dims == 3 || output.dims == 2))
      << "YOLOX output must be a float 1xNx(5+C) tensor (got " << ShapeText(output) << ", "
      << MatTypeName(output.type()) << ")";
  const int rows = output.dims == 3 ? output.size[1] : output.size[0];
  const int cols = output.dims == 3 ? output.size[2] : output.size[1];
  DYPHO_CHECK_INPUT((output.dims == 2 || output.size[0] == 1) && rows == anchors && cols > 5)
      << "YOLOX output has shape " << ShapeText(output) << " but a " << input.width << "x" << input.height
      << " input needs 1x" << anchors << "x(5+classes)";
  const int num_classes = cols - 5;
  for (int c : class_ids)
    DYPHO_CHECK_INPUT(c >= 0 && c < num_classes)
        << "class id " << c << " is not in the model's " << num_classes << " classes";
  const float* data = output.ptr<float>();
  std::vector<Detection> candidates;
  int row = 0;
  for (int s : kStrides) {
    const int grid_w = input.width / s, grid_h = input.height / s;
    for (int gy = 0; gy < grid_h; ++gy) {
      for (int gx = 0; gx < grid_w; ++gx, ++row) {
        const float* p = data + static_cast<size_t>(row) * cols;
        const float objectness = p[4];
        if (objectness < score_threshold) continue;  // score = objectness * class score <= objectness
        int best_class = -1;
        float best_score = 0.0f;
        for (int c : class_ids) {
          const float score = objectness * p[5 + c];
          if (score > best_score) best_score = score, best_class = c;
        }
        if (best_class < 0 || best_score < score_threshold) continue;
        const double cx = (p[0] + gx) * s, cy = (p[1] + gy) * s;
        const double w = std::exp(std::min(p[2], 20.0f)) * s, h = std::exp(std::min(p[3], 20.0f)) * s;
        Detection d;
        if (!letterbox.BoxToImage(cx, cy, w, h, image_size, &d.box)) continue;
        d.class_id = best_class;
        d.score = best_score;
        candidates.push_back(d);
      }
    }
  }
  std::vector<Detection> kept;
  for (int i : SuppressPerClass(candidates, score_threshold, nms_threshold)) kept.push_back(candidates[i]);
  return kept;
}

struct YoloxSegmenter::Impl : OnnxSegmenterModel {
  explicit Impl(OnnxSegmenterModel m) : OnnxSegmenterModel(std::move(m)) {}
  cv::Size Square() const { return {input_size, input_size}; }
  bool rect_failed = false;  // the model would not run at the rect_input shape: square from then on
  cv::Size last_input;
};

YoloxSegmenter::YoloxSegmenter(const SegmenterOptions& options)
    : impl_(std::make_unique<Impl>(LoadOnnxSegmenter(options, "YOLOX", kDefaultInputSize))) {
  // Check the output shape once on a blank (pad-valued) input.
  const cv::Mat blank(1, 1, CV_8UC3, cv::Scalar::all(kPadValue));
  const Letterbox lb = Letterbox::Make(blank.size(), {impl_->input_size, impl_->input_size}, false);
  const std::vector<cv::Mat> outputs =
      RunNetwork(impl_->net, MakeLetterboxBlob(blank, lb, true, 1.0, kPadValue), options.model_path);
  DYPHO_CHECK_INPUT(outputs.size() == 1) << "model '" << options.model_path << "' has " << outputs.size()
                                         << " outputs; YOLOX has one";
  const cv::Mat& out = outputs[0];
  const int anchors = YoloxAnchorCount(impl_->Square());
  DYPHO_CHECK_INPUT(out.dims == 3 && out.size[0] == 1 && out.size[1] == anchors && out.size[2] > 5)
      << "model '" << options.model_path << "' has output shape " << ShapeText(out) << "; a YOLOX model at "
      << impl_->input_size << "x" << impl_->input_size << " gives 1x" << anchors << "x(5+classes)";
  for (int c : impl_->class_ids)
    DYPHO_CHECK_INPUT(c < out.size[2] - 5) << "model '" << options.model_path << "' has " << out.size[2] - 5
                                           << " classes; class id " << c << " is not among them";
}

YoloxSegmenter::~YoloxSegmenter() = default;

int YoloxSegmenter::input_size() const { return impl_->input_size; }

std::vector<Detection> YoloxSegmenter::SecondLook(const cv::Mat& rgb, const cv::Rect& box, const BoxMask& region,
                                                  double max_cover, const cv::Size& net_input) {
  std::vector<Detection> found;
  if (box.empty() || !region.from_depth || region.mask.empty()) return found;
  if (Cover(region) >= max_cover) return found;
  const int margin = box.width / 10;
  const cv::Rect crop = cv::Rect(box.x - margin, box.y, box.width + 2 * margin, box.height) & cv::Rect({}, rgb.size());
  const cv::Rect in_crop = region.roi - crop.tl();
  if (in_crop != (in_crop & cv::Rect({}, crop.size())) || region.mask.size() != in_crop.size()) return found;
  cv::Mat grey(crop.size(), CV_8UC1, cv::Scalar(0));
  region.mask.copyTo(grey(in_crop));
  DilateMask(grey, 4);
  cv::Mat image = rgb(crop).clone();
  image.setTo(cv::Scalar::all(kPadValue), grey);
  const SegmenterOptions& o = impl_->options;
  const cv::Size input = net_input == impl_->Square() ? net_input : YoloxRectInput(crop.size(), impl_->input_size);
  const Letterbox lb = Letterbox::Make(crop.size(), input, false);
  const std::vector<cv::Mat> outputs =
      RunNetwork(impl_->net, MakeLetterboxBlob(image, lb, true, 1.0, kPadValue), o.model_path);
  for (Detection d : DecodeYoloxOutput(outputs.at(0), input, lb, crop.size(), impl_->class_ids, o.score_threshold,
                                       o.nms_threshold)) {
    const cv::Rect b = BoxPixels(d.box, crop.size());
    // A whole second person standing in the box: confident, nearly as tall
    // as the box, narrower than it, and mostly outside the greyed region (not
    // the greyed person found again, not a limb or an outline of it).
    if (b.empty() || d.score < kSecondLookScore || b.height < 0.8 * box.height || b.width > 0.7 * box.width ||
        cv::countNonZero(grey(b)) > 0.5 * b.area())
      continue;
    d.box.x += crop.x;
    d.box.y += crop.y;
    found.push_back(d);
  }
  return found;
}

cv::Size YoloxSegmenter::last_input() const { return impl_->last_input; }

Segmentation YoloxSegmenter::Segment(const SegmenterInput& input) {
  CheckSegmenterInput(input);
  const SegmenterOptions& o = impl_->options;
  const cv::Size image_size = input.rgb.size();
  const auto run = [&](const cv::Size& net_input, Letterbox* lb) {
    *lb = Letterbox::Make(image_size, net_input, false);
    return RunNetwork(impl_->net, MakeLetterboxBlob(input.rgb, *lb, true, 1.0, kPadValue), o.model_path);
  };
  const auto decode = [&](const std::vector<cv::Mat>& outputs, const cv::Size& net_input, const Letterbox& lb) {
    return DecodeYoloxOutput(outputs.at(0), net_input, lb, image_size, impl_->class_ids, o.score_threshold,
                             o.nms_threshold);
  };
  Segmentation result;
  cv::Size net_input = impl_->Square();
  bool decoded = false;
  const cv::Size rect = YoloxRectInput(image_size, impl_->input_size);
  if (o.rect_input && !impl_->rect_failed && rect != net_input) {
    // A model fixed at export to a square input fails here (an OpenCV error, or
    // an output with the square's anchor count, which the decoding rejects).
    try {
      Letterbox lb;
      result.detections = decode(run(rect, &lb), rect, lb);
      net_input = rect;
      decoded = true;
    } catch (const InvalidInput& e) {
      impl_->rect_failed = true;
      DYPHO_LOG(Warning) << "model '" << o.model_path << "' does not run at " << rect.width << "x" << rect.height
                         << " (" << e.what() << "); using " << net_input.width << "x" << net_input.height
                         << " (masking.segmenter.rect_input=false avoids this try)";
    }
  }
  if (!decoded) {
    Letterbox lb;
    result.detections = decode(run(net_input, &lb), net_input, lb);
  }
  impl_->last_input = net_input;
  DropWeakEnclosingBoxes(o.enclosing_score_ratio, 0.8, &result.detections);
  result.mask = cv::Mat(image_size, CV_8UC1, cv::Scalar(0));
  std::vector<cv::Rect> boxes;
  for (const Detection& d : result.detections) boxes.push_back(BoxPixels(d.box, image_size));
  // Together, so that a person behind another finds their own depth.
  const std::vector<BoxMask> masks = MasksFromDepthInBoxes(input.depth, boxes, o.box_mask);
  for (size_t k = 0; k < boxes.size(); ++k) {
    if (boxes[k].empty()) continue;
    TakeRegion(masks[k], &result.detections[k], &result.mask);
  }
  if (o.second_look_max_cover > 0 && !input.depth.empty()) {
    // The people found by a second look get their region from the depth
    // outside every region found so far (else the nearer person's layer);
    // made once, when the first is found.
    cv::Mat rest;
    for (size_t k = 0, n = boxes.size(); k < n; ++k) {
      for (Detection& d : SecondLook(input.rgb, boxes[k], masks[k], o.second_look_max_cover, net_input)) {
        if (rest.empty()) {
          cv::Mat found_so_far = result.mask.clone();
          DilateMask(found_so_far, 4);
          rest = input.depth.clone();
          rest.setTo(0.0f, found_so_far);
        }
        const BoxMask bm = MaskFromDepthInBox(rest, BoxPixels(d.box, image_size), o.box_mask);
        if (!bm.from_depth || bm.roi.empty()) continue;
        // Behind the near person and close to them (a wall or a desk farther
        // back that the detector took for a person is left), and person-like
        // in its box.
        const double cover = Cover(bm);
        const bool take = bm.depth > masks[k].depth && bm.depth < masks[k].depth + kSecondLookMaxGap && cover >= 0.25;
        DYPHO_LOG(Debug) << "second look: person " << d.score << " box " << bm.roi << " cover " << cover << " depth "
                         << bm.depth << " (near " << masks[k].depth << ")" << (take ? " taken" : "");
        if (!take) continue;
        TakeRegion(bm, &d, &result.mask);
        result.detections.push_back(d);
      }
    }
  }
  DilateMask(result.mask, o.dilation_px);
  return result;
}

}  // namespace dypho
