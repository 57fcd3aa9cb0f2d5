// Per-Gaussian preprocessing shared by all backends: parameters -> screen
// footprint, colour and depth (forward), and the reverse chain (VJP) from the
// per-Gaussian screen-space gradients back to the parameters and the pose.
#pragma once

#include "kernels/math/blend.h"
#include "kernels/math/covariance.h"
#include "kernels/math/projection.h"
#include "kernels/math/sh.h"
#include "kernels/math/types.h"

namespace dypho::kernels::math {

// Camera constants for one render, in the scalar type of the computation.
template <typename T>
struct CameraData {
  Mat3<T> R;          // cam_from_world rotation
  Vec3<T> t;          // cam_from_world translation
  Vec3<T> center;     // camera centre in world coordinates
  T fx, fy, cx, cy;   // [px]
  int width, height;  // [px]
  int tiles_x, tiles_y;
  ProjectionLimits limits;
  T near_plane, far_plane, low_pass;
  int sh_degree;      // active degree, already clipped to the stored coefficients
};

template <typename T>
struct Projected {
  SplatT<T> splat;
  T color[3];
  T depth;             // camera z of the mean [m]
  int radius;          // 3-sigma radius [px]
  int tile_x0, tile_y0, tile_x1, tile_y1;  // touched tiles, [x0, x1) x [y0, y1)
  unsigned clamped;    // colour channels clamped at 0 (bit per channel)
};

enum ProjectStatus : int { kVisible = 0, kCulled = 1, kNonFinite = 2 };

template <typename T>
DYPHO_HD inline bool AllFinite(const T* v, int n) {
  for (int i = 0; i < n; ++i) {
    if (!isfinite(v[i])) return false;
  }
  return true;
}

// Forward for Gaussian i. Returns kVisible and fills `out`, or why it is not
// drawn.
template <typename T>
DYPHO_HD inline int ProjectGaussian(int i, const T* means, const T* log_scales, const T* quats,
                                    const T* opacity_logits, const T* sh, int sh_coeffs,
                                    const CameraData<T>& cam, Projected<T>* out) {
  const T* m = means + 3 * i;
  const T* ls = log_scales + 3 * i;
  const T* q = quats + 4 * i;
  const T* shi = sh + 3 * sh_coeffs * i;
  const int active = ShCoeffsForDegree(cam.sh_degree);
  if (!AllFinite(m, 3) || !AllFinite(ls, 3) || !AllFinite(q, 4) || !isfinite(opacity_logits[i]) ||
      !AllFinite(shi, 3 * active)) {
    return kNonFinite;
  }
  const T qn2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
  if (!(qn2 > T(1e-24))) return kNonFinite;  // a zero quaternion has no rotation
  const T opacity = Sigmoid(opacity_logits[i]);
  if (!(opacity >= T(kMinAlpha))) return kCulled;  // can never reach alpha 1/255

  const Vec3<T> mean(m[0], m[1], m[2]);
  const Mat3<T> sigma = QuatScaleToCovariance(q, ls);
  Vec3<T> mean_c;
  Mat3<T> sigma_c;
  TransformToCamera(cam.R, cam.t, mean, sigma, &mean_c, &sigma_c);
  if (!(mean_c.z >= cam.near_plane && mean_c.z <= cam.far_plane)) return kCulled;

  Vec2<T> mean2d;
  Mat2<T> cov2d;
  PerspectiveProject(mean_c, sigma_c, cam.fx, cam.fy, cam.cx, cam.cy, cam.limits, &mean2d, &cov2d);
  Mat2<T> conic(T(0));
  if (!DilatedConic(cov2d, cam.low_pass, &conic)) return kCulled;
  const int radius = Radius3Sigma(cov2d, cam.low_pass);
  if (!(radius > 0)) return kCulled;
  // Pixel centres are at integer coordinates: tile t holds [16 t, 16 t + 15].
  const T r = T(radius);
  // A NaN mean passes the comparisons below; its tile range would be undefined.
  if (!isfinite(mean2d.x) || !isfinite(mean2d.y)) return kCulled;
  if (mean2d.x + r < T(0) || mean2d.x - r > T(cam.width - 1) || mean2d.y + r < T(0) ||
      mean2d.y - r > T(cam.height - 1)) {
    return kCulled;
  }
  const int x0 = static_cast<int>(floor((mean2d.x - r) / T(16)));
  const int x1 = static_cast<int>(floor((mean2d.x + r) / T(16))) + 1;
  const int y0 = static_cast<int>(floor((mean2d.y - r) / T(16)));
  const int y1 = static_cast<int>(floor((mean2d.y + r) / T(16))) + 1;
  out->tile_x0 = x0 < 0 ? 0 : x0;
  out->tile_y0 = y0 < 0 ? 0 : y0;
  out->tile_x1 = x1 > cam.tiles_x ? cam.tiles_x : x1;
  out->tile_y1 = y1 > cam.tiles_y ? cam.tiles_y : y1;
  if (out->tile_x0 >= out->tile_x1 || out->tile_y0 >= out->tile_y1) return kCulled;

  out->splat.mean_x = mean2d.x;
  out->splat.mean_y = mean2d.y;
  out->splat.A = conic[0][0];
  out->splat.B = conic[1][0];
  out->splat.C = conic[1][1];
  out->splat.opacity = opacity;
  out->splat.power_min = PowerThreshold(opacity);
  out->depth = mean_c.z;
  out->radius = radius;
  const Vec3<T> color = ShToColor(cam.sh_degree, shi, mean, cam.center, &out->clamped);
  out->color[0] = color.x;
  out->color[1] = color.y;
  out->color[2] = color.z;
  return kVisible;
}

// Per-Gaussian gradients collected by the rasterizer's backward pass.
template <typename T>
struct ScreenGrads {
  T v_mean_x, v_mean_y;  // dL/d mean2d
  T v_A, v_B, v_C;       // dL/d conic entries (B counted once: sigma^2 uses 2B)
  T v_color[3];
  T v_opacity;
  T v_depth;             // dL/d camera z of the mean
};

// Reverse of ProjectGaussian for a visible Gaussian. Writes v_mean[3],
// v_log_scale[3], v_quat[4], v_logit, v_sh[3K] (the K active coefficients;
// the caller zeroes the rest) and accumulates dL/dR, dL/dt of cam_from_world.
template <typename T>
DYPHO_HD inline void ProjectGaussianVjp(int i, const T* means, const T* log_scales, const T* quats,
                                        const T* opacity_logits, const T* sh, int sh_coeffs,
                                        const CameraData<T>& cam, unsigned clamped, const ScreenGrads<T>& g,
                                        T* v_mean, T* v_log_scale, T* v_quat, T* v_logit, T* v_sh,
                                        Mat3<T>* v_R, Vec3<T>* v_t) {
  const T* m = means + 3 * i;
  const T* ls = log_scales + 3 * i;
  const T* q = quats + 4 * i;
  const T* shi = sh + 3 * sh_coeffs * i;
  const Vec3<T> mean(m[0], m[1], m[2]);
  const Mat3<T> sigma = QuatScaleToCovariance(q, ls);
  Vec3<T> mean_c;
  Mat3<T> sigma_c;
  TransformToCamera(cam.R, cam.t, mean, sigma, &mean_c, &sigma_c);
  Vec2<T> mean2d;
  Mat2<T> cov2d;
  PerspectiveProject(mean_c, sigma_c, cam.fx, cam.fy, cam.cx, cam.cy, cam.limits, &mean2d, &cov2d);
  Mat2<T> conic(T(0));
  DilatedConic(cov2d, cam.low_pass, &conic);

  // conic entries -> symmetric matrix gradient (B appears twice in sigma^2)
  Mat2<T> v_conic;
  v_conic[0][0] = g.v_A;
  v_conic[1][1] = g.v_C;
  v_conic[1][0] = v_conic[0][1] = T(0.5) * g.v_B;
  const Mat2<T> v_cov2d = DilatedConicVjp(conic, v_conic);
  Vec3<T> v_mean_c(T(0), T(0), g.v_depth);
  Mat3<T> v_sigma_c;
  PerspectiveProjectVjp(mean_c, sigma_c, cam.fx, cam.fy, cam.limits, Vec2<T>(g.v_mean_x, g.v_mean_y), v_cov2d,
                        &v_mean_c, &v_sigma_c);
  Vec3<T> v_mean_w;
  Mat3<T> v_sigma;
  TransformToCameraVjp(cam.R, mean, sigma, v_mean_c, v_sigma_c, &v_mean_w, &v_sigma, v_R, v_t);
  QuatScaleToCovarianceVjp(q, ls, v_sigma, v_quat, v_log_scale);

  Vec3<T> v_center(T(0));
  ShToColorVjp(cam.sh_degree, shi, mean, cam.center, clamped, Vec3<T>(g.v_color[0], g.v_color[1], g.v_color[2]),
               v_sh, &v_mean_w, &v_center);
  CameraCenterVjp(cam.R, cam.t, v_center, v_R, v_t);

  v_mean[0] = v_mean_w.x;
  v_mean[1] = v_mean_w.y;
  v_mean[2] = v_mean_w.z;
  const T opacity = Sigmoid(opacity_logits[i]);
  *v_logit = g.v_opacity * opacity * (T(1) - opacity);
}

// Camera constants from the public camera and settings.
template <typename T, typename Settings, typename Camera>
inline CameraData<T> MakeCameraData(const Camera& camera, const Settings& settings, int sh_coeffs) {
  CameraData<T> c;
  const double* m = camera.cam_from_world;
  c.R = Mat3FromRows<T>(T(m[0]), T(m[1]), T(m[2]), T(m[4]), T(m[5]), T(m[6]), T(m[8]), T(m[9]), T(m[10]));
  c.t = Vec3<T>(T(m[3]), T(m[7]), T(m[11]));
  c.center = CameraCenter(c.R, c.t);
  c.fx = T(camera.fx);
  c.fy = T(camera.fy);
  c.cx = T(camera.cx);
  c.cy = T(camera.cy);
  c.width = camera.width;
  c.height = camera.height;
  c.tiles_x = (camera.width + 15) / 16;
  c.tiles_y = (camera.height + 15) / 16;
  c.limits = MakeProjectionLimits(float(camera.fx), float(camera.fy), float(camera.cx), float(camera.cy),
                                  camera.width, camera.height);
  c.near_plane = T(settings.near_plane);
  c.far_plane = T(settings.far_plane);
  c.low_pass = T(settings.low_pass);
  int degree = settings.sh_degree;
  while (degree > 0 && ShCoeffsForDegree(degree) > sh_coeffs) --degree;
  c.sh_degree = degree < 0 ? 0 : degree;
  return c;
}

}  // namespace dypho::kernels::math
