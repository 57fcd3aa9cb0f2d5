// Host+device scalar and matrix types for the rasterizer math. Every function
// in kernels/math is `DYPHO_HD inline` and templated on the scalar type, so
// the CPU backend (float), the CUDA kernels (float) and the finite-difference
// tests (double) all run the same code.
//
// Matrices are GLM types: glm::mat<C, R, T> has C columns and R rows and is
// indexed m[column][row]. `Row(m, i, j)` reads row i, column j.
#pragma once

#if defined(__CUDACC__)
#define DYPHO_HD __host__ __device__
#else
#define DYPHO_HD
#endif

#include <cmath>
#include <cstdint>
#include <cstring>

#include <glm/glm.hpp>

namespace dypho::kernels::math {

#if !defined(__CUDACC__)
using std::ceil;
using std::exp;
using std::floor;

using std::isfinite;
using std::log;
using std::sqrt;
#endif

template <typename T> using Vec2 = glm::vec<2, T, glm::defaultp>;
template <typename T> using Vec3 = glm::vec<3, T, glm::defaultp>;
template <typename T> using Mat2 = glm::mat<2, 2, T, glm::defaultp>;
template <typename T> using Mat3 = glm::mat<3, 3, T, glm::defaultp>;
// 2 rows, 3 columns (the Jacobian of the perspective projection).
template <typename T> using Mat2x3 = glm::mat<3, 2, T, glm::defaultp>;

// Row-major construction (GLM's constructors take columns).
template <typename T>
DYPHO_HD inline Mat3<T> Mat3FromRows(T a00, T a01, T a02, T a10, T a11, T a12, T a20, T a21,
                                     T a22) {
  return Mat3<T>(a00, a10, a20, a01, a11, a21, a02, a12, a22);
}

// exp for the per-pixel alpha, identical on every backend and vectorizable
// on the CPU (no libm call): exp(x) = 2^n exp(r) with n = round(x / ln 2),
// r = x - n ln 2 (Cody-Waite split of ln 2, |r| <= 0.347) and a degree-7
// Taylor polynomial for exp(r) (truncation error < 6e-9 relative).
// x is clamped to [-87, 0] (alpha only needs powers <= 0). Double precision
// (the finite-difference tests) uses the exact exp.
DYPHO_HD inline float FloatFromBits(int32_t bits) {
#if defined(__CUDA_ARCH__)
  return __int_as_float(bits);
#else
  float f;
  std::memcpy(&f, &bits, sizeof(f));
  return f;
#endif
}
DYPHO_HD inline int32_t BitsFromFloat(float f) {
#if defined(__CUDA_ARCH__)
  return __float_as_int(f);
#else
  int32_t bits;
  std::memcpy(&bits, &f, sizeof(bits));
  return bits;
#endif
}

// floor(y) for |y| < 2^22 (also as an integer) from float additions only:
// adding and subtracting 1.5 * 2^23 rounds to the nearest integer, a step
// down fixes the rounding up. Unlike floorf and a float-to-int conversion,
// this keeps the CPU loops that call ExpNonPositive vectorizable by GCC
// without -fno-trapping-math. The same values as floorf (checked for every
// float the clamped exponent below can take).
DYPHO_HD inline float FloorSmall(float y, int32_t* as_int) {
  constexpr float kShift = 12582912.0f;  // 1.5 * 2^23, bits 0x4B400000
  float n = (y + kShift) - kShift;
  n = n > y ? n - 1.0f : n;
  *as_int = BitsFromFloat(n + kShift) - 0x4B400000;
  return n;
}

DYPHO_HD inline float ExpNonPositive(float x) {
  // The clamp on the bits, with integer min/and: float selects or fminf
  // keep GCC from vectorizing the callers' loops (or make it duplicate the
  // polynomial). Unsigned, every x below -87 (sign set, larger magnitude) has
  // larger bits than -87 (0xC2AE0000) and every x >= 0 smaller ones; then
  // the sign mask zeroes x > 0.
  uint32_t bits = static_cast<uint32_t>(BitsFromFloat(x));
  bits = bits < 0xC2AE0000u ? bits : 0xC2AE0000u;
  bits &= static_cast<uint32_t>(static_cast<int32_t>(bits) >> 31);
  x = FloatFromBits(static_cast<int32_t>(bits));
  int32_t n_int;
  const float n = FloorSmall(x * 1.44269504088896341f + 0.5f, &n_int);
  const float r = (x - n * 0.693145751953125f) - n * 1.42860682030941723e-6f;
  float p = 1.0f / 5040.0f;
  p = p * r + 1.0f / 720.0f;
  p = p * r + 1.0f / 120.0f;
  p = p * r + 1.0f / 24.0f;
  p = p * r + 1.0f / 6.0f;
  p = p * r + 0.5f;
  p = p * r + 1.0f;
  p = p * r + 1.0f;
  return p * FloatFromBits((n_int + 127) << 23);
}
DYPHO_HD inline double ExpNonPositive(double x) { return exp(x); }

template <typename T>
DYPHO_HD inline T Sigmoid(T x) {
  return T(1) / (T(1) + exp(-x));
}

template <typename T>
DYPHO_HD inline T Clamp(T x, T lo, T hi) {
  return x < lo ? lo : (x > hi ? hi : x);
}

}  // namespace dypho::kernels::math
