// The 80 COCO object classes in the order of the usual detector outputs
// (YOLOX, YOLOv5/v8: index 0 = person), and the subset that moves on its own.
#pragma once

#include <string>
#include <vector>

namespace dypho {

// Names of the 80 COCO classes, index = class id of the detector output.
const std::vector<std::string>& CocoClassNames();
// Class id of `name` (exact COCO spelling, e.g. "person", "traffic light"); -1 when unknown.
int CocoClassId(const std::string& name);
// The COCO classes that move by themselves or are driven: person, the
// animals (bird .. giraffe) and the vehicles (bicycle, car, motorcycle,
// airplane, bus, train, truck, boat).
const std::vector<std::string>& MovingCocoClasses();
// Parses a comma-separated list of class names; the word "moving" expands to
// MovingCocoClasses(). Throws InvalidInput naming an unknown class.
std::vector<std::string> ParseClassList(const std::string& text);

}  // namespace dypho
