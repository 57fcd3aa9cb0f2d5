// Semantic prior: a segmenter turns one RGB(-D) frame into a mask of the
// objects of the classes that move (people, animals, vehicles, boats).
//
// Implementations (chosen by CreateSegmenter, the only place that knows them):
//  - YOLOX detector (masking/yolox_detector.h): boxes from an ONNX model run by
//    OpenCV DNN; the mask inside each box is made from depth
//    (masking/depth_box_mask.h).
//  - YOLOv8-seg (masking/yolov8_seg.h): boxes plus mask coefficients times
//    prototype masks, for users who export such a model.
//  - Folder of PNG masks (masking/png_folder_segmenter.h), for masks made
//    offline by any other segmenter.
// With no model and no folder the semantic mask is empty and the rest of the
// masking still works.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "masking/depth_box_mask.h"

namespace dypho {

struct SegmenterOptions {
  // "auto": png_folder when set, else the model at model_path (YOLOv8-seg
  // when it has a prototype-mask output, else YOLOX), else none.
  std::string kind = "auto";                      // auto | none | yolox | yolov8-seg | png-folder
  std::string model_path;                         // ONNX model file; "" = no model (empty semantic mask)
  std::string png_folder;                         // folder of <image name>.png masks (nonzero = dynamic)
  std::vector<std::string> classes = {"person"};  // COCO class names treated as dynamic (see coco_classes.h)
  double score_threshold = 0.3;                   // min detection score (YOLOX: objectness x class), [0, 1]
  double nms_threshold = 0.45;                    // boxes of one class overlapping more (IoU) are suppressed, [0, 1]
  int input_size = 0;                             // network input edge [px]; 0 = 416 (YOLOX), 640 (YOLOv8-seg)
  double enclosing_score_ratio = 0.5;             // YOLOX: drop a box holding one of >= 1/ratio its score; 0 = off
  bool rect_input = true;                         // YOLOX: input_size on the long side only (416x320 for 4:3)
  // YOLOX with depth: a box whose depth region covers less than this share
  // of it gets a second look: the detector runs again on the box (10 % wider)
  // with the region greyed out, and a person found there that is not the
  // region gets its own mask from the depth outside the region (two people in
  // one box: the one beside or behind; kept when confident, nearly as tall as
  // the box, narrower, and at most 0.8 m behind the near one). 0 = off.
  double second_look_max_cover = 0.7;
  double mask_threshold = 0.5;                    // YOLOv8-seg: mask probability threshold, (0, 1)
  int dilation_px = 6;                            // model masks grow by this margin [px], 0..100
  bool png_missing_is_empty = false;              // png-folder: a missing file is an empty mask (else an error)
  DepthBoxMaskOptions box_mask;                   // YOLOX: mask inside each box from depth

  // False with `error` naming the field when a value is out of range or a
  // class name is unknown.
  bool IsValid(std::string* error) const;
};

// One frame to segment.
struct SegmenterInput {
  cv::Mat rgb;       // CV_8UC3, RGB order
  cv::Mat depth;     // CV_32FC1 [m], 0 = invalid; empty when there is none
  std::string name;  // image name without extension (png-folder looks up <name>.png)
};

// One detected object.
struct Detection {
  cv::Rect2f box;      // [px] in the input image (clipped to it)
  int class_id = -1;   // COCO class id
  float score = 0.0f;  // detection score in [0, 1]
  cv::Rect mask_roi;   // where `mask` lies in the image (empty without a mask)
  cv::Mat mask;        // CV_8UC1 of mask_roi's size, 255 = object (before dilation)
  float depth = 0.0f;  // [m] the object's dominant depth (YOLOX with depth), 0 = unknown
};

struct Segmentation {
  cv::Mat mask;                       // CV_8UC1, image size, 255 = dynamic (after dilation)
  std::vector<Detection> detections;  // empty for png-folder
};

class Segmenter {
 public:
  virtual ~Segmenter() = default;
  // Throws InvalidInput naming the argument for an empty or wrongly typed
  // image, a depth image of another size, or (png-folder) a missing or
  // wrongly sized mask file. Not required to be thread-safe.
  virtual Segmentation Segment(const SegmenterInput& input) = 0;
  // "yolox", "yolov8-seg", "png-folder", "none", ...
  virtual std::string Name() const = 0;
};

// The segmenter the options ask for; a segmenter that returns an empty mask
// when they ask for none. Throws InvalidInput for invalid options, a missing
// or unreadable model file, or a model whose inputs or outputs do not have
// the expected shape (naming the file).
std::unique_ptr<Segmenter> CreateSegmenter(const SegmenterOptions& options);

// Checks a SegmenterInput (rgb CV_8UC3; depth empty or CV_32FC1 of the same size).
void CheckSegmenterInput(const SegmenterInput& input);
// Class ids of `names` (COCO); throws InvalidInput naming an unknown one.
std::vector<int> ClassIds(const std::vector<std::string>& names);

}  // namespace dypho
