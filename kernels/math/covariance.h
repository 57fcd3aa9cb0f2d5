// World-space covariance from rotation and scale, beside its VJP.
//   R = R(q / |q|),  M = R S,  S = diag(exp(log_scale)),  Sigma = M M^T.
#pragma once

#include "kernels/math/types.h"

namespace dypho::kernels::math {

// q = (w, x, y, z), not necessarily normalised.
template <typename T>
DYPHO_HD inline Mat3<T> QuatToRotmat(const T q[4]) {
  const T inv = T(1) / sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  const T w = q[0] * inv, x = q[1] * inv, y = q[2] * inv, z = q[3] * inv;
  return Mat3FromRows<T>(T(1) - T(2) * (y * y + z * z), T(2) * (x * y - w * z), T(2) * (x * z + w * y),
                         T(2) * (x * y + w * z), T(1) - T(2) * (x * x + z * z), T(2) * (y * z - w * x),
                         T(2) * (x * z - w * y), T(2) * (y * z + w * x), T(1) - T(2) * (x * x + y * y));
}

// VJP: v_R (dL/dR_ij, any matrix) -> v_q. Derivatives of each R_ij with
// respect to the normalised (w, x, y, z), then through n = q / |q|:
// v_q = (v_n - n (n . v_n)) / |q|.
template <typename T>
DYPHO_HD inline void QuatToRotmatVjp(const T q[4], const Mat3<T>& v_R, T v_q[4]) {
  const T norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  const T w = q[0] / norm, x = q[1] / norm, y = q[2] / norm, z = q[3] / norm;
  // vij = dL/dR(row i, col j)
  const T v00 = v_R[0][0], v01 = v_R[1][0], v02 = v_R[2][0];
  const T v10 = v_R[0][1], v11 = v_R[1][1], v12 = v_R[2][1];
  const T v20 = v_R[0][2], v21 = v_R[1][2], v22 = v_R[2][2];
  const T vw = T(2) * (-z * v01 + y * v02 + z * v10 - x * v12 - y * v20 + x * v21);
  const T vx = T(2) * (y * v01 + z * v02 + y * v10 - T(2) * x * v11 - w * v12 + z * v20 + w * v21 -
                       T(2) * x * v22);
  const T vy = T(2) * (-T(2) * y * v00 + x * v01 + w * v02 + x * v10 + z * v12 - w * v20 + z * v21 -
                       T(2) * y * v22);
  const T vz = T(2) * (-T(2) * z * v00 - w * v01 + x * v02 + w * v10 - T(2) * z * v11 + y * v12 +
                       x * v20 + y * v21);
  const T dot = w * vw + x * vx + y * vy + z * vz;
  v_q[0] = (vw - w * dot) / norm;
  v_q[1] = (vx - x * dot) / norm;
  v_q[2] = (vy - y * dot) / norm;
  v_q[3] = (vz - z * dot) / norm;
}

template <typename T>
DYPHO_HD inline Mat3<T> QuatScaleToCovariance(const T q[4], const T log_scale[3]) {
  const Mat3<T> R = QuatToRotmat(q);
  Mat3<T> M = R;
  for (int j = 0; j < 3; ++j) M[j] *= exp(log_scale[j]);  // column j scaled by s_j
  return M * glm::transpose(M);
}

// VJP: v_Sigma (dL/dSigma_ij treating entries as independent) -> v_q, v_log_scale.
//   dSigma = dM M^T + M dM^T  =>  v_M = (v_Sigma + v_Sigma^T) M
//   M = R S  =>  v_R = v_M S,  v_s_j = sum_i v_M_ij R_ij,  v_log_s_j = v_s_j s_j.
template <typename T>
DYPHO_HD inline void QuatScaleToCovarianceVjp(const T q[4], const T log_scale[3],
                                              const Mat3<T>& v_sigma, T v_q[4], T v_log_scale[3]) {
  const Mat3<T> R = QuatToRotmat(q);
  Mat3<T> M = R;
  T s[3];
  for (int j = 0; j < 3; ++j) {
    s[j] = exp(log_scale[j]);
    M[j] *= s[j];
  }
  const Mat3<T> v_M = (v_sigma + glm::transpose(v_sigma)) * M;
  Mat3<T> v_R = v_M;
  for (int j = 0; j < 3; ++j) {
    v_R[j] *= s[j];
    v_log_scale[j] = glm::dot(v_M[j], R[j]) * s[j];
  }
  QuatToRotmatVjp(q, v_R, v_q);
}

}  // namespace dypho::kernels::math
