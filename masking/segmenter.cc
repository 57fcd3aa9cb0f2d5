#include "masking/segmenter.h"

#include <sstream>

#include "common/check.h"
#include "masking/coco_classes.h"
#include "masking/dnn_model.h"
#include "masking/mat_checks.h"
#include "masking/png_folder_segmenter.h"
#include "masking/yolov8_seg.h"
#include "masking/yolox_detector.h"

namespace dypho {
namespace {

class NoSegmenter : public Segmenter {
 public:
  Segmentation Segment(const SegmenterInput& input) override {
    CheckSegmenterInput(input);
    return {cv::Mat(input.rgb.size(), CV_8UC1, cv::Scalar(0)), {}};
  }
  std::string Name() const override { return "none"; }
};

}  // namespace

bool SegmenterOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  std::string sub;
  if (kind != "auto" && kind != "none" && kind != "yolox" && kind != "yolov8-seg" && kind != "png-folder")
    msg << "kind must be auto, none, yolox, yolov8-seg or png-folder (got '" << kind << "')";
  else if ((kind == "yolox" || kind == "yolov8-seg") && model_path.empty())
    msg << "model_path must be set for kind " << kind;
  else if (kind == "png-folder" && png_folder.empty())
    msg << "png_folder must be set for kind png-folder";
  else if (!(score_threshold >= 0 && score_threshold <= 1))
    msg << "score_threshold must be in [0, 1] (got " << score_threshold << ")";
  else if (!(nms_threshold >= 0 && nms_threshold <= 1))
    msg << "nms_threshold must be in [0, 1] (got " << nms_threshold << ")";
  else if (input_size < 0 || input_size > 4096 || input_size % 32 != 0)
    msg << "input_size must be 0 or a multiple of 32 up to 4096 (got " << input_size << ")";
  else if (!(enclosing_score_ratio >= 0 && enclosing_score_ratio <= 1))
    msg << "enclosing_score_ratio must be in [0, 1] (got " << enclosing_score_ratio << ")";
  else if (!(second_look_max_cover >= 0 && second_look_max_cover <= 1))
    msg << "second_look_max_cover must be in [0, 1] (got " << second_look_max_cover << ")";
  else if (!(mask_threshold > 0 && mask_threshold < 1))
    msg << "mask_threshold must be in (0, 1) (got " << mask_threshold << ")";
  else if (dilation_px < 0 || dilation_px > 100)
    msg << "dilation_px must be in 0..100 (got " << dilation_px << ")";
  else if (!box_mask.IsValid(&sub))
    msg << "box_mask." << sub;
  else {
    for (const std::string& c : classes) {
      if (CocoClassId(c) < 0) {
        msg << "classes: unknown COCO class '" << c << "'";
        break;
      }
    }
  }
  if (msg.str().empty()) return true;
  if (error) *error = msg.str();
  return false;
}

void CheckSegmenterInput(const SegmenterInput& input) {
  CheckMat(input.rgb, CV_8UC3, cv::Size(), "rgb");
  CheckOptionalMat(input.depth, CV_32FC1, input.rgb.size(), "depth");
}

std::vector<int> ClassIds(const std::vector<std::string>& names) {
  std::vector<int> ids;
  for (const std::string& name : names) {
    const int id = CocoClassId(name);
    DYPHO_CHECK_INPUT(id >= 0) << "unknown COCO class '" << name << "'";
    ids.push_back(id);
  }
  return ids;
}

std::unique_ptr<Segmenter> CreateSegmenter(const SegmenterOptions& options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "SegmenterOptions." << error;
  std::string kind = options.kind;
  if (kind == "auto") {
    if (!options.png_folder.empty()) {
      kind = "png-folder";
    } else if (!options.model_path.empty()) {
      // YOLOv8-seg has two outputs (detections and prototypes), YOLOX one.
      cv::dnn::Net net = LoadOnnxModel(options.model_path);
      kind = net.getUnconnectedOutLayersNames().size() == 2 ? "yolov8-seg" : "yolox";
    } else {
      kind = "none";
    }
  }
  if (kind == "png-folder") return std::make_unique<PngFolderSegmenter>(options);
  if (kind == "yolox") return std::make_unique<YoloxSegmenter>(options);
  if (kind == "yolov8-seg") return std::make_unique<Yolov8SegSegmenter>(options);
  return std::make_unique<NoSegmenter>();
}

}  // namespace dypho
