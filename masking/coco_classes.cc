#include "masking/coco_classes.h"

#include <algorithm>
#include <sstream>

#include "common/check.h"

namespace dypho {

const std::vector<std::string>& CocoClassNames() {
  static const std::vector<std::string> kNames = {
      "person",         "bicycle",    "car",           "motorcycle",    "airplane",     "bus",           "train",
      "truck",          "boat",       "traffic light", "fire hydrant",  "stop sign",    "parking meter", "bench",
      "bird",           "cat",        "dog",           "horse",         "sheep",        "cow",           "elephant",
      "bear",           "zebra",      "giraffe",       "backpack",      "umbrella",     "handbag",       "tie",
      "suitcase",       "frisbee",    "skis",          "snowboard",     "sports ball",  "kite",          "baseball bat",
      "baseball glove", "skateboard", "surfboard",     "tennis racket", "bottle",       "wine glass",    "cup",
      "fork",           "knife",      "spoon",         "bowl",          "banana",       "apple",         "sandwich",
      "orange",         "broccoli",   "carrot",        "hot dog",       "pizza",        "donut",         "cake",
      "chair",          "couch",      "potted plant",  "bed",           "dining table", "toilet",        "tv",
      "laptop",         "mouse",      "remote",        "keyboard",      "cell phone",   "microwave",     "oven",
      "toaster",        "sink",       "refrigerator",  "book",          "clock",        "vase",          "scissors",
      "teddy bear",     "hair drier", "toothbrush"};
  return kNames;
}

int CocoClassId(const std::string& name) {
  const auto& names = CocoClassNames();
  const auto it = std::find(names.begin(), names.end(), name);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

const std::vector<std::string>& MovingCocoClasses() {
  static const std::vector<std::string> kMoving = {
      "person", "bicycle", "car",   "motorcycle", "airplane", "bus",      "train", "truck", "boat",   "bird",
      "cat",    "dog",     "horse", "sheep",      "cow",      "elephant", "bear",  "zebra", "giraffe"};
  return kMoving;
}

std::vector<std::string> ParseClassList(const std::string& text) {
  std::vector<std::string> classes;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    const size_t first = item.find_first_not_of(" \t");
    if (first == std::string::npos) continue;
    item = item.substr(first, item.find_last_not_of(" \t") - first + 1);
    if (item == "moving") {
      for (const auto& c : MovingCocoClasses())
        if (std::find(classes.begin(), classes.end(), c) == classes.end()) classes.push_back(c);
      continue;
    }
    DYPHO_CHECK_INPUT(CocoClassId(item) >= 0)
        << "unknown COCO class '" << item << "' (use COCO names such as person, dog, car, boat, or 'moving')";
    if (std::find(classes.begin(), classes.end(), item) == classes.end()) classes.push_back(item);
  }
  return classes;
}

}  // namespace dypho
