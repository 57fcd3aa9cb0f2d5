// Finite-difference checks in double precision for every VJP in kernels/math.
#include <functional>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "common/rigid3.h"
#include "kernels/math/preprocess.h"

namespace dypho::kernels::math {
namespace {

using Vec = std::vector<double>;

// Central differences of a scalar function of a flat parameter vector.
Vec NumericGrad(const std::function<double(const Vec&)>& f, Vec x, double h = 1e-6) {
  Vec g(x.size());
  for (size_t i = 0; i < x.size(); ++i) {
    const double keep = x[i];
    x[i] = keep + h;
    const double fp = f(x);
    x[i] = keep - h;
    const double fm = f(x);
    x[i] = keep;
    g[i] = (fp - fm) / (2 * h);
  }
  return g;
}

void ExpectGradNear(const Vec& analytic, const Vec& numeric, double rel = 1e-6, const char* what = "") {
  ASSERT_EQ(analytic.size(), numeric.size());
  double scale = 1e-3;
  for (double v : numeric) scale = std::max(scale, std::abs(v));
  for (size_t i = 0; i < analytic.size(); ++i) {
    EXPECT_NEAR(analytic[i], numeric[i], rel * scale) << what << " entry " << i;
  }
}

Vec RandomVec(std::mt19937* rng, int n, double lo = -1, double hi = 1) {
  std::uniform_real_distribution<double> u(lo, hi);
  Vec v(n);
  for (double& x : v) x = u(*rng);
  return v;
}

Mat3<double> ToMat3(const double* v) {  // row-major
  return Mat3FromRows<double>(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8]);
}
double Dot(const Mat3<double>& a, const Mat3<double>& b) {
  double s = 0;
  for (int c = 0; c < 3; ++c) s += glm::dot(a[c], b[c]);
  return s;
}
double Dot(const Mat2<double>& a, const Mat2<double>& b) {
  return glm::dot(a[0], b[0]) + glm::dot(a[1], b[1]);
}

TEST(KernelsMath, QuatToRotmatIsRotation) {
  std::mt19937 rng(1);
  for (int trial = 0; trial < 5; ++trial) {
    Vec q = RandomVec(&rng, 4);
    const Mat3<double> R = QuatToRotmat(q.data());
    const Mat3<double> I = glm::transpose(R) * R;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) EXPECT_NEAR(I[i][j], i == j ? 1.0 : 0.0, 1e-12);
    }
    EXPECT_NEAR(glm::determinant(R), 1.0, 1e-12);
  }
}

TEST(KernelsMath, QuatToRotmatVjp) {
  std::mt19937 rng(2);
  for (int trial = 0; trial < 5; ++trial) {
    const Vec q = RandomVec(&rng, 4);
    const Vec vr = RandomVec(&rng, 9);
    const Mat3<double> V = ToMat3(vr.data());
    auto f = [&](const Vec& x) { return Dot(V, QuatToRotmat(x.data())); };
    Vec analytic(4);
    QuatToRotmatVjp(q.data(), V, analytic.data());
    ExpectGradNear(analytic, NumericGrad(f, q), 1e-7, "v_q");
  }
}

TEST(KernelsMath, QuatScaleToCovarianceVjp) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 5; ++trial) {
    Vec x = RandomVec(&rng, 7);  // q (4), log scale (3)
    const Mat3<double> V = ToMat3(RandomVec(&rng, 9).data());
    auto f = [&](const Vec& p) { return Dot(V, QuatScaleToCovariance(p.data(), p.data() + 4)); };
    Vec analytic(7);
    QuatScaleToCovarianceVjp(x.data(), x.data() + 4, V, analytic.data(), analytic.data() + 4);
    ExpectGradNear(analytic, NumericGrad(f, x), 1e-7, "v_q|v_log_scale");
  }
}

TEST(KernelsMath, TransformToCameraVjp) {
  std::mt19937 rng(4);
  for (int trial = 0; trial < 5; ++trial) {
    // x = R (9, row-major, not constrained), t (3), mean (3), sigma (9)
    Vec x = RandomVec(&rng, 24);
    const Vec a = RandomVec(&rng, 3);
    const Mat3<double> B = ToMat3(RandomVec(&rng, 9).data());
    auto unpack = [](const Vec& p, Mat3<double>* R, Vec3<double>* t, Vec3<double>* m, Mat3<double>* S) {
      *R = ToMat3(p.data());
      *t = Vec3<double>(p[9], p[10], p[11]);
      *m = Vec3<double>(p[12], p[13], p[14]);
      *S = ToMat3(p.data() + 15);
    };
    auto f = [&](const Vec& p) {
      Mat3<double> R, S, Sc;
      Vec3<double> t, m, mc;
      unpack(p, &R, &t, &m, &S);
      TransformToCamera(R, t, m, S, &mc, &Sc);
      return a[0] * mc.x + a[1] * mc.y + a[2] * mc.z + Dot(B, Sc);
    };
    // The VJP assumes a symmetric Sigma: symmetrise the input.
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < i; ++j) x[15 + 3 * i + j] = x[15 + 3 * j + i];
    }
    Mat3<double> R, S;
    Vec3<double> t, m;
    unpack(x, &R, &t, &m, &S);
    Vec3<double> v_m;
    Mat3<double> v_S, v_R(0.0);
    Vec3<double> v_t(0.0);
    TransformToCameraVjp(R, m, S, Vec3<double>(a[0], a[1], a[2]), B, &v_m, &v_S, &v_R, &v_t);
    Vec analytic(24);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        analytic[3 * i + j] = v_R[j][i];
        analytic[15 + 3 * i + j] = v_S[j][i];
      }
      analytic[9 + i] = v_t[i];
      analytic[12 + i] = v_m[i];
    }
    Vec numeric = NumericGrad(f, x);
    ExpectGradNear(analytic, numeric, 1e-7, "transform");
  }
}

void CheckPerspective(const Vec3<double>& mean_c, unsigned seed) {
  std::mt19937 rng(seed);
  const double fx = 300, fy = 280;
  const ProjectionLimits lim = MakeProjectionLimits(300.f, 280.f, 160.f, 120.f, 320, 240);
  Vec x(12);
  x[0] = mean_c.x;
  x[1] = mean_c.y;
  x[2] = mean_c.z;
  Vec s = RandomVec(&rng, 9, -0.1, 0.1);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) x[3 + 3 * i + j] = (i == j ? 0.2 : 0.0) + 0.5 * (s[3 * i + j] + s[3 * j + i]);
  }
  const Vec a = RandomVec(&rng, 2);
  Mat2<double> B;
  const Vec b = RandomVec(&rng, 4);
  B[0][0] = b[0];
  B[1][0] = b[1];
  B[0][1] = b[2];
  B[1][1] = b[3];
  auto f = [&](const Vec& p) {
    Vec2<double> m2;
    Mat2<double> c2;
    PerspectiveProject(Vec3<double>(p[0], p[1], p[2]), ToMat3(p.data() + 3), fx, fy, 160.0, 120.0, lim, &m2, &c2);
    return a[0] * m2.x + a[1] * m2.y + Dot(B, c2);
  };
  Vec3<double> v_mc(0.0);
  Mat3<double> v_sc;
  PerspectiveProjectVjp(Vec3<double>(x[0], x[1], x[2]), ToMat3(x.data() + 3), fx, fy, lim, Vec2<double>(a[0], a[1]),
                        B, &v_mc, &v_sc);
  Vec analytic(12);
  for (int i = 0; i < 3; ++i) {
    analytic[i] = v_mc[i];
    for (int j = 0; j < 3; ++j) analytic[3 + 3 * i + j] = v_sc[j][i];
  }
  ExpectGradNear(analytic, NumericGrad(f, x), 1e-6, "perspective");
}

TEST(KernelsMath, PerspectiveProjectVjpInsideView) { CheckPerspective(Vec3<double>(0.3, -0.2, 2.5), 5); }
TEST(KernelsMath, PerspectiveProjectVjpClampedTangent) {
  // Far outside the view in x and y: the Jacobian uses the clamped tangent.
  CheckPerspective(Vec3<double>(6.0, -5.0, 2.0), 6);
}

TEST(KernelsMath, DilatedConicVjp) {
  std::mt19937 rng(7);
  Vec x = {2.0, 0.3, 0.3, 1.5};  // col-major entries of cov2d
  const Vec b = RandomVec(&rng, 4);
  Mat2<double> B;
  B[0][0] = b[0];
  B[1][0] = b[1];
  B[0][1] = b[2];
  B[1][1] = b[3];
  auto to_mat = [](const Vec& p) {
    Mat2<double> m;
    m[0][0] = p[0];
    m[0][1] = p[1];
    m[1][0] = p[2];
    m[1][1] = p[3];
    return m;
  };
  auto f = [&](const Vec& p) {
    Mat2<double> conic;
    EXPECT_TRUE(DilatedConic(to_mat(p), 0.3, &conic));
    return Dot(B, conic);
  };
  Mat2<double> conic;
  ASSERT_TRUE(DilatedConic(to_mat(x), 0.3, &conic));
  const Mat2<double> v = DilatedConicVjp(conic, B);
  // DilatedConic symmetrises the off-diagonal (b = (m01 + m10) / 2), so its
  // gradient splits evenly; the VJP returns the symmetric-matrix gradient.
  const Vec numeric = NumericGrad(f, x);
  EXPECT_NEAR(v[0][0], numeric[0], 1e-7);
  EXPECT_NEAR(v[1][1], numeric[3], 1e-7);
  EXPECT_NEAR(0.5 * (v[0][1] + v[1][0]), 0.5 * (numeric[1] + numeric[2]) , 1e-7);
  EXPECT_NEAR(v[0][1] + v[1][0], numeric[1] + numeric[2], 1e-7);
}

TEST(KernelsMath, ShToColorVjpAllDegrees) {
  for (int degree = 0; degree <= 3; ++degree) {
    std::mt19937 rng(10 + degree);
    const int K = ShCoeffsForDegree(degree);
    // x = sh (3K), mean (3), centre (3)
    Vec x = RandomVec(&rng, 3 * K + 6, -0.5, 0.5);
    x[0] = x[1] = x[2] = 1.0;  // keep the colour positive (no clamp)
    x[3 * K + 2] += 3.0;
    const Vec w = RandomVec(&rng, 3);
    auto f = [&](const Vec& p) {
      unsigned clamped;
      const Vec3<double> c = ShToColor(degree, p.data(), Vec3<double>(p[3 * K], p[3 * K + 1], p[3 * K + 2]),
                                       Vec3<double>(p[3 * K + 3], p[3 * K + 4], p[3 * K + 5]), &clamped);
      return w[0] * c.x + w[1] * c.y + w[2] * c.z;
    };
    unsigned clamped;
    const Vec3<double> mean(x[3 * K], x[3 * K + 1], x[3 * K + 2]);
    const Vec3<double> center(x[3 * K + 3], x[3 * K + 4], x[3 * K + 5]);
    ShToColor(degree, x.data(), mean, center, &clamped);
    ASSERT_EQ(clamped, 0u);
    Vec analytic(3 * K + 6, 0.0);
    Vec3<double> v_mean(0.0), v_center(0.0);
    ShToColorVjp(degree, x.data(), mean, center, clamped, Vec3<double>(w[0], w[1], w[2]), analytic.data(), &v_mean,
                 &v_center);
    for (int i = 0; i < 3; ++i) {
      analytic[3 * K + i] = v_mean[i];
      analytic[3 * K + 3 + i] = v_center[i];
    }
    ExpectGradNear(analytic, NumericGrad(f, x), 1e-7, "sh");
  }
}

TEST(KernelsMath, ShClampZeroesGradient) {
  const double sh[3] = {-5.0, 0.2, 0.2};  // red channel clamped at 0
  unsigned clamped;
  const Vec3<double> c = ShToColor(0, sh, Vec3<double>(0, 0, 1), Vec3<double>(0.0), &clamped);
  EXPECT_EQ(c.x, 0.0);
  EXPECT_EQ(clamped, 1u);
  double v_sh[3];
  Vec3<double> vm(0.0), vc(0.0);
  ShToColorVjp(0, sh, Vec3<double>(0, 0, 1), Vec3<double>(0.0), clamped, Vec3<double>(1.0), v_sh, &vm, &vc);
  EXPECT_EQ(v_sh[0], 0.0);
  EXPECT_NEAR(v_sh[1], 0.28209479177387814, 1e-15);
}

TEST(KernelsMath, SplatAlphaVjp) {
  // x = opacity, A, B, C, mean_x, mean_y at pixel (px, py)
  const Vec x = {0.6, 0.5, 0.1, 0.4, 10.3, 7.8};
  const double px = 11, py = 7;
  auto f = [&](const Vec& p) {
    const double power = SplatPower(p[1], p[2], p[3], px - p[4], py - p[5]);
    return SplatAlpha(p[0], power);
  };
  Vec a(6, 0.0);
  const double power = SplatPower(x[1], x[2], x[3], px - x[4], py - x[5]);
  SplatAlphaVjp(x[0], power, x[1], x[2], x[3], px - x[4], py - x[5], 1.0, &a[0], &a[1], &a[2], &a[3], &a[4], &a[5]);
  ExpectGradNear(a, NumericGrad(f, x), 1e-7, "alpha");
  // Above the 0.99 cap the derivative is zero.
  Vec b(6, 0.0);
  SplatAlphaVjp(5.0, 0.0, x[1], x[2], x[3], 0.0, 0.0, 1.0, &b[0], &b[1], &b[2], &b[3], &b[4], &b[5]);
  for (double v : b) EXPECT_EQ(v, 0.0);
}

TEST(KernelsMath, SplatReachesRectIsExact) {
  // Compare the closed-form rectangle test with brute force over pixel centres.
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 300; ++trial) {
    SplatT<double> s;
    s.mean_x = 8 + 30 * u(rng);
    s.mean_y = 8 + 30 * u(rng);
    const double l1 = 0.02 + 0.5 * (u(rng) + 1), l2 = 0.02 + 0.5 * (u(rng) + 1), th = 3 * u(rng);
    const double c = std::cos(th), sn = std::sin(th);
    s.A = l1 * c * c + l2 * sn * sn;
    s.C = l1 * sn * sn + l2 * c * c;
    s.B = (l1 - l2) * c * sn;
    s.power_min = -4.5;
    bool brute = false;
    for (int y = 0; y < 16 && !brute; ++y) {
      for (int x = 0; x < 16 && !brute; ++x) {
        brute = SplatPower(s.A, s.B, s.C, x - s.mean_x, y - s.mean_y) >= s.power_min;
      }
    }
    // The continuous test may accept a rectangle whose pixel centres all miss;
    // it must never reject one that a pixel centre reaches.
    if (brute) EXPECT_TRUE(SplatReachesRect(s, 0.0, 0.0, 15.0, 15.0)) << trial;
  }
}

// A pixel composited from a list of (alpha, colour, depth): the closed-form
// per-alpha gradient of the sorted compositing against finite differences.
TEST(KernelsMath, SortedAlphaGrad) {
  std::mt19937 rng(9);
  const int n = 5;
  Vec alphas = RandomVec(&rng, n, 0.1, 0.8);
  const Vec colors = RandomVec(&rng, 3 * n, 0, 1), depths = RandomVec(&rng, n, 1, 3);
  const Vec bg = {0.2, 0.5, 0.7}, vc = RandomVec(&rng, 3);
  const double vd = 0.7, va = -0.4;
  auto composite = [&](const Vec& a, double out[5]) {
    double T = 1, C[3] = {0, 0, 0}, D = 0;
    for (int i = 0; i < n; ++i) {
      for (int c = 0; c < 3; ++c) C[c] += a[i] * T * colors[3 * i + c];
      D += a[i] * T * depths[i];
      T *= 1 - a[i];
    }
    for (int c = 0; c < 3; ++c) out[c] = C[c] + T * bg[c];
    out[3] = D;
    out[4] = 1 - T;
  };
  auto f = [&](const Vec& a) {
    double o[5];
    composite(a, o);
    return vc[0] * o[0] + vc[1] * o[1] + vc[2] * o[2] + vd * o[3] + va * o[4];
  };
  double out[5];
  composite(alphas, out);
  const double T_final = 1 - out[4];
  Vec analytic(n);
  double T = 1, pre[3] = {0, 0, 0}, pre_d = 0;
  for (int i = 0; i < n; ++i) {
    const double w = alphas[i] * T;
    for (int c = 0; c < 3; ++c) pre[c] += w * colors[3 * i + c];
    pre_d += w * depths[i];
    const Vec3<double> suffix(out[0] - pre[0], out[1] - pre[1], out[2] - pre[2]);
    analytic[i] = SortedAlphaGrad(alphas[i], T, Vec3<double>(colors[3 * i], colors[3 * i + 1], colors[3 * i + 2]),
                                  depths[i], suffix, out[3] - pre_d, T_final, Vec3<double>(vc[0], vc[1], vc[2]), vd,
                                  va);
    T *= 1 - alphas[i];
  }
  ExpectGradNear(analytic, NumericGrad(f, alphas), 1e-7, "sorted alpha");
}

TEST(KernelsMath, OitWeightDerivative) {
  for (double z : {0.5, 1.0, 2.5, 7.0, 40.0}) {
    double d;
    OitWeight(z, &d);
    double dp, dm;
    const double num = (OitWeight(z + 1e-6, &dp) - OitWeight(z - 1e-6, &dm)) / 2e-6;
    EXPECT_NEAR(d, num, 1e-6 * std::max(1.0, std::abs(num))) << z;
  }
  double d;
  EXPECT_EQ(OitWeight(0.01, &d), 3e3);  // clamped near the camera
  EXPECT_EQ(d, 0.0);
}

TEST(KernelsMath, OitPixelVjp) {
  std::mt19937 rng(11);
  const int n = 4;
  // x = alphas (n), colours (3n), depths (n)
  Vec x = RandomVec(&rng, 5 * n, 0.1, 0.8);
  for (int i = 0; i < n; ++i) x[4 * n + i] = 1.0 + 2.0 * x[4 * n + i];
  const Vec bg = {0.1, 0.4, 0.9}, vc = RandomVec(&rng, 3);
  const double vd = 0.3, va = 0.8;
  auto composite = [&](const Vec& p, double* A, double* P, double Cbar[3], double* Dbar, double out[5]) {
    *A = 0;
    *P = 1;
    double Cn[3] = {0, 0, 0}, Dn = 0;
    for (int i = 0; i < n; ++i) {
      double dfdz;
      const double f = OitWeight(p[4 * n + i], &dfdz);
      *A += p[i] * f;
      for (int c = 0; c < 3; ++c) Cn[c] += p[i] * f * p[n + 3 * i + c];
      Dn += p[i] * f * p[4 * n + i];
      *P *= 1 - p[i];
    }
    for (int c = 0; c < 3; ++c) {
      Cbar[c] = Cn[c] / *A;
      out[c] = Cbar[c] * (1 - *P) + *P * bg[c];
    }
    *Dbar = Dn / *A;
    out[3] = *Dbar * (1 - *P);
    out[4] = 1 - *P;
  };
  auto f = [&](const Vec& p) {
    double A, P, Cb[3], Db, o[5];
    composite(p, &A, &P, Cb, &Db, o);
    return vc[0] * o[0] + vc[1] * o[1] + vc[2] * o[2] + vd * o[3] + va * o[4];
  };
  double A, P, Cb[3], Db, o[5];
  composite(x, &A, &P, Cb, &Db, o);
  Vec analytic(5 * n, 0.0);
  for (int i = 0; i < n; ++i) {
    double dfdz;
    const double fz = OitWeight(x[4 * n + i], &dfdz);
    Vec3<double> v_c(0.0);
    double v_a = 0, v_z = 0;
    OitPixelVjp(x[i], Vec3<double>(x[n + 3 * i], x[n + 3 * i + 1], x[n + 3 * i + 2]), x[4 * n + i], fz, dfdz, A, P,
                Vec3<double>(Cb[0], Cb[1], Cb[2]), Db, Vec3<double>(bg[0], bg[1], bg[2]),
                Vec3<double>(vc[0], vc[1], vc[2]), vd, va, &v_c, &v_a, &v_z);
    analytic[i] = v_a;
    for (int c = 0; c < 3; ++c) analytic[n + 3 * i + c] = v_c[c];
    analytic[4 * n + i] = v_z;
  }
  ExpectGradNear(analytic, NumericGrad(f, x), 1e-7, "oit");
}

TEST(KernelsMath, PoseGradToTwistAndCameraCenter) {
  // L(R, t) = <VR, R> + <vt, t> + <vc, centre(R, t)>, perturbed on the left by exp(xi).
  std::mt19937 rng(12);
  const Vec vr = RandomVec(&rng, 9), vt = RandomVec(&rng, 3), vc = RandomVec(&rng, 3);
  Eigen::Matrix<double, 6, 1> base_twist;
  base_twist << 0.3, -0.2, 0.5, 0.2, 0.4, -0.3;
  const Rigid3d base = Rigid3d::Exp(base_twist);
  auto loss_of = [&](const Rigid3d& T) {
    const Eigen::Matrix3d R = T.rotation.toRotationMatrix();
    const Eigen::Vector3d c = -R.transpose() * T.translation;
    double s = 0;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) s += vr[3 * i + j] * R(i, j);
      s += vt[i] * T.translation[i] + vc[i] * c[i];
    }
    return s;
  };
  auto f = [&](const Vec& xi) {
    Eigen::Matrix<double, 6, 1> e;
    for (int i = 0; i < 6; ++i) e[i] = xi[i];
    return loss_of(Rigid3d::Exp(e) * base);
  };
  const Eigen::Matrix3d Re = base.rotation.toRotationMatrix();
  const Mat3<double> R = Mat3FromRows<double>(Re(0, 0), Re(0, 1), Re(0, 2), Re(1, 0), Re(1, 1), Re(1, 2), Re(2, 0),
                                              Re(2, 1), Re(2, 2));
  const Vec3<double> t(base.translation.x(), base.translation.y(), base.translation.z());
  Mat3<double> v_R = ToMat3(vr.data());
  Vec3<double> v_t(vt[0], vt[1], vt[2]);
  CameraCenterVjp(R, t, Vec3<double>(vc[0], vc[1], vc[2]), &v_R, &v_t);
  Vec analytic(6);
  PoseGradToTwist(R, t, v_R, v_t, analytic.data());
  ExpectGradNear(analytic, NumericGrad(f, Vec(6, 0.0)), 1e-7, "twist");
}

}  // namespace
}  // namespace dypho::kernels::math
