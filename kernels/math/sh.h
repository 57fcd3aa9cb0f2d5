// View-dependent colour from real spherical harmonics of degree 0..3, beside
// its VJP. Basis constants are the standard real SH normalisations (as in
// Kerbl et al. 2023 and Sloan 2008, "Stupid Spherical Harmonics Tricks").
// colour = max(0, sum_k Y_k(d) sh_k + 0.5), d = (mean - camera centre) / |.|.
#pragma once

#include "kernels/math/types.h"

namespace dypho::kernels::math {

// Number of coefficients per channel for a degree.
DYPHO_HD inline int ShCoeffsForDegree(int degree) { return (degree + 1) * (degree + 1); }

// Basis values Y[k] and their gradients with respect to the unit direction
// d = (x, y, z) (treating x, y, z as independent), for k < (degree+1)^2.
template <typename T>
DYPHO_HD inline void ShBasis(int degree, T x, T y, T z, T Y[16], Vec3<T> dY[16]) {
  const T C0 = T(0.28209479177387814);
  const T C1 = T(0.4886025119029199);
  const T C2[5] = {T(1.0925484305920792), T(-1.0925484305920792), T(0.31539156525252005),
                   T(-1.0925484305920792), T(0.5462742152960396)};
  const T C3[7] = {T(-0.5900435899266435), T(2.890611442640554), T(-0.4570457994644658),
                   T(0.3731763325901154), T(-0.4570457994644658), T(1.445305721320277),
                   T(-0.5900435899266435)};
  Y[0] = C0;
  dY[0] = Vec3<T>(T(0));
  if (degree < 1) return;
  Y[1] = -C1 * y;  dY[1] = Vec3<T>(T(0), -C1, T(0));
  Y[2] = C1 * z;   dY[2] = Vec3<T>(T(0), T(0), C1);
  Y[3] = -C1 * x;  dY[3] = Vec3<T>(-C1, T(0), T(0));
  if (degree < 2) return;
  const T xx = x * x, yy = y * y, zz = z * z;
  Y[4] = C2[0] * x * y;                 dY[4] = Vec3<T>(C2[0] * y, C2[0] * x, T(0));
  Y[5] = C2[1] * y * z;                 dY[5] = Vec3<T>(T(0), C2[1] * z, C2[1] * y);
  Y[6] = C2[2] * (T(2) * zz - xx - yy); dY[6] = Vec3<T>(-T(2) * C2[2] * x, -T(2) * C2[2] * y, T(4) * C2[2] * z);
  Y[7] = C2[3] * x * z;                 dY[7] = Vec3<T>(C2[3] * z, T(0), C2[3] * x);
  Y[8] = C2[4] * (xx - yy);             dY[8] = Vec3<T>(T(2) * C2[4] * x, -T(2) * C2[4] * y, T(0));
  if (degree < 3) return;
  Y[9] = C3[0] * y * (T(3) * xx - yy);
  dY[9] = Vec3<T>(T(6) * C3[0] * x * y, C3[0] * (T(3) * xx - T(3) * yy), T(0));
  Y[10] = C3[1] * x * y * z;
  dY[10] = Vec3<T>(C3[1] * y * z, C3[1] * x * z, C3[1] * x * y);
  Y[11] = C3[2] * y * (T(4) * zz - xx - yy);
  dY[11] = Vec3<T>(-T(2) * C3[2] * x * y, C3[2] * (T(4) * zz - xx - T(3) * yy), T(8) * C3[2] * y * z);
  Y[12] = C3[3] * z * (T(2) * zz - T(3) * xx - T(3) * yy);
  dY[12] = Vec3<T>(-T(6) * C3[3] * x * z, -T(6) * C3[3] * y * z, C3[3] * (T(6) * zz - T(3) * xx - T(3) * yy));
  Y[13] = C3[4] * x * (T(4) * zz - xx - yy);
  dY[13] = Vec3<T>(C3[4] * (T(4) * zz - T(3) * xx - yy), -T(2) * C3[4] * x * y, T(8) * C3[4] * x * z);
  Y[14] = C3[5] * z * (xx - yy);
  dY[14] = Vec3<T>(T(2) * C3[5] * x * z, -T(2) * C3[5] * y * z, C3[5] * (xx - yy));
  Y[15] = C3[6] * x * (xx - T(3) * yy);
  dY[15] = Vec3<T>(C3[6] * (T(3) * xx - T(3) * yy), -T(6) * C3[6] * x * y, T(0));
}

// sh: [K, 3] coefficients of one Gaussian (K = coefficients stored). `degree`
// is the active degree (<= what K holds). Writes the clamped colour and, per
// channel, whether it was clamped (bit c set).
template <typename T, typename ShT>
DYPHO_HD inline Vec3<T> ShToColor(int degree, const ShT* sh, const Vec3<T>& mean, const Vec3<T>& cam_center,
                                  unsigned* clamped) {
  const Vec3<T> raw_dir = mean - cam_center;
  const Vec3<T> d = raw_dir / sqrt(glm::dot(raw_dir, raw_dir));
  T Y[16];
  Vec3<T> dY[16];
  ShBasis(degree, d.x, d.y, d.z, Y, dY);
  Vec3<T> color(T(0.5));
  const int K = ShCoeffsForDegree(degree);
  for (int k = 0; k < K; ++k) {
    color += Y[k] * Vec3<T>(T(sh[3 * k]), T(sh[3 * k + 1]), T(sh[3 * k + 2]));
  }
  unsigned mask = 0;
  for (int c = 0; c < 3; ++c) {
    if (color[c] < T(0)) {
      color[c] = T(0);
      mask |= 1u << c;
    }
  }
  *clamped = mask;
  return color;
}

// VJP: v_color -> v_sh (written for the K active coefficients), v_mean and
// v_cam_center (accumulated). d = r / |r|, v_r = (v_d - d (d . v_d)) / |r|.
template <typename T, typename ShT>
DYPHO_HD inline void ShToColorVjp(int degree, const ShT* sh, const Vec3<T>& mean, const Vec3<T>& cam_center,
                                  unsigned clamped, Vec3<T> v_color, T* v_sh, Vec3<T>* v_mean,
                                  Vec3<T>* v_cam_center) {
  for (int c = 0; c < 3; ++c) {
    if (clamped & (1u << c)) v_color[c] = T(0);
  }
  const Vec3<T> raw_dir = mean - cam_center;
  const T len = sqrt(glm::dot(raw_dir, raw_dir));
  const Vec3<T> d = raw_dir / len;
  T Y[16];
  Vec3<T> dY[16];
  ShBasis(degree, d.x, d.y, d.z, Y, dY);
  const int K = ShCoeffsForDegree(degree);
  Vec3<T> v_d(T(0));
  for (int k = 0; k < K; ++k) {
    v_sh[3 * k] = Y[k] * v_color.x;
    v_sh[3 * k + 1] = Y[k] * v_color.y;
    v_sh[3 * k + 2] = Y[k] * v_color.z;
    if (k > 0) {
      const T s = T(sh[3 * k]) * v_color.x + T(sh[3 * k + 1]) * v_color.y + T(sh[3 * k + 2]) * v_color.z;
      v_d += s * dY[k];
    }
  }
  const Vec3<T> v_r = (v_d - d * glm::dot(d, v_d)) / len;
  *v_mean += v_r;
  *v_cam_center -= v_r;
}

}  // namespace dypho::kernels::math
