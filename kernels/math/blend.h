// Per-(Gaussian, pixel) math shared by every rasterizer (CPU, CUDA; the GLSL
// shaders mirror it), each beside its VJP.
#pragma once

#include "kernels/math/types.h"

namespace dypho::kernels::math {

constexpr float kMaxAlpha = 0.99f;          // alpha = min(0.99, o exp(power))
constexpr float kMinAlpha = 1.0f / 255.0f;  // contributions below are skipped
constexpr float kMinTransmittance = 1e-4f;  // sorted mode stops below this
constexpr float kMaxSigma2 = 9.0f;          // 3-sigma ellipse

// The screen-space footprint of one projected Gaussian.
template <typename T>
struct SplatT {
  T mean_x, mean_y;  // 2D mean [px]
  T A, B, C;         // conic: sigma^2 = A dx^2 + 2 B dx dy + C dy^2
  T opacity;         // sigmoid(logit)
  T power_min;       // contributes iff power >= power_min
};
using Splat = SplatT<float>;

// Contribution threshold on power = -sigma^2/2: inside the 3-sigma ellipse
// and alpha >= 1/255, i.e. power >= max(-4.5, -log(255 opacity)).
template <typename T>
DYPHO_HD inline T PowerThreshold(T opacity) {
  const T alpha_limit = -log(T(255) * opacity);
  return alpha_limit > T(-0.5f * kMaxSigma2) ? alpha_limit : T(-0.5f * kMaxSigma2);
}

template <typename T>
DYPHO_HD inline T SplatPower(T A, T B, T C, T dx, T dy) {
  return T(-0.5) * (A * dx * dx + C * dy * dy) - B * dx * dy;
}

// alpha for a power that passed the threshold.
template <typename T>
DYPHO_HD inline T SplatAlpha(T opacity, T power) {
  const T a = opacity * ExpNonPositive(power);
  return a < T(kMaxAlpha) ? a : T(kMaxAlpha);
}

// VJP of alpha = min(0.99, o exp(power(conic, mean2d))) at pixel (px, py),
// dx = px - mean_x. Accumulates into the per-Gaussian gradients. The clamp
// at 0.99 has zero derivative.
//   d alpha/d o = G;  d alpha/d power = alpha;
//   d power/dA = -dx^2/2, d power/dB = -dx dy, d power/dC = -dy^2/2;
//   d power/d mean_x = A dx + B dy, d power/d mean_y = B dx + C dy.
template <typename T>
DYPHO_HD inline void SplatAlphaVjpG(T opacity, T G, T A, T B, T C, T dx, T dy, T v_alpha, T* v_opacity, T* v_A,
                                    T* v_B, T* v_C, T* v_mean_x, T* v_mean_y) {
  if (opacity * G >= T(kMaxAlpha)) return;
  const T alpha = opacity * G;
  *v_opacity += G * v_alpha;
  const T v_power = alpha * v_alpha;
  *v_A += T(-0.5) * dx * dx * v_power;
  *v_B += -dx * dy * v_power;
  *v_C += T(-0.5) * dy * dy * v_power;
  *v_mean_x += (A * dx + B * dy) * v_power;
  *v_mean_y += (B * dx + C * dy) * v_power;
}

// The same, computing G = exp(power).
template <typename T>
DYPHO_HD inline void SplatAlphaVjp(T opacity, T power, T A, T B, T C, T dx, T dy, T v_alpha, T* v_opacity,
                                   T* v_A, T* v_B, T* v_C, T* v_mean_x, T* v_mean_y) {
  SplatAlphaVjpG(opacity, ExpNonPositive(power), A, B, C, dx, dy, v_alpha, v_opacity, v_A, v_B, v_C, v_mean_x, v_mean_y);
}

// Does the cut-off ellipse (sigma^2 <= -2 power_min) reach a pixel centre inside the
// rectangle [x0, x1] x [y0, y1]? Exact: the minimum of the positive definite
// quadratic over the rectangle is at the 2D mean when it lies inside, else on
// an edge, where each edge is a 1D quadratic minimised in closed form.
template <typename T>
DYPHO_HD inline bool SplatReachesRect(const SplatT<T>& s, T x0, T y0, T x1, T y1) {
  const T r2 = T(-2) * s.power_min;
  const T dx0 = x0 - s.mean_x, dx1 = x1 - s.mean_x;
  const T dy0 = y0 - s.mean_y, dy1 = y1 - s.mean_y;
  if (dx0 <= 0 && dx1 >= 0 && dy0 <= 0 && dy1 >= 0) return true;
  T best = T(3.0e38f);
  // vertical edges (dx fixed)
  for (int e = 0; e < 2; ++e) {
    const T dx = e ? dx1 : dx0;
    T dy = -s.B * dx / s.C;
    dy = dy < dy0 ? dy0 : (dy > dy1 ? dy1 : dy);
    const T q = s.A * dx * dx + T(2) * s.B * dx * dy + s.C * dy * dy;
    best = q < best ? q : best;
  }
  // horizontal edges (dy fixed)
  for (int e = 0; e < 2; ++e) {
    const T dy = e ? dy1 : dy0;
    T dx = -s.B * dy / s.A;
    dx = dx < dx0 ? dx0 : (dx > dx1 ? dx1 : dx);
    const T q = s.A * dx * dx + T(2) * s.B * dx * dy + s.C * dy * dy;
    best = q < best ? q : best;
  }
  return best <= r2;
}

// The footprint slightly enlarged (power_min' = 1.001 power_min - 0.0005,
// i.e. r2' = 1.001 r2 + 1e-3) for culling: tile lists and pixel spans built
// from it never drop a pixel that passes the exact per-pixel test in float
// rounding; the per-pixel test stays the arbiter. Every backend uses it.
template <typename T>
DYPHO_HD inline T CullingPowerMin(T power_min) {
  return power_min * T(1.001) - T(0.0005);
}

// The cut-off ellipse sigma^2 <= r2 (r2 = -2 power_min) along a line of
// constant dy: dx in [lo, hi], from A dx^2 + 2 B dy dx + C dy^2 - r2 = 0:
// dx = (-B dy +- sqrt(A r2 - det dy^2)) / A with det = A C - B^2.
// Returns false when the line misses the ellipse.
template <typename T>
DYPHO_HD inline bool EllipseSpanAt(const SplatT<T>& s, T r2, T det, T inv_a, T dy, T* lo, T* hi) {
  const T disc = s.A * r2 - det * dy * dy;
  if (disc < T(0)) return false;
  const T root = sqrt(disc);
  *lo = (-s.B * dy - root) * inv_a;
  *hi = (-s.B * dy + root) * inv_a;
  return true;
}
template <typename T>
DYPHO_HD inline bool EllipseSpanAt(const SplatT<T>& s, T dy, T* lo, T* hi) {
  return EllipseSpanAt(s, T(-2) * s.power_min, s.A * s.C - s.B * s.B, T(1) / s.A, dy, lo, hi);
}

// Per-ellipse constants of EllipseBandExtent, so a caller that asks for many
// bands of one ellipse computes them once (same values either way).
template <typename T>
struct EllipseExtents {
  T r2, det, inv_a;   // -2 power_min, A C - B^2, 1 / A
  T y_ext, x_ext;        // |dy| <= y_ext and |dx| <= x_ext on the ellipse
  T dy_right, dy_left;   // dy of its rightmost and leftmost points
};
template <typename T>
DYPHO_HD inline EllipseExtents<T> MakeEllipseExtents(const SplatT<T>& s) {
  EllipseExtents<T> k;
  k.r2 = T(-2) * s.power_min;
  k.det = s.A * s.C - s.B * s.B;
  k.inv_a = T(1) / s.A;
  k.y_ext = sqrt(k.r2 * s.A / k.det);
  k.x_ext = sqrt(k.r2 * s.C / k.det);
  // B dx + C dy = 0 with dx = +x_ext (rightmost) and -x_ext (leftmost).
  k.dy_right = -s.B * k.x_ext / s.C;
  k.dy_left = s.B * k.x_ext / s.C;
  return k;
}

// The x-extent [lo, hi] (relative to the mean) of the cut-off ellipse inside
// the band dy in [dy0, dy1]. The band's slice of the ellipse is convex, the
// right end hi(dy) is concave and the left end lo(dy) convex, so each extreme
// is at the ellipse's own extreme point when that lies in the band, else at
// the nearer band edge. Returns false when the band misses the ellipse.
template <typename T>
DYPHO_HD inline bool EllipseBandExtent(const SplatT<T>& s, const EllipseExtents<T>& k, T dy0, T dy1, T* lo,
                                       T* hi) {
  if (dy1 < -k.y_ext || dy0 > k.y_ext) return false;
  const T dy_right = Clamp(k.dy_right, dy0, dy1);
  const T dy_left = Clamp(k.dy_left, dy0, dy1);
  T l0, h0, l1, h1;
  const bool ok_r = EllipseSpanAt(s, k.r2, k.det, k.inv_a, Clamp(dy_right, -k.y_ext, k.y_ext), &l0, &h0);
  const bool ok_l = EllipseSpanAt(s, k.r2, k.det, k.inv_a, Clamp(dy_left, -k.y_ext, k.y_ext), &l1, &h1);
  if (!ok_r || !ok_l) {
    // Rounding at the tangent points: fall back to the ellipse's full extent.
    *lo = -k.x_ext;
    *hi = k.x_ext;
    return true;
  }
  *hi = h0;
  *lo = l1;
  return true;
}
template <typename T>
DYPHO_HD inline bool EllipseBandExtent(const SplatT<T>& s, T dy0, T dy1, T* lo, T* hi) {
  return EllipseBandExtent(s, MakeEllipseExtents(s), dy0, dy1, lo, hi);
}

// ---------------------------------------------------------------------------
// Sorted compositing, backward, in front-to-back order. With w_i = alpha_i T_i,
// colour C = sum w_i c_i + T_N bg, depth D = sum w_i z_i, alpha_out = 1 - T_N.
// S_C = sum_{j>i} w_j c_j + T_N bg = C - sum_{j<=i} w_j c_j (likewise S_D):
//   dC/dalpha_i = T_i c_i - S_C / (1 - alpha_i)
//   dD/dalpha_i = T_i z_i - S_D / (1 - alpha_i)
//   dalpha_out/dalpha_i = T_N / (1 - alpha_i)
template <typename T>
DYPHO_HD inline T SortedAlphaGrad(T alpha, T transmittance, const Vec3<T>& color, T z, const Vec3<T>& suffix_color,
                                  T suffix_depth, T final_transmittance, const Vec3<T>& v_color, T v_depth,
                                  T v_alpha_out) {
  const T inv = T(1) / (T(1) - alpha);
  return glm::dot(v_color, transmittance * color - suffix_color * inv) +
         v_depth * (transmittance * z - suffix_depth * inv) + v_alpha_out * final_transmittance * inv;
}

// ---------------------------------------------------------------------------
// Order-independent compositing: the depth weight of McGuire & Bavoil (2013),
// eq. 7, with z in metres: f(z) = clamp(10 / (1e-5 + (z/5)^2 + (z/200)^6), 1e-2, 3e3).
template <typename T>
DYPHO_HD inline T OitWeight(T z, T* dfdz) {
  const T a = z / T(5), b = z / T(200);
  const T b3 = b * b * b;
  const T denom = T(1e-5) + a * a + b3 * b3;
  const T f = T(10) / denom;
  if (f < T(1e-2)) {
    *dfdz = T(0);
    return T(1e-2);
  }
  if (f > T(3e3)) {
    *dfdz = T(0);
    return T(3e3);
  }
  // d denom/dz = 2a/5 + 6 b^5/200
  *dfdz = -T(10) * (T(2) * a / T(5) + T(6) * b3 * b * b / T(200)) / (denom * denom);
  return f;
}

// Per pixel: A = sum alpha_i f_i, P = prod (1 - alpha_i), Cbar = sum alpha_i f_i c_i / A,
// Dbar = sum alpha_i f_i z_i / A; C = Cbar (1 - P) + P bg, D = Dbar (1 - P), alpha = 1 - P.
//   dC/dc_i = alpha_i f_i / A (1 - P)
//   dC/dalpha_i = (c_i - Cbar) f_i / A (1 - P) + (Cbar - bg) P / (1 - alpha_i)
//   dC/dz_i = (c_i - Cbar) alpha_i f'_i / A (1 - P)
//   dD/dalpha_i = (z_i - Dbar) f_i / A (1 - P) + Dbar P / (1 - alpha_i)
//   dD/dz_i = alpha_i f_i / A (1 - P) + (z_i - Dbar) alpha_i f'_i / A (1 - P)
//   dalpha/dalpha_i = P / (1 - alpha_i)
template <typename T>
DYPHO_HD inline void OitPixelVjp(T alpha, const Vec3<T>& color, T z, T f, T dfdz, T sum_weight, T prod_transmit,
                                 const Vec3<T>& mean_color, T mean_depth, const Vec3<T>& background,
                                 const Vec3<T>& v_color, T v_depth, T v_alpha_out, Vec3<T>* v_c, T* v_alpha,
                                 T* v_z) {
  const T K = T(1) - prod_transmit;
  const T inv_a = T(1) / (T(1) - alpha);
  const T fa = f / sum_weight * K;
  const T dc = glm::dot(v_color, color - mean_color);
  *v_c += alpha * fa * v_color;
  *v_alpha += dc * fa + glm::dot(v_color, mean_color - background) * prod_transmit * inv_a +
              v_depth * ((z - mean_depth) * fa + mean_depth * prod_transmit * inv_a) +
              v_alpha_out * prod_transmit * inv_a;
  const T dfa = alpha * dfdz / sum_weight * K;
  *v_z += dc * dfa + v_depth * (alpha * fa + (z - mean_depth) * dfa);
}

// ---------------------------------------------------------------------------
// Camera pose gradient. Given dL/dR and dL/dt of cam_from_world = [R | t],
// the gradient with respect to a left twist xi = (rho, phi),
// [R' | t'] = exp(xi) [R | t] ~ [(I + [phi]x) R | t + rho + [phi]x t]:
//   v_rho = v_t;  with N = R v_R^T + t v_t^T,  dL = tr(N [phi]x), so
//   v_phi = (N12 - N21, N20 - N02, N01 - N10).
template <typename T>
DYPHO_HD inline void PoseGradToTwist(const Mat3<T>& R, const Vec3<T>& t, const Mat3<T>& v_R, const Vec3<T>& v_t,
                                     T v_twist[6]) {
  const Mat3<T> N = R * glm::transpose(v_R) + glm::outerProduct(t, v_t);
  // N(row i, col j) = N[j][i]
  v_twist[0] = v_t.x;
  v_twist[1] = v_t.y;
  v_twist[2] = v_t.z;
  v_twist[3] = N[2][1] - N[1][2];
  v_twist[4] = N[0][2] - N[2][0];
  v_twist[5] = N[1][0] - N[0][1];
}

// Camera centre c = -R^T t and its VJP (accumulated into v_R, v_t):
//   v_R += -t v_c^T,  v_t += -R v_c.
template <typename T>
DYPHO_HD inline Vec3<T> CameraCenter(const Mat3<T>& R, const Vec3<T>& t) {
  return -(glm::transpose(R) * t);
}
template <typename T>
DYPHO_HD inline void CameraCenterVjp(const Mat3<T>& R, const Vec3<T>& t, const Vec3<T>& v_c, Mat3<T>* v_R,
                                     Vec3<T>* v_t) {
  *v_R -= glm::outerProduct(t, v_c);
  *v_t -= R * v_c;
}

}  // namespace dypho::kernels::math
