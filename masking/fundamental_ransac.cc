#include "masking/fundamental_ransac.h"

#include <algorithm>
#include <cfloat>
#include <cmath>

#include <Eigen/Dense>

namespace dypho {
namespace {

using Mat3 = Eigen::Matrix3d;

// Hartley's normalisation: the points moved to their centroid and scaled
// to a mean distance of sqrt(2). Returns T (x_normalised = T x).
Mat3 Normalise(const std::vector<cv::Point2f>& p, std::vector<Eigen::Vector2d>* out) {
  const size_t n = p.size();
  double cx = 0, cy = 0;
  for (const cv::Point2f& q : p) {
    cx += q.x;
    cy += q.y;
  }
  cx /= n;
  cy /= n;
  double mean = 0;
  for (const cv::Point2f& q : p) mean += std::hypot(q.x - cx, q.y - cy);
  mean /= n;
  const double s = mean > 0 ? std::sqrt(2.0) / mean : 1.0;
  out->resize(n);
  for (size_t i = 0; i < n; ++i) (*out)[i] = {s * (p[i].x - cx), s * (p[i].y - cy)};
  Mat3 t;
  t << s, 0, -s * cx, 0, s, -s * cy, 0, 0, 1;
  return t;
}

// OpenCV's RANSACUpdateNumIters (calib3d/src/ptsetreg.cpp) for 7-point samples.
int SamplesNeeded(double confidence, double outlier_ratio, int max_samples) {
  const double num = std::log(std::max(1.0 - confidence, DBL_MIN));
  const double denom_arg = 1.0 - std::pow(1.0 - outlier_ratio, 7);
  if (denom_arg < DBL_MIN) return 0;
  const double denom = std::log(denom_arg);
  return denom >= 0 || -num >= max_samples * (-denom) ? max_samples : static_cast<int>(std::lround(num / denom));
}

// A small deterministic generator (splitmix64).
struct Rng {
  uint64_t state;
  uint64_t Next() {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  int Below(int n) { return static_cast<int>(Next() % static_cast<uint64_t>(n)); }
};

// The two null vectors of the 7x9 system a (rows: matches) as 3x3 matrices:
// Gauss-Jordan elimination with partial pivoting over the first 7 columns
// (a is overwritten); false when a pivot vanishes (a degenerate sample).
bool NullSpace7x9(double a[7][9], Mat3* f1, Mat3* f2) {
  for (int c = 0; c < 7; ++c) {
    int pivot = c;
    for (int r = c + 1; r < 7; ++r)
      if (std::abs(a[r][c]) > std::abs(a[pivot][c])) pivot = r;
    if (std::abs(a[pivot][c]) < 1e-10) return false;
    if (pivot != c)
      for (int k = 0; k < 9; ++k) std::swap(a[c][k], a[pivot][k]);
    const double inv = 1.0 / a[c][c];
    for (int k = c; k < 9; ++k) a[c][k] *= inv;
    for (int r = 0; r < 7; ++r) {
      if (r == c || a[r][c] == 0) continue;
      const double m = a[r][c];
      for (int k = c; k < 9; ++k) a[r][k] -= m * a[c][k];
    }
  }
  // x = (-a[.][7], 1, 0) and (-a[.][8], 0, 1).
  double x[9], y[9];
  for (int r = 0; r < 7; ++r) {
    x[r] = -a[r][7];
    y[r] = -a[r][8];
  }
  x[7] = 1, x[8] = 0, y[7] = 0, y[8] = 1;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      (*f1)(r, c) = x[3 * r + c];
      (*f2)(r, c) = y[3 * r + c];
    }
  return true;
}

}  // namespace

int RealCubicRoots(double c3, double c2, double c1, double c0, double roots[3]) {
  const double scale = std::max({std::abs(c3), std::abs(c2), std::abs(c1), std::abs(c0)});
  if (scale == 0) return 0;
  if (std::abs(c3) <= 1e-12 * scale) {
    if (std::abs(c2) <= 1e-12 * scale) {
      if (std::abs(c1) <= 1e-12 * scale) return 0;
      roots[0] = -c0 / c1;
      return 1;
    }
    const double disc = c1 * c1 - 4 * c2 * c0;
    if (disc < 0) return 0;
    const double s = std::sqrt(disc);
    // The numerically stable pair.
    const double q = -0.5 * (c1 + (c1 >= 0 ? s : -s));
    int n = 0;
    if (q != 0) roots[n++] = c0 / q;
    roots[n++] = q / c2;
    return n;
  }
  const double b = c2 / c3, c = c1 / c3, d = c0 / c3;
  const double p = c - b * b / 3.0, q = 2.0 * b * b * b / 27.0 - b * c / 3.0 + d;
  const double delta = q * q / 4.0 + p * p * p / 27.0;
  int n;
  if (delta > 0 || p == 0) {
    const double s = std::sqrt(std::max(delta, 0.0));
    roots[0] = std::cbrt(-q / 2.0 + s) + std::cbrt(-q / 2.0 - s) - b / 3.0;
    n = 1;
  } else {
    const double r = 2.0 * std::sqrt(-p / 3.0);
    const double arg = std::clamp(3.0 * q / (2.0 * p) * std::sqrt(-3.0 / p), -1.0, 1.0);
    const double phi = std::acos(arg) / 3.0;
    for (int k = 0; k < 3; ++k) roots[k] = r * std::cos(phi - 2.0 * M_PI * k / 3.0) - b / 3.0;
    n = 3;
  }
  // Two Newton steps on the original polynomial polish the closed form.
  for (int k = 0; k < n; ++k) {
    double a = roots[k];
    for (int it = 0; it < 2; ++it) {
      const double f = ((c3 * a + c2) * a + c1) * a + c0, df = (3 * c3 * a + 2 * c2) * a + c1;
      if (df == 0) break;
      a -= f / df;
    }
    roots[k] = a;
  }
  return n;
}

FundamentalFit FitFundamentalRansac(const std::vector<cv::Point2f>& p1, const std::vector<cv::Point2f>& p2,
                                    double threshold_px, double confidence, int max_samples, int refits, uint64_t seed) {
  FundamentalFit fit;
  const int n = static_cast<int>(p1.size());
  if (n < 7 || p2.size() != p1.size() || !(threshold_px > 0) || max_samples < 1) return fit;
  std::vector<Eigen::Vector2d> q1, q2;
  const Mat3 t1 = Normalise(p1, &q1), t2 = Normalise(p2, &q2);
  std::vector<double> u1(n), v1(n), u2(n), v2(n);
  for (int i = 0; i < n; ++i) {
    u1[i] = p1[i].x;
    v1[i] = p1[i].y;
    u2[i] = p2[i].x;
    v2[i] = p2[i].y;
  }
  const double thr2 = threshold_px * threshold_px;
  // Inliers of F (pixels): the larger of the two squared point-to-line
  // distances d^2 / |l|^2 at most thr2, tested as d^2 <= thr2 |l|^2 (no
  // division). Stops early, returning a count <= `beat`, once the matches
  // left cannot lift the count above `beat` (no mask then).
  auto count = [&](const Mat3& f, std::vector<uint8_t>* mask, int beat) {
    const double f00 = f(0, 0), f01 = f(0, 1), f02 = f(0, 2), f10 = f(1, 0), f11 = f(1, 1), f12 = f(1, 2);
    const double f20 = f(2, 0), f21 = f(2, 1), f22 = f(2, 2);
    int c = 0;
    for (int i = 0; i < n; ++i) {
      const double a = f00 * u1[i] + f01 * v1[i] + f02;
      const double b = f10 * u1[i] + f11 * v1[i] + f12;
      const double cc = f20 * u1[i] + f21 * v1[i] + f22;
      const double d = u2[i] * a + v2[i] * b + cc;  // x2^T F x1
      const double a1 = f00 * u2[i] + f10 * v2[i] + f20;
      const double b1 = f01 * u2[i] + f11 * v2[i] + f21;
      const double dd = d * d;
      const bool in = dd <= thr2 * (a * a + b * b) && dd <= thr2 * (a1 * a1 + b1 * b1);
      if (mask) (*mask)[i] = in;
      c += in;
      if (!mask && c + (n - 1 - i) <= beat) return c;
    }
    return c;
  };

  Rng rng{seed};
  int needed = max_samples, best = -1;
  Mat3 best_f = Mat3::Zero();
  double a[7][9];
  int idx[7];
  for (int s = 0; s < needed; ++s) {
    // 7 distinct matches.
    for (int k = 0; k < 7; ++k) {
      for (;;) {
        idx[k] = n == 7 ? k : rng.Below(n);
        bool repeat = false;
        for (int j = 0; j < k; ++j) repeat |= idx[j] == idx[k];
        if (!repeat) break;
      }
    }
    ++fit.samples;
    for (int k = 0; k < 7; ++k) {
      const Eigen::Vector2d& x1 = q1[idx[k]];
      const Eigen::Vector2d& x2 = q2[idx[k]];
      const double row[9] = {x2.x() * x1.x(), x2.x() * x1.y(), x2.x(), x2.y() * x1.x(), x2.y() * x1.y(),
                             x2.y(),          x1.x(),          x1.y(), 1.0};
      std::copy(row, row + 9, a[k]);
    }
    Mat3 f1, f2;
    if (!NullSpace7x9(a, &f1, &f2)) continue;  // a degenerate sample
    // det(a F1 + (1 - a) F2) = c3 a^3 + c2 a^2 + c1 a + c0, from its values at a = 0, 1, -1, 2.
    const double d0 = f2.determinant(), d1 = f1.determinant();
    const double dm = (2.0 * f2 - f1).determinant(), d2 = (2.0 * f1 - f2).determinant();
    const double c0 = d0, c2 = (d1 + dm) / 2.0 - c0, odd = (d1 - dm) / 2.0;
    const double c3 = (d2 - c0 - 4.0 * c2 - 2.0 * odd) / 6.0, c1 = odd - c3;
    double roots[3];
    const int nr = RealCubicRoots(c3, c2, c1, c0, roots);
    for (int r = 0; r < nr; ++r) {
      Mat3 f = t2.transpose() * (roots[r] * f1 + (1.0 - roots[r]) * f2) * t1;
      const double norm = f.norm();
      if (!(norm > 0) || !std::isfinite(norm)) continue;
      f /= norm;
      const int c = count(f, nullptr, best);
      if (c > best) {
        best = c;
        best_f = f;
        needed = std::min(needed, SamplesNeeded(confidence, static_cast<double>(n - c) / n, max_samples));
      }
    }
    if (n == 7) break;
  }
  if (best < 7) return fit;
  // Least-squares refits on the inliers (the normalised 8-point algorithm
  // with the rank-2 constraint, Hartley & Zisserman 11.2), kept while they
  // do not lose inliers: a minimal sample's model carries the noise of its
  // 7 matches, the refit averages it over all inliers.
  std::vector<uint8_t> mask(n);
  for (int round = 0; round < refits && best >= 8; ++round) {
    count(best_f, &mask, -1);
    Eigen::Matrix<double, 9, 9> ata = Eigen::Matrix<double, 9, 9>::Zero();
    for (int i = 0; i < n; ++i) {
      if (!mask[i]) continue;
      const Eigen::Vector2d& x1 = q1[i];
      const Eigen::Vector2d& x2 = q2[i];
      Eigen::Matrix<double, 9, 1> row;
      row << x2.x() * x1.x(), x2.x() * x1.y(), x2.x(), x2.y() * x1.x(), x2.y() * x1.y(), x2.y(), x1.x(), x1.y(), 1.0;
      ata.selfadjointView<Eigen::Lower>().rankUpdate(row);
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(ata.selfadjointView<Eigen::Lower>());
    if (eig.info() != Eigen::Success) break;
    const Eigen::Matrix<double, 9, 1> v = eig.eigenvectors().col(0);  // smallest eigenvalue
    Mat3 fn;
    fn << v(0), v(1), v(2), v(3), v(4), v(5), v(6), v(7), v(8);
    Eigen::JacobiSVD<Mat3> svd(fn, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Vector3d sv = svd.singularValues();
    sv(2) = 0;
    Mat3 f = t2.transpose() * (svd.matrixU() * sv.asDiagonal() * svd.matrixV().transpose()) * t1;
    const double norm = f.norm();
    if (!(norm > 0) || !std::isfinite(norm)) break;
    f /= norm;
    const int c = count(f, nullptr, -1);
    if (c < best) break;
    best = c;
    best_f = f;
  }
  // OpenCV's convention: F(2,2) = 1 when it is not near zero.
  if (std::abs(best_f(2, 2)) > FLT_EPSILON) best_f /= best_f(2, 2);
  fit.ok = true;
  fit.inlier.assign(n, 0);
  fit.inliers = count(best_f, &fit.inlier, -1);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) fit.F(r, c) = best_f(r, c);
  return fit;
}

}  // namespace dypho
