#include "engine/pipeline/overlay_writer.h"

#include <algorithm>
#include <utility>

#include "engine/io/image_io.h"
#include "tracker/cv_view.h"

namespace dypho {
namespace {

void Draw(const std::string& path, const cv::Mat& rgb, const MaskResult& masks) {
  const cv::Mat overlay = DrawMaskOverlay(rgb, masks);
  ImageU8 image(overlay.cols, overlay.rows, overlay.channels());
  overlay.copyTo(CvView(image));
  WriteRgb8(path, image);
}

}  // namespace

OverlayWriter::OverlayWriter(bool threaded, int max_pending)
    : threaded_(threaded), max_pending_(static_cast<size_t>(std::max(1, max_pending))), worker_(threaded, "dypho-overlay") {}

OverlayWriter::~OverlayWriter() {
  for (std::future<void>& f : pending_) f.wait();
}

void OverlayWriter::Write(const std::string& path, const cv::Mat& rgb, const MaskResult& masks) {
  if (!threaded_) {
    Draw(path, rgb, masks);
    return;
  }
  while (pending_.size() >= max_pending_) {
    std::future<void> oldest = std::move(pending_.front());
    pending_.pop_front();
    oldest.get();  // rethrows its error
  }
  // What DrawMaskOverlay reads, owned by the job.
  MaskResult own;
  own.mask = masks.mask.clone();
  own.detections = masks.detections;
  own.features = masks.features;
  pending_.push_back(worker_.Submit<void>(
      [path, rgb = rgb.clone(), own = std::move(own)] { Draw(path, rgb, own); }));
}

void OverlayWriter::Finish() {
  while (!pending_.empty()) {
    std::future<void> oldest = std::move(pending_.front());
    pending_.pop_front();
    oldest.get();  // rethrows its error
  }
}

}  // namespace dypho
