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

// The rotation and translation of a row-major 3x4 [R | t].
template <typename T>
DYPHO_HD inline void SplitPose(const float* cam_from_world, Mat3<T>* rotation, Vec3<T>* translation) {
  const float* m = cam_from_world;
  *rotation = Mat3FromRows<T>(m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]);
  *translation = Vec3<T>(m[3], m[7], m[11]);
}

template <typename T>
DYPHO_HD inline T Sigmoid(T x) {
  return T(1) / (T(1) + exp(-x));
}

template <typename T>
DYPHO_HD inline T Clamp(T x, T lo, T hi) {
  return x < lo ? lo : (x > hi ? hi : x);
}

}  // namespace dypho::kernels::math
