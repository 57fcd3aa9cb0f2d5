// The camera's exposure as a forward model: rolling shutter and motion blur.
//
// The rasterizer renders a global-shutter image with no exposure time. A real
// frame differs in two ways when the camera turns fast (TUM fr1/rpy turns at
// up to about 2.5 rad/s):
// - rolling shutter: rows are read one after the other over `readout`
//   seconds, so the camera that saw row v is Exp(omega * tau) cam_mid with
//   tau = readout * (v / (H - 1) - 0.5) (the convention of
//   tracker/orb_tracker.h; the frame's pose is the middle row's);
// - motion blur: each pixel integrates light over the exposure time, i.e.
//   over times tau + s, s uniform in [-exposure / 2, exposure / 2].
// Both are modelled for rotation only (the camera moves millimetres within
// one frame): the sensor image is the render warped by the homography
// K R(omega t)^T K^-1 of each sample time and averaged,
//   sensor(q) = 1/N sum_j render(pi(K R(omega (tau(q) + s_j))^T K^-1 q)),
// s_j = exposure ((j + 0.5) / N - 0.5). Training compares the frame with this
// image (engine/torch/mapper.cc, a differentiable grid_sample of the render)
// so a sharp map explains blurred, sheared frames; evaluation applies the
// same model (ApplySensorModel) before scoring. Measured on
// tum_fr1_rpy_head250 before the model: the best horizontal shift between a
// map render and a frame changed by 8 to 10 px from the top band of rows to
// the bottom band (frames 32 to 47), and the frames are visibly smeared.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "common/camera.h"
#include "common/image.h"
#include "common/rigid3.h"

namespace dypho {

struct SensorModel {
  double readout = 0.0;   // [s] first to last row; 0 = global shutter
  double exposure = 0.0;  // [s] integration time; 0 = no blur
  int max_samples = 5;    // most time samples of the blur (the count follows the blur length)
  bool active() const { return readout > 0 || exposure > 0; }
  // Throws InvalidInput naming the field.
  void Validate() const;
};

// Angular velocity [rad/s] of the model (cam_t = Exp(omega t) cam_0) from the
// cam_from_world poses at times t0 < t1: omega = Log(R1 R0^T) / (t1 - t0).
Eigen::Vector3d AngularVelocity(const Rigid3d& cam_from_world_0, double t0, const Rigid3d& cam_from_world_1,
                                double t1);

// A frame's angular velocity from the previous frame with a pose: zero when
// there is none, or it is not older, or it is kMaxAngularVelocityGap or
// more older (a rate cannot be told across such a gap).
constexpr double kMaxAngularVelocityGap = 0.2;  // [s]
Eigen::Vector3d AngularVelocitySince(const std::optional<Rigid3d>& previous, double previous_time,
                                     const Rigid3d& cam_from_world, double time);

// Number of blur samples for a frame: one per 1.5 px of blur streak at the
// image edge, at least 1, at most model.max_samples.
int SensorSampleCount(const Camera& pinhole, const Eigen::Vector3d& omega, const SensorModel& model);

// For each sample j and sensor row y, the homography H = K R(omega t)^T K^-1
// (t = tau(y) + s_j) taking a sensor pixel (x, y, 1) of that row to the
// homogeneous render pixel it reads: samples x height x 9 floats, row-major
// 3x3. `pinhole` has no distortion.
std::vector<float> SensorRowHomographies(const Camera& pinhole, const Eigen::Vector3d& omega,
                                         const SensorModel& model, int samples);

// For each sample j and each sensor pixel q (row-major), the position in the
// global-shutter render [px, pixel centres at integers] it reads (the row
// homographies applied): samples x height x width x 2 floats (x, y); points
// behind the camera get -1e6 (outside).
std::vector<float> SensorSamplePositions(const Camera& pinhole, const Eigen::Vector3d& omega,
                                         const SensorModel& model, int samples);

// The sensor image of a render (any channel count; bilinear, outside = 0).
// Throws InvalidInput when the render's size differs from the camera's.
ImageF ApplySensorModel(const ImageF& render, const Camera& pinhole, const Eigen::Vector3d& omega,
                        const SensorModel& model);

}  // namespace dypho
