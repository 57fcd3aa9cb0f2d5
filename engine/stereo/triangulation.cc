#include "engine/stereo/triangulation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include <opencv2/imgproc.hpp>

namespace dypho::stereo {

cv::Mat PlanePrior(const std::vector<SupportPoint>& points, cv::Size size, bool right_image) {
  const int w = size.width, h = size.height;
  cv::Mat prior(h, w, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  if (points.size() < 3) return prior;
  cv::Subdiv2D subdiv(cv::Rect(0, 0, w, h));
  std::unordered_map<long, int> disparity_at;  // key y * w + x
  std::vector<cv::Point2f> vertices;  // in the order of `points` (row-major: short point location walks)
  vertices.reserve(points.size());
  for (const SupportPoint& p : points) {
    const int u = right_image ? std::clamp(p.u - p.d, 0, w - 1) : p.u;
    if (disparity_at.emplace(long(p.v) * w + u, p.d).second) vertices.emplace_back(float(u), float(p.v));
  }
  subdiv.insert(vertices);
  std::vector<cv::Vec6f> triangles;
  subdiv.getTriangleList(triangles);
  for (const cv::Vec6f& t : triangles) {
    double x[3], y[3], d[3];
    bool inside = true;
    for (int k = 0; k < 3 && inside; ++k) {
      x[k] = t[2 * k], y[k] = t[2 * k + 1];
      inside = x[k] >= 0 && x[k] < w && y[k] >= 0 && y[k] < h;
      if (inside) d[k] = disparity_at.at(long(std::lround(y[k])) * w + long(std::lround(x[k])));
    }
    if (!inside) continue;  // a triangle of Subdiv2D's virtual outer vertices
    // Plane d = a x + b y + c through the three vertices (Cramer's rule).
    const double det = (x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]);
    if (std::abs(det) < 1e-9) continue;
    const double a = ((d[1] - d[0]) * (y[2] - y[0]) - (d[2] - d[0]) * (y[1] - y[0])) / det;
    const double b = ((x[1] - x[0]) * (d[2] - d[0]) - (x[2] - x[0]) * (d[1] - d[0])) / det;
    const double c = d[0] - a * x[0] - b * y[0];
    const int y0 = std::max(0, int(std::ceil(std::min({y[0], y[1], y[2]}))));
    const int y1 = std::min(h - 1, int(std::floor(std::max({y[0], y[1], y[2]}))));
    for (int py = y0; py <= y1; ++py) {
      // Span of the triangle on this row: intersect the three edges.
      double lo = 1e30, hi = -1e30;
      for (int k = 0; k < 3; ++k) {
        const int k2 = (k + 1) % 3;
        const double ya = y[k], yb = y[k2];
        if ((py < std::min(ya, yb)) || (py > std::max(ya, yb))) continue;
        if (ya == yb) {
          lo = std::min({lo, x[k], x[k2]}), hi = std::max({hi, x[k], x[k2]});
        } else {
          const double xi = x[k] + (py - ya) * (x[k2] - x[k]) / (yb - ya);
          lo = std::min(lo, xi), hi = std::max(hi, xi);
        }
      }
      const int x0 = std::max(0, int(std::ceil(lo))), x1 = std::min(w - 1, int(std::floor(hi)));
      float* row = prior.ptr<float>(py);
      for (int px = x0; px <= x1; ++px) row[px] = float(a * px + b * py + c);
    }
  }
  return prior;
}

}  // namespace dypho::stereo
