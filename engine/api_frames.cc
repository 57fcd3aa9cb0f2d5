#include "engine/api_frames.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "engine/map/depth_warp.h"
#include "engine/map/sensor_model.h"
#include "engine/render/render.h"
#include "engine/stereo/disparity.h"
#include "engine/stereo/pair_depth.h"

namespace dypho {

namespace {

// Depth [m] of a rectified pair, as the stereo datasets' frame loader makes
// it (engine/stereo/stereo_dataset.cc): matched pixels with disparity >= 1.
ImageF StereoDepth(const ImageU8& left_rgb, const uint8_t* right_rgb, const EngineOptions& options,
                   double* seconds = nullptr) {
  const int w = options.camera.width, h = options.camera.height;
  cv::Mat left_grey, right_grey;
  cv::cvtColor(cv::Mat(h, w, CV_8UC3, const_cast<uint8_t*>(left_rgb.data())), left_grey, cv::COLOR_RGB2GRAY);
  cv::cvtColor(cv::Mat(h, w, CV_8UC3, const_cast<uint8_t*>(right_rgb)), right_grey, cv::COLOR_RGB2GRAY);
  stereo::DisparityOptions d;
  d.method = stereo::ParseDisparityMethod(options.stereo_method);
  d.SetMaxDisparity(options.stereo_max_disparity);
  const cv::Mat depth =
      stereo::PairDepth(left_grey, right_grey, d, options.camera.fx, options.stereo_baseline, 1.0, 1, seconds);
  ImageF out(w, h, 1);
  for (int y = 0; y < h; ++y) std::memcpy(out.data() + size_t(y) * w, depth.ptr<float>(y), w * sizeof(float));
  return out;
}

}  // namespace

ImageF DepthAtColourTime(ImageF pinhole_depth, const Camera& camera, double depth_dt,
                         const std::optional<Rigid3d>& previous, double previous_time, const Rigid3d& cam_from_world,
                         double time, const Eigen::Vector3d& omega) {
  if (pinhole_depth.empty() || !(std::abs(depth_dt) >= 1e-3)) return pinhole_depth;
  // cam(t + s) = Exp(twist s) cam(t) (twist ordered rho, phi).
  Eigen::Matrix<double, 6, 1> twist = Eigen::Matrix<double, 6, 1>::Zero();
  if (previous && time > previous_time && time - previous_time < kMaxAngularVelocityGap) {
    twist = (cam_from_world * previous->Inverse()).Log() / (time - previous_time);
  } else {
    twist.tail<3>() = omega;
  }
  if (twist.isZero()) return pinhole_depth;
  // The colour camera from the depth camera: Exp(twist dt)^-1.
  return WarpDepth(pinhole_depth, camera, Rigid3d::Exp(-twist * depth_dt));
}

PushedFrame CopyPushedFrame(const FrameBuffers& frame, const Rigid3d* cam_from_world, const EngineOptions& options) {
  const int w = options.camera.width, h = options.camera.height;
  DYPHO_CHECK_INPUT(frame.rgb != nullptr) << "PushFrame: FrameBuffers.rgb is null";
  DYPHO_CHECK_INPUT(!(frame.depth && frame.depth_m)) << "PushFrame: give FrameBuffers.depth or depth_m, not both";
  DYPHO_CHECK_INPUT(!(frame.right_rgb && (frame.depth || frame.depth_m)) || frame.keyframe_depth_from_pair)
      << "PushFrame: give FrameBuffers.right_rgb or a depth buffer, not both (unless keyframe_depth_from_pair)";
  DYPHO_CHECK_INPUT(!frame.keyframe_depth_from_pair || (frame.right_rgb && (frame.depth || frame.depth_m)))
      << "PushFrame: FrameBuffers.keyframe_depth_from_pair needs right_rgb and a (preview) depth buffer";
  DYPHO_CHECK_INPUT(!frame.right_rgb || options.stereo_baseline > 0)
      << "PushFrame: FrameBuffers.right_rgb needs EngineOptions.stereo_baseline > 0";
  DYPHO_CHECK_INPUT(std::isfinite(frame.timestamp)) << "PushFrame: FrameBuffers.timestamp is not finite";
  DYPHO_CHECK_INPUT(cam_from_world == nullptr || FinitePose(*cam_from_world))
      << "PushFrame: cam_from_world is not finite";
  DYPHO_CHECK_INPUT(!frame.angular_velocity || frame.angular_velocity->allFinite())
      << "PushFrame: FrameBuffers.angular_velocity is not finite";
  DYPHO_CHECK_INPUT(!frame.depth_timestamp ||
                    (std::isfinite(*frame.depth_timestamp) && std::abs(*frame.depth_timestamp - frame.timestamp) <= 0.1))
      << "PushFrame: FrameBuffers.depth_timestamp must be finite and within 0.1 s of timestamp";
  PushedFrame out;
  out.timestamp = frame.timestamp;
  out.rgb = ImageU8(w, h, 3);
  std::copy(frame.rgb, frame.rgb + out.rgb.size(), out.rgb.data());
  if (frame.depth) {
    // Each of the 65536 raw values converted once per depth scale (the same
    // floats as converting every pixel: 0.14 ms instead of 0.43 ms at 640x480).
    thread_local double lut_scale = 0.0;
    thread_local std::vector<float> lut;
    if (lut.empty() || lut_scale != options.depth_scale) {
      lut.resize(65536);
      for (size_t v = 0; v < lut.size(); ++v) {
        const float d = static_cast<float>(static_cast<uint16_t>(v) / options.depth_scale);
        lut[v] = std::isfinite(d) && d > 0 ? d : 0.0f;
      }
      lut_scale = options.depth_scale;
    }
    out.depth = ImageF(w, h, 1);
    for (size_t i = 0; i < out.depth.size(); ++i) out.depth.data()[i] = lut[frame.depth[i]];
  } else if (frame.depth_m) {
    out.depth = ImageF(w, h, 1);
    for (size_t i = 0; i < out.depth.size(); ++i) {
      const float d = frame.depth_m[i];
      out.depth.data()[i] = std::isfinite(d) && d > 0 ? d : 0.0f;
    }
  }
  if (frame.right_rgb && frame.keyframe_depth_from_pair) {
    out.right = ImageU8(w, h, 3);
    std::copy(frame.right_rgb, frame.right_rgb + out.right.size(), out.right.data());
  } else if (frame.right_rgb) {
    out.depth = StereoDepth(out.rgb, frame.right_rgb, options);
  }
  if (frame.dynamic_mask) {
    out.mask = ImageU8(w, h, 1);
    std::copy(frame.dynamic_mask, frame.dynamic_mask + out.mask.size(), out.mask.data());
  }
  return out;
}

double ResolvePairDepth(KeyframeInput* input, const EngineOptions& options) {
  if (input->right_rgb.empty()) return 0.0;
  double seconds = 0.0;
  input->depth = StereoDepth(input->rgb, input->right_rgb.data(), options, &seconds);
  input->right_rgb = ImageU8();
  return 1000.0 * seconds;
}

KeyframeStoreOptions StoreOptionsFor(const EngineOptions& o) {
  KeyframeStoreOptions s;
  s.raw_capacity = o.queue_capacity;
  s.memory_limit_bytes = static_cast<size_t>(o.waiting_memory_mb * 1048576.0);
  s.spill_dir = o.spill_dir;
  return s;
}

EngineRender RenderForHost(const GaussianCloud& cloud, const Camera& camera, const Rigid3d& cam_from_world,
                           kernels::CompositeMode mode, const EngineOptions& options) {
  kernels::RasterSettings settings;
  settings.mode = mode;
  settings.sh_degree = options.mapper.sh_degree;
  settings.num_threads = options.mapper.num_threads;
  for (float& b : settings.background) b = options.mapper.background;
  const RenderedView view = RenderView(cloud, camera, cam_from_world, settings);
  EngineRender out;
  out.width = camera.width;
  out.height = camera.height;
  out.color = view.color.pixels();
  out.depth = NormalizedDepth(view, 0.5f).pixels();
  out.alpha = view.alpha.pixels();
  return out;
}

std::optional<ImageU8> AskKeyframeMask(const EngineOptions& options, PushedFrame frame) {
  if (!options.keyframe_mask) return std::nullopt;
  const int w = options.camera.width, h = options.camera.height;
  KeyframeMaskRequest request;
  request.timestamp = frame.timestamp;
  request.width = w;
  request.height = h;
  request.rgb = frame.rgb.data();
  request.depth_m = frame.depth.empty() ? nullptr : frame.depth.data();
  request.dynamic_mask = frame.mask.empty() ? nullptr : frame.mask.data();
  const std::vector<uint8_t> extra = options.keyframe_mask(request);
  if (extra.empty()) return std::nullopt;
  DYPHO_CHECK_INPUT(extra.size() == static_cast<size_t>(w) * h)
      << "EngineOptions.keyframe_mask returned " << extra.size() << " values for a " << w << "x" << h << " frame";
  ImageU8 mask = frame.mask.empty() ? ImageU8(w, h, 1, 0) : std::move(frame.mask);
  for (size_t i = 0; i < extra.size(); ++i)
    if (extra[i] != 0) mask.data()[i] = 255;
  return mask;
}

ImageF KeyframeSourceDepth(const Undistorter& undistort, const ImageF& depth, const KeyframeSource& s) {
  return DepthAtColourTime(undistort.Depth(depth), undistort.pinhole(), s.depth_dt, s.previous_pose, s.previous_time,
                           s.cam_from_world, s.timestamp, s.omega);
}

KeyframeInput MakeKeyframeInput(const Undistorter& undistort, KeyframeSource s, bool with_right) {
  KeyframeInput in;
  in.timestamp = s.timestamp;
  in.rgb = undistort.Rgb(s.pushed.rgb);
  in.depth = s.pinhole_depth ? std::move(*s.pinhole_depth) : KeyframeSourceDepth(undistort, s.pushed.depth, s);
  in.dynamic_mask = undistort.ExcludedPixels(s.pushed.mask);
  in.cam_from_world = s.cam_from_world;
  in.features = std::move(s.features);
  in.angular_velocity = s.omega;
  if (with_right) in.right_rgb = std::move(s.pushed.right);
  return in;
}

}  // namespace dypho
