#include "engine/synth/quad_renderer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/check.h"

namespace dypho::synth {
namespace {

using Eigen::Vector3d;

constexpr double kNear = 1e-4;         // nearest depth that counts [m]
constexpr double kEdgeEpsilon = 1e-9;  // inclusive tolerance on (s, t) so shared edges leave no gaps
constexpr int kRowBlock = 8;           // rows per parallel work item
// Smaller images render on one thread: thread hand-offs would cost more.
constexpr long kMinParallelPixels = 1 << 16;

// A quad in camera coordinates, prepared for the pixel loop. With the pixel
// ray r = ((u - cx) / fx, (v - cy) / fy, 1) and X = z r on the plane
// n . X = h: z = h / (n . r), s = z (a . r) - oa, t = z (b . r) - ob.
struct CamQuad {
  Vector3d n;
  double h;
  Vector3d a;
  double oa;
  Vector3d b;
  double ob;
  int x0, x1, y0, y1;  // pixel bounding box, inclusive
  int index;
};

// Clips a polygon (camera coordinates) to z >= kNear.
std::vector<Vector3d> ClipNear(const std::vector<Vector3d>& poly) {
  std::vector<Vector3d> out;
  for (size_t i = 0; i < poly.size(); ++i) {
    const Vector3d& p = poly[i];
    const Vector3d& q = poly[(i + 1) % poly.size()];
    const bool p_in = p.z() >= kNear, q_in = q.z() >= kNear;
    if (p_in) out.push_back(p);
    if (p_in != q_in) {
      const double f = (kNear - p.z()) / (q.z() - p.z());
      out.push_back(p + f * (q - p));
    }
  }
  return out;
}

std::vector<CamQuad> PrepareQuads(const std::vector<Quad>& quads, const Rigid3d& cam_from_world,
                                  const Camera& camera) {
  const Eigen::Matrix3d R = cam_from_world.rotation.toRotationMatrix();
  std::vector<CamQuad> out;
  out.reserve(quads.size());
  for (size_t i = 0; i < quads.size(); ++i) {
    const Quad& q = quads[i];
    CamQuad c;
    const Vector3d o = R * q.origin + cam_from_world.translation;
    const Vector3d es = R * q.edge_s, et = R * q.edge_t;
    c.n = R * q.normal;
    c.h = c.n.dot(o);
    if (!(c.h < 0.0)) continue;  // back face, edge-on, or NaN
    c.a = es / q.edge_s.squaredNorm();
    c.b = et / q.edge_t.squaredNorm();
    c.oa = c.a.dot(o);
    c.ob = c.b.dot(o);
    const std::vector<Vector3d> poly = ClipNear({o, o + es, o + es + et, o + et});
    if (poly.size() < 3) continue;
    double umin = std::numeric_limits<double>::infinity(), umax = -umin, vmin = umin, vmax = -umin;
    for (const Vector3d& p : poly) {
      const double u = camera.fx * p.x() / p.z() + camera.cx;
      const double v = camera.fy * p.y() / p.z() + camera.cy;
      umin = std::min(umin, u);
      umax = std::max(umax, u);
      vmin = std::min(vmin, v);
      vmax = std::max(vmax, v);
    }
    // One pixel of margin: the exact test is per pixel anyway.
    umin = std::max(umin - 1.0, 0.0);
    vmin = std::max(vmin - 1.0, 0.0);
    umax = std::min(umax + 1.0, camera.width - 1.0);
    vmax = std::min(vmax + 1.0, camera.height - 1.0);
    if (!(umin <= umax && vmin <= vmax)) continue;
    c.x0 = static_cast<int>(std::floor(umin));
    c.x1 = static_cast<int>(std::ceil(umax));
    c.y0 = static_cast<int>(std::floor(vmin));
    c.y1 = static_cast<int>(std::ceil(vmax));
    c.index = static_cast<int>(i);
    out.push_back(c);
  }
  return out;
}

void CheckCamera(const Camera& camera) {
  camera.Validate("synthetic renderer");
  DYPHO_CHECK_INPUT(!camera.HasDistortion())
      << "synthetic renderer: camera distortion must be zero (render undistorted images)";
}

}  // namespace

Quad MakeQuad(const Vector3d& centre, const Vector3d& normal, const Vector3d& up, double width,
              double height) {
  Quad q;
  const Vector3d right = up.cross(normal);
  q.normal = normal;
  q.edge_s = right * width;
  q.edge_t = -up * height;
  q.origin = centre - 0.5 * q.edge_s - 0.5 * q.edge_t;
  return q;
}

std::array<Eigen::Vector2d, kBoxFaces> BoxFaceSizes(const Vector3d& size) {
  return {Eigen::Vector2d(size.y(), size.z()), Eigen::Vector2d(size.y(), size.z()),
          Eigen::Vector2d(size.x(), size.z()), Eigen::Vector2d(size.x(), size.z()),
          Eigen::Vector2d(size.x(), size.y()), Eigen::Vector2d(size.x(), size.y())};
}

std::array<Quad, kBoxFaces> BoxQuads(const Rigid3d& world_from_box, const Vector3d& size, bool inward) {
  const Vector3d half = 0.5 * size;
  const Vector3d axes[3] = {Vector3d::UnitX(), Vector3d::UnitY(), Vector3d::UnitZ()};
  const auto sizes = BoxFaceSizes(size);
  std::array<Quad, kBoxFaces> quads;
  const Eigen::Matrix3d R = world_from_box.rotation.toRotationMatrix();
  for (int f = 0; f < kBoxFaces; ++f) {
    const int axis = f / 2;
    const double sign = (f % 2 == 0) ? 1.0 : -1.0;
    const Vector3d outward = sign * axes[axis];
    const Vector3d centre = outward * half[axis];
    const Vector3d up = axis == 2 ? Vector3d::UnitY() : Vector3d::UnitZ();
    const Vector3d normal = inward ? -outward : outward;
    const Quad local = MakeQuad(centre, normal, up, sizes[f].x(), sizes[f].y());
    Quad& q = quads[f];
    q.origin = world_from_box * local.origin;
    q.edge_s = R * local.edge_s;
    q.edge_t = R * local.edge_t;
    q.normal = R * local.normal;
  }
  return quads;
}

VisibilityBuffer RasterizeQuads(const std::vector<Quad>& quads, const Rigid3d& cam_from_world,
                                const Camera& camera) {
  CheckCamera(camera);
  const int W = camera.width, H = camera.height;
  VisibilityBuffer vis;
  vis.width = W;
  vis.height = H;
  vis.depth.assign(static_cast<size_t>(W) * H, std::numeric_limits<double>::infinity());
  vis.quad.assign(static_cast<size_t>(W) * H, -1);
  const std::vector<CamQuad> cam_quads = PrepareQuads(quads, cam_from_world, camera);
  const int blocks = (H + kRowBlock - 1) / kRowBlock;
  const double inv_fx = 1.0 / camera.fx, inv_fy = 1.0 / camera.fy;

#pragma omp parallel for schedule(dynamic, 1) if (static_cast <long>(W) * H >= kMinParallelPixels)
  for (int block = 0; block < blocks; ++block) {
    const int row0 = block * kRowBlock, row1 = std::min(H, row0 + kRowBlock) - 1;
    for (const CamQuad& c : cam_quads) {
      const int y0 = std::max(c.y0, row0), y1 = std::min(c.y1, row1);
      for (int y = y0; y <= y1; ++y) {
        const double yn = (y - camera.cy) * inv_fy;
        // Row constants: each of n.r, a.r, b.r is affine in xn.
        const double n_row = c.n.y() * yn + c.n.z();
        const double a_row = c.a.y() * yn + c.a.z();
        const double b_row = c.b.y() * yn + c.b.z();
        double* depth = &vis.depth[static_cast<size_t>(y) * W];
        int32_t* id = &vis.quad[static_cast<size_t>(y) * W];
        for (int x = c.x0; x <= c.x1; ++x) {
          const double xn = (x - camera.cx) * inv_fx;
          const double denom = c.n.x() * xn + n_row;
          if (!(denom < 0.0)) continue;
          const double z = c.h / denom;
          if (!(z >= kNear) || !(z < depth[x])) continue;
          const double s = z * (c.a.x() * xn + a_row) - c.oa;
          if (s < -kEdgeEpsilon || s > 1.0 + kEdgeEpsilon) continue;
          const double t = z * (c.b.x() * xn + b_row) - c.ob;
          if (t < -kEdgeEpsilon || t > 1.0 + kEdgeEpsilon) continue;
          depth[x] = z;
          id[x] = c.index;
        }
      }
    }
  }
  for (size_t i = 0; i < vis.depth.size(); ++i) {
    if (vis.quad[i] < 0) vis.depth[i] = 0.0;
  }
  return vis;
}

QuadRender RenderQuads(const std::vector<Quad>& quads, const std::vector<Texture>& textures,
                       const Rigid3d& cam_from_world, const Camera& camera, bool with_colour) {
  for (const Quad& q : quads) {
    DYPHO_CHECK(q.texture < static_cast<int>(textures.size()) || !with_colour)
        << "quad texture " << q.texture << " out of range (" << textures.size() << " textures)";
  }
  const VisibilityBuffer vis = RasterizeQuads(quads, cam_from_world, camera);
  const int W = camera.width, H = camera.height;
  QuadRender out;
  if (with_colour) out.rgb = ImageU8(W, H, 3, 0);
  out.depth = ImageF(W, H, 1, 0.0f);
  out.cos_incidence = ImageF(W, H, 1, 0.0f);
  out.mask = ImageU8(W, H, 1, 0);
  const Eigen::Matrix3d R = cam_from_world.rotation.toRotationMatrix();
  // The same plane parameters as the rasterizer, for every quad (cheap).
  std::vector<CamQuad> cam(quads.size());
  for (size_t i = 0; i < quads.size(); ++i) {
    const Quad& q = quads[i];
    CamQuad& c = cam[i];
    const Vector3d o = R * q.origin + cam_from_world.translation;
    c.n = R * q.normal;
    c.h = c.n.dot(o);
    c.a = (R * q.edge_s) / q.edge_s.squaredNorm();
    c.b = (R * q.edge_t) / q.edge_t.squaredNorm();
    c.oa = c.a.dot(o);
    c.ob = c.b.dot(o);
  }
  const double inv_fx = 1.0 / camera.fx, inv_fy = 1.0 / camera.fy;

#pragma omp parallel for schedule(dynamic, 4) if (static_cast <long>(W) * H >= kMinParallelPixels)
  for (int y = 0; y < H; ++y) {
    const double yn = (y - camera.cy) * inv_fy;
    for (int x = 0; x < W; ++x) {
      const size_t p = static_cast<size_t>(y) * W + x;
      const int qi = vis.quad[p];
      if (qi < 0) continue;
      const Quad& q = quads[qi];
      const CamQuad& c = cam[qi];
      const double xn = (x - camera.cx) * inv_fx;
      // n.r, a.r, b.r for the pixel's ray r = (xn, yn, 1).
      const double nr = c.n.x() * xn + c.n.y() * yn + c.n.z();
      out.depth.at(x, y) = static_cast<float>(vis.depth[p]);
      out.cos_incidence.at(x, y) = static_cast<float>(std::abs(nr) / std::sqrt(xn * xn + yn * yn + 1.0));
      if (q.object >= 0) out.mask.at(x, y) = 255;
      if (!with_colour) continue;
      Eigen::Vector3f albedo = q.colour;
      if (q.texture >= 0) {
        // Texture coordinates of the pixel and of its right and lower
        // neighbours on the same plane give the footprint (the rays differ by
        // 1 / fx in x or 1 / fy in y); the other side is used when a
        // neighbour's ray misses the plane.
        const double ar = c.a.x() * xn + c.a.y() * yn + c.a.z();
        const double br = c.b.x() * xn + c.b.y() * yn + c.b.z();
        auto st_at = [&](double n_dot, double a_dot, double b_dot, double* s, double* t) {
          if (!(n_dot < 0.0)) return false;
          const double z = c.h / n_dot;
          *s = z * a_dot - c.oa;
          *t = z * b_dot - c.ob;
          return std::isfinite(*s) && std::isfinite(*t);
        };
        double s = 0.0, t = 0.0;
        st_at(nr, ar, br, &s, &t);
        const double dnx = c.n.x() * inv_fx, dax = c.a.x() * inv_fx, dbx = c.b.x() * inv_fx;
        const double dny = c.n.y() * inv_fy, day = c.a.y() * inv_fy, dby = c.b.y() * inv_fy;
        double s1, t1, dsdu = 1e3, dtdu = 1e3, dsdv = 1e3, dtdv = 1e3;
        if (st_at(nr + dnx, ar + dax, br + dbx, &s1, &t1)) {
          dsdu = s1 - s;
          dtdu = t1 - t;
        } else if (st_at(nr - dnx, ar - dax, br - dbx, &s1, &t1)) {
          dsdu = s - s1;
          dtdu = t - t1;
        }
        if (st_at(nr + dny, ar + day, br + dby, &s1, &t1)) {
          dsdv = s1 - s;
          dtdv = t1 - t;
        } else if (st_at(nr - dny, ar - day, br - dby, &s1, &t1)) {
          dsdv = s - s1;
          dtdv = t - t1;
        }
        albedo = textures[q.texture].SampleFootprint(s, t, dsdu, dtdu, dsdv, dtdv);
      }
      const Eigen::Vector3f colour = albedo * q.shade;
      for (int ch = 0; ch < 3; ++ch) {
        const float v = std::min(1.0f, std::max(0.0f, colour[ch]));
        out.rgb.at(x, y, ch) = static_cast<uint8_t>(v * 255.0f + 0.5f);
      }
    }
  }
  return out;
}

}  // namespace dypho::synth
