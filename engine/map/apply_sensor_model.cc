// ApplySensorModel (engine/map/sensor_model.h): the one part of the sensor
// model that uses OpenCV (cv::remap), apart from sensor_model.cc so that the
// mapper, which needs only the row homographies, builds without OpenCV
// (tools/gpu_check).
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "engine/map/sensor_model.h"

namespace dypho {

ImageF ApplySensorModel(const ImageF& render, const Camera& pinhole, const Eigen::Vector3d& omega,
                        const SensorModel& model) {
  DYPHO_CHECK_INPUT(render.width() == pinhole.width && render.height() == pinhole.height)
      << "sensor model: render is " << render.width() << "x" << render.height() << ", the camera "
      << pinhole.width << "x" << pinhole.height;
  if (!model.active()) return render;
  const int n = SensorSampleCount(pinhole, omega, model);
  const std::vector<float> pos = SensorSamplePositions(pinhole, omega, model, n);
  const int w = render.width(), h = render.height(), c = render.channels();
  const cv::Mat src(h, w, CV_32FC(c), const_cast<float*>(render.data()));
  cv::Mat sum(h, w, CV_32FC(c), cv::Scalar::all(0));
  for (int j = 0; j < n; ++j) {
    const cv::Mat map(h, w, CV_32FC2, const_cast<float*>(pos.data() + static_cast<size_t>(j) * w * h * 2));
    cv::Mat sample;
    cv::remap(src, sample, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
    sum += sample;
  }
  ImageF out(w, h, c);
  cv::Mat dst(h, w, CV_32FC(c), out.data());
  sum.convertTo(dst, CV_32F, 1.0 / n);
  return out;
}

}  // namespace dypho
