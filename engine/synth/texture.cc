#include "engine/synth/texture.h"

#include <algorithm>
#include <cmath>

#include "common/check.h"
#include "engine/synth/random.h"

namespace dypho::synth {

using Eigen::Vector3f;

// ---------------------------------------------------------------------------
// Texture: mip chain and filtering.

Texture::Texture(int width, int height, const std::vector<float>& rgb) {
  DYPHO_CHECK(width > 0 && height > 0 && rgb.size() == static_cast<size_t>(width) * height * 3)
      << "texture size " << width << "x" << height << " does not match " << rgb.size() << " values";
  std::vector<float> current = rgb;
  int w = width, h = height;
  while (true) {
    Level level;
    level.width = w;
    level.height = h;
    level.rgb.resize(current.size());
    for (size_t i = 0; i < current.size(); ++i) {
      const float v = std::min(1.0f, std::max(0.0f, current[i]));
      level.rgb[i] = static_cast<uint8_t>(v * 255.0f + 0.5f);
    }
    levels_.push_back(std::move(level));
    if (w == 1 && h == 1) break;
    // 2x2 box filter (the last row/column repeats for odd sizes).
    const int nw = std::max(1, (w + 1) / 2), nh = std::max(1, (h + 1) / 2);
    std::vector<float> next(static_cast<size_t>(nw) * nh * 3);
    for (int y = 0; y < nh; ++y) {
      const int y0 = std::min(2 * y, h - 1), y1 = std::min(2 * y + 1, h - 1);
      for (int x = 0; x < nw; ++x) {
        const int x0 = std::min(2 * x, w - 1), x1 = std::min(2 * x + 1, w - 1);
        for (int c = 0; c < 3; ++c) {
          const float sum = current[(static_cast<size_t>(y0) * w + x0) * 3 + c] +
                            current[(static_cast<size_t>(y0) * w + x1) * 3 + c] +
                            current[(static_cast<size_t>(y1) * w + x0) * 3 + c] +
                            current[(static_cast<size_t>(y1) * w + x1) * 3 + c];
          next[(static_cast<size_t>(y) * nw + x) * 3 + c] = 0.25f * sum;
        }
      }
    }
    current.swap(next);
    w = nw;
    h = nh;
  }
}

Vector3f Texture::Texel(int x, int y) const {
  const Level& l = levels_[0];
  x = std::min(std::max(x, 0), l.width - 1);
  y = std::min(std::max(y, 0), l.height - 1);
  const uint8_t* p = &l.rgb[(static_cast<size_t>(y) * l.width + x) * 3];
  return Vector3f(p[0], p[1], p[2]) / 255.0f;
}

Vector3f Texture::SampleBilinear(const Level& level, double s, double t) const {
  // Clamp first so that the integer conversions stay defined for any input;
  // at the border both taps read the edge texel (clamp to edge).
  const float x = static_cast<float>(std::min(std::max(s * level.width - 0.5, -1.0), level.width - 1.0));
  const float y = static_cast<float>(std::min(std::max(t * level.height - 0.5, -1.0), level.height - 1.0));
  const float xf = std::floor(x), yf = std::floor(y);
  const int xi = static_cast<int>(xf), yi = static_cast<int>(yf);
  const float ax = x - xf, ay = y - yf;
  const int x0 = std::max(xi, 0), x1 = std::min(xi + 1, level.width - 1);
  const int y0 = std::max(yi, 0), y1 = std::min(yi + 1, level.height - 1);
  const uint8_t* r0 = &level.rgb[static_cast<size_t>(y0) * level.width * 3];
  const uint8_t* r1 = &level.rgb[static_cast<size_t>(y1) * level.width * 3];
  const uint8_t* p00 = r0 + 3 * x0;
  const uint8_t* p10 = r0 + 3 * x1;
  const uint8_t* p01 = r1 + 3 * x0;
  const uint8_t* p11 = r1 + 3 * x1;
  Vector3f out;
  for (int c = 0; c < 3; ++c) {
    const float top = p00[c] + ax * (p10[c] - p00[c]);
    const float bottom = p01[c] + ax * (p11[c] - p01[c]);
    out[c] = (top + ay * (bottom - top)) * (1.0f / 255.0f);
  }
  return out;
}

Vector3f Texture::SampleTrilinear(double s, double t, double lod) const {
  DYPHO_CHECK(!levels_.empty()) << "sampling an empty texture";
  const double max_lod = static_cast<double>(levels_.size() - 1);
  lod = std::isfinite(lod) ? std::min(std::max(lod, 0.0), max_lod) : max_lod;
  const int l0 = static_cast<int>(lod);
  const float f = static_cast<float>(lod - l0);
  const Vector3f a = SampleBilinear(levels_[l0], s, t);
  if (f < 1.0f / 64.0f || l0 + 1 >= num_levels()) return a;
  const Vector3f b = SampleBilinear(levels_[l0 + 1], s, t);
  return a + f * (b - a);
}

Vector3f Texture::SampleFootprint(double s, double t, double ds_du, double dt_du, double ds_dv,
                                  double dt_dv) const {
  constexpr int kMaxAnisotropy = 4;
  const double w = width(), h = height();
  // Footprint axes in texels of level 0.
  const double len_u = std::sqrt(ds_du * w * ds_du * w + dt_du * h * dt_du * h);
  const double len_v = std::sqrt(ds_dv * w * ds_dv * w + dt_dv * h * dt_dv * h);
  double major = len_u, minor = len_v;
  double axis_s = ds_du, axis_t = dt_du;
  if (len_v > len_u) {
    std::swap(major, minor);
    axis_s = ds_dv;
    axis_t = dt_dv;
  }
  if (!std::isfinite(major)) return SampleTrilinear(s, t, 1e9);
  const double ratio = major / std::max(minor, 1e-12);
  // Rounded (not ceiled) so that nearly isotropic footprints take one sample.
  const int n = static_cast<int>(std::min<double>(kMaxAnisotropy, std::max(1.0, std::round(ratio))));
  const double lod = major > 1e-12 ? static_cast<double>(std::log2(static_cast<float>(major / n))) : 0.0;
  if (n == 1) return SampleTrilinear(s, t, lod);
  Vector3f sum = Vector3f::Zero();
  for (int i = 0; i < n; ++i) {
    const double k = (i + 0.5) / n - 0.5;
    sum += SampleTrilinear(s + k * axis_s, t + k * axis_t, lod);
  }
  return sum / static_cast<float>(n);
}

// ---------------------------------------------------------------------------
// Painting.

Vector3f HsvToRgb(double h, double s, double v) {
  h = (h - std::floor(h)) * 6.0;
  const int i = static_cast<int>(h) % 6;
  const double f = h - std::floor(h);
  const double p = v * (1.0 - s), q = v * (1.0 - s * f), r = v * (1.0 - s * (1.0 - f));
  double R = v, G = r, B = p;
  switch (i) {
    case 0:
      R = v;
      G = r;
      B = p;
      break;
    case 1:
      R = q;
      G = v;
      B = p;
      break;
    case 2:
      R = p;
      G = v;
      B = r;
      break;
    case 3:
      R = p;
      G = q;
      B = v;
      break;
    case 4:
      R = r;
      G = p;
      B = v;
      break;
    default:
      R = v;
      G = p;
      B = q;
      break;
  }
  return Vector3f(static_cast<float>(R), static_cast<float>(G), static_cast<float>(B));
}

namespace {

// A float RGB canvas addressed in metres: x to the right, y down, origin at
// the top-left corner.
class Canvas {
 public:
  // `tpm_x`, `tpm_y`: texels per metre along x and y.
  Canvas(int width, int height, double tpm_x, double tpm_y)
      : width_(width),
        height_(height),
        tpm_x_(tpm_x),
        tpm_y_(tpm_y),
        rgb_(static_cast<size_t>(width) * height * 3, 0.5f) {}

  int width() const { return width_; }
  int height() const { return height_; }
  double width_m() const { return width_ / tpm_x_; }
  double height_m() const { return height_ / tpm_y_; }
  // The larger texel side [m].
  double texel_m() const { return 1.0 / std::min(tpm_x_, tpm_y_); }
  const std::vector<float>& rgb() const { return rgb_; }

  void Fill(const Vector3f& c) { Rect(0, 0, width_m(), height_m(), c); }

  // Filled rectangle [x0, x1] x [y0, y1] (metres), at least one texel.
  void Rect(double x0, double y0, double x1, double y1, const Vector3f& c) {
    int ix0, ix1, iy0, iy1;
    if (!Span(x0, x1, width_, tpm_x_, &ix0, &ix1) || !Span(y0, y1, height_, tpm_y_, &iy0, &iy1)) {
      return;
    }
    for (int y = iy0; y < iy1; ++y) {
      float* row = &rgb_[(static_cast<size_t>(y) * width_) * 3];
      for (int x = ix0; x < ix1; ++x) {
        row[3 * x] = c[0];
        row[3 * x + 1] = c[1];
        row[3 * x + 2] = c[2];
      }
    }
  }

  void Outline(double x0, double y0, double x1, double y1, double thickness, const Vector3f& c) {
    thickness = std::max(thickness, texel_m());
    Rect(x0, y0, x1, y0 + thickness, c);
    Rect(x0, y1 - thickness, x1, y1, c);
    Rect(x0, y0, x0 + thickness, y1, c);
    Rect(x1 - thickness, y0, x1, y1, c);
  }

  void Checker(double x0, double y0, double x1, double y1, double cell, const Vector3f& a,
               const Vector3f& b) {
    cell = std::max(cell, 2.0 * texel_m());
    int row = 0;
    for (double y = y0; y < y1; y += cell, ++row) {
      int col = 0;
      for (double x = x0; x < x1; x += cell, ++col) {
        Rect(x, y, std::min(x + cell, x1), std::min(y + cell, y1), ((row + col) & 1) ? a : b);
      }
    }
  }

  // Multiplies the brightness by 1 + amplitude * (noise - 0.5) with value
  // noise of the given cell sizes (metres; anisotropic when they differ).
  void Mottle(uint64_t seed, double cell_x, double cell_y, double amplitude) {
    // Value noise: random values on a lattice of cell_x x cell_y metres,
    // interpolated with smoothstep weights.
    const double fx = 1.0 / (tpm_x_ * cell_x), fy = 1.0 / (tpm_y_ * cell_y);
    const int nx = static_cast<int>(std::floor((width_ - 0.5) * fx)) + 2;
    const int ny = static_cast<int>(std::floor((height_ - 0.5) * fy)) + 2;
    std::vector<float> lattice(static_cast<size_t>(nx) * ny);
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        lattice[static_cast<size_t>(j) * nx + i] =
            static_cast<float>(UnitFromBits(Hash(seed, static_cast<uint64_t>(i), static_cast<uint64_t>(j))));
      }
    }
    auto smooth = [](double f) { return f * f * (3.0 - 2.0 * f); };
    std::vector<int> xi(width_);
    std::vector<float> wx(width_);
    for (int x = 0; x < width_; ++x) {
      const double u = (x + 0.5) * fx;
      xi[x] = static_cast<int>(u);
      wx[x] = static_cast<float>(smooth(u - xi[x]));
    }
    for (int y = 0; y < height_; ++y) {
      const double v = (y + 0.5) * fy;
      const int yi = static_cast<int>(v);
      const float wy = static_cast<float>(smooth(v - yi));
      const float* row0 = &lattice[static_cast<size_t>(yi) * nx];
      const float* row1 = row0 + nx;
      for (int x = 0; x < width_; ++x) {
        const int i = xi[x];
        const float top = row0[i] + wx[x] * (row0[i + 1] - row0[i]);
        const float bottom = row1[i] + wx[x] * (row1[i + 1] - row1[i]);
        const float n = top + wy * (bottom - top);
        const float f = static_cast<float>(1.0 + amplitude * (n - 0.5));
        float* p = &rgb_[(static_cast<size_t>(y) * width_ + x) * 3];
        p[0] *= f;
        p[1] *= f;
        p[2] *= f;
      }
    }
  }

 private:
  static bool Span(double a, double b, int n, double tpm, int* i0, int* i1) {
    if (b < a) std::swap(a, b);
    double fa = std::round(a * tpm), fb = std::round(b * tpm);
    if (fb <= fa) fb = fa + 1.0;
    fa = std::max(fa, 0.0);
    fb = std::min(fb, static_cast<double>(n));
    if (fb <= fa) return false;
    *i0 = static_cast<int>(fa);
    *i1 = static_cast<int>(fb);
    return true;
  }

  int width_, height_;
  double tpm_x_, tpm_y_;
  std::vector<float> rgb_;
};

// A colour that stands out: light on dark or dark on light, any hue.
Vector3f ContrastColour(Rng& rng, bool light) {
  const double h = rng.Uniform();
  const double s = rng.Uniform(0.25, 0.95);
  const double v = light ? rng.Uniform(0.7, 0.97) : rng.Uniform(0.06, 0.35);
  return HsvToRgb(h, s, v);
}

Vector3f Jitter(Rng& rng, const Vector3f& c, double amount) {
  Vector3f out = c;
  for (int i = 0; i < 3; ++i) out[i] = static_cast<float>(out[i] * (1.0 + rng.Uniform(-amount, amount)));
  return out.cwiseMax(0.0f).cwiseMin(1.0f);
}

// Scatters count = density * area / scale^2 rectangles of about `scale`
// metres inside [x0, x1] x [y0, y1]; alternately light and dark, some as
// outlines. The many axis-aligned corners give FAST/ORB their features.
void ScatterRects(Canvas& canvas, Rng& rng, double x0, double y0, double x1, double y1, double scale,
                  double density, double outline_prob) {
  const double area = std::max(0.0, (x1 - x0) * (y1 - y0));
  const int count = static_cast<int>(std::ceil(density * area / (scale * scale)));
  for (int i = 0; i < count; ++i) {
    const double w = scale * rng.Uniform(0.35, 1.3);
    const double h = scale * rng.Uniform(0.35, 1.3);
    const double x = rng.Uniform(x0, std::max(x0, x1 - w));
    const double y = rng.Uniform(y0, std::max(y0, y1 - h));
    const Vector3f c = ContrastColour(rng, rng.Bernoulli(0.5));
    if (rng.Bernoulli(outline_prob)) {
      canvas.Outline(x, y, std::min(x + w, x1), std::min(y + h, y1), 0.12 * std::min(w, h), c);
    } else {
      canvas.Rect(x, y, std::min(x + w, x1), std::min(y + h, y1), c);
    }
  }
}

// Rows of small dark bars, like lines of text.
void TextLines(Canvas& canvas, Rng& rng, double x0, double y0, double x1, double y1, double line_h,
               const Vector3f& ink) {
  for (double y = y0 + 0.5 * line_h; y + line_h < y1; y += 1.8 * line_h) {
    double x = x0 + rng.Uniform(0.0, 2.0) * line_h;
    const double end = x1 - rng.Uniform(0.0, 0.4) * (x1 - x0);
    while (x < end) {
      const double word = line_h * rng.Uniform(1.0, 5.0);
      canvas.Rect(x, y, std::min(x + word, end), y + line_h, ink);
      x += word + line_h * rng.Uniform(0.6, 1.2);
    }
  }
}

void PaintPoster(Canvas& canvas, Rng& rng, double x0, double y0, double x1, double y1) {
  const bool light = rng.Bernoulli(0.5);
  canvas.Rect(x0, y0, x1, y1, ContrastColour(rng, light));
  const int kind = rng.UniformInt(0, 2);
  const double size = std::min(x1 - x0, y1 - y0);
  if (kind == 0) {
    canvas.Checker(x0 + 0.1 * size, y0 + 0.1 * size, x1 - 0.1 * size, y1 - 0.4 * size,
                   size * rng.Uniform(0.06, 0.15), ContrastColour(rng, true), ContrastColour(rng, false));
  } else if (kind == 1) {
    // Vertical or horizontal colour bands.
    const bool vertical = rng.Bernoulli(0.5);
    double p = vertical ? x0 : y0;
    const double end = vertical ? x1 : y1;
    while (p < end) {
      const double band = size * rng.Uniform(0.04, 0.15);
      if (vertical) {
        canvas.Rect(p, y0, std::min(p + band, end), y1, ContrastColour(rng, rng.Bernoulli(0.5)));
      } else {
        canvas.Rect(x0, p, x1, std::min(p + band, end), ContrastColour(rng, rng.Bernoulli(0.5)));
      }
      p += band;
    }
  }
  ScatterRects(canvas, rng, x0, y0, x1, y1, 0.3 * size, 0.8, 0.2);
  ScatterRects(canvas, rng, x0, y0, x1, y1, 0.1 * size, 1.0, 0.3);
  TextLines(canvas, rng, x0 + 0.08 * size, y1 - 0.3 * size, x1 - 0.08 * size, y1 - 0.05 * size, 0.025 * size,
            ContrastColour(rng, !light));
  canvas.Outline(x0, y0, x1, y1, 0.025 * size, ContrastColour(rng, false));
}

void PaintWall(Canvas& c, Rng& rng, uint64_t seed) {
  const double W = c.width_m(), H = c.height_m();
  c.Fill(HsvToRgb(rng.Uniform(), rng.Uniform(0.08, 0.25), rng.Uniform(0.7, 0.85)));
  c.Mottle(Hash(seed, 1), 0.6, 0.6, 0.25);
  // Skirting board.
  c.Rect(0, H - 0.1, W, H, ContrastColour(rng, false));
  ScatterRects(c, rng, 0, 0, W, H - 0.1, 0.25, 0.15, 0.3);
  const int posters = std::max(1, static_cast<int>(W * H / 1.6));
  for (int i = 0; i < posters; ++i) {
    const double pw = rng.Uniform(0.35, 1.1), ph = rng.Uniform(0.4, 1.0);
    const double x = rng.Uniform(0.0, std::max(0.0, W - pw));
    const double y = rng.Uniform(0.15, std::max(0.15, H - 0.3 - ph));
    PaintPoster(c, rng, x, y, x + pw, y + ph);
  }
  ScatterRects(c, rng, 0, 0, W, H, 0.09, 0.12, 0.3);
  ScatterRects(c, rng, 0, 0, W, H, 0.035, 0.08, 0.2);
}

void PaintFloor(Canvas& c, Rng& rng, uint64_t seed) {
  const double W = c.width_m(), H = c.height_m();
  const Vector3f base = HsvToRgb(rng.Uniform(), rng.Uniform(0.1, 0.4), rng.Uniform(0.45, 0.7));
  const double tile = rng.Uniform(0.4, 0.6);
  const Vector3f grout = ContrastColour(rng, false);
  for (double y = 0; y < H; y += tile) {
    for (double x = 0; x < W; x += tile) {
      c.Rect(x, y, x + tile, y + tile, Jitter(rng, base, 0.25));
      const double r = rng.Uniform();
      if (r < 0.25) {
        c.Checker(x + 0.15 * tile, y + 0.15 * tile, x + 0.85 * tile, y + 0.85 * tile,
                  tile * rng.Uniform(0.1, 0.2), ContrastColour(rng, true), ContrastColour(rng, false));
      } else if (r < 0.5) {
        const double m = rng.Uniform(0.1, 0.3) * tile;
        c.Rect(x + m, y + m, x + tile - m, y + tile - m, ContrastColour(rng, rng.Bernoulli(0.5)));
      }
      c.Outline(x, y, x + tile, y + tile, 0.012, grout);
    }
  }
  ScatterRects(c, rng, 0, 0, W, H, 0.12, 0.08, 0.3);
  ScatterRects(c, rng, 0, 0, W, H, 0.04, 0.05, 0.2);
  c.Mottle(Hash(seed, 2), 0.8, 0.8, 0.3);
}

void PaintCeiling(Canvas& c, Rng& rng, uint64_t seed) {
  const double W = c.width_m(), H = c.height_m();
  c.Fill(HsvToRgb(rng.Uniform(), rng.Uniform(0.0, 0.1), rng.Uniform(0.8, 0.9)));
  const double panel = 0.6;
  const Vector3f line = HsvToRgb(0.0, 0.0, 0.45);
  for (double y = 0; y < H; y += panel) {
    for (double x = 0; x < W; x += panel) {
      if (rng.Bernoulli(0.12)) {
        c.Rect(x + 0.05, y + 0.15, x + panel - 0.05, y + panel - 0.15, HsvToRgb(0.15, 0.1, 1.0));
      } else if (rng.Bernoulli(0.2)) {
        c.Rect(x + 0.2, y + 0.2, x + 0.4, y + 0.4, ContrastColour(rng, false));
      }
      c.Outline(x, y, x + panel, y + panel, 0.015, line);
    }
  }
  ScatterRects(c, rng, 0, 0, W, H, 0.06, 0.3, 0.4);
  c.Mottle(Hash(seed, 3), 0.5, 0.5, 0.2);
}

void PaintWood(Canvas& c, Rng& rng, uint64_t seed) {
  const double W = c.width_m(), H = c.height_m();
  c.Fill(HsvToRgb(rng.Uniform(0.05, 0.11), rng.Uniform(0.45, 0.75), rng.Uniform(0.35, 0.65)));
  c.Mottle(Hash(seed, 4), 0.4, 0.012, 0.6);  // grain streaks along x
  c.Mottle(Hash(seed, 5), 0.15, 0.15, 0.25);
  const int papers = static_cast<int>(std::ceil(W * H / 0.3));
  for (int i = 0; i < papers; ++i) {
    const double pw = rng.Uniform(0.1, 0.3), ph = rng.Uniform(0.1, 0.3);
    const double x = rng.Uniform(0.0, std::max(0.0, W - pw)), y = rng.Uniform(0.0, std::max(0.0, H - ph));
    c.Rect(x, y, x + pw, y + ph, HsvToRgb(rng.Uniform(), rng.Uniform(0.0, 0.3), 0.95));
    TextLines(c, rng, x + 0.01, y + 0.01, x + pw - 0.01, y + ph - 0.01, 0.006, ContrastColour(rng, false));
  }
  ScatterRects(c, rng, 0, 0, W, H, 0.05, 0.1, 0.3);
}

void PaintBooks(Canvas& c, Rng& rng, uint64_t seed) {
  const double W = c.width_m(), H = c.height_m();
  double x = 0;
  while (x < W) {
    const double w = rng.Uniform(0.02, 0.07);
    const Vector3f spine = ContrastColour(rng, rng.Bernoulli(0.5));
    c.Rect(x, 0, x + w, H, spine);
    const int labels = rng.UniformInt(1, 3);
    for (int i = 0; i < labels; ++i) {
      const double y = rng.Uniform(0.05, 0.85) * H;
      c.Rect(x + 0.2 * w, y, x + 0.8 * w, y + rng.Uniform(0.03, 0.12) * H,
             ContrastColour(rng, spine.mean() < 0.5f));
    }
    c.Rect(x, 0, x + 0.1 * w, H, spine * 0.6f);
    x += w;
  }
  c.Mottle(Hash(seed, 6), 0.3, 0.3, 0.2);
}

void PaintCube(Canvas& c, Rng& rng, uint64_t seed) {
  const double W = c.width_m(), H = c.height_m();
  const double cell = rng.Uniform(0.03, 0.09);
  c.Checker(0, 0, W, H, cell, ContrastColour(rng, true), ContrastColour(rng, false));
  ScatterRects(c, rng, 0, 0, W, H, 0.06, 0.1, 0.3);
  c.Outline(0, 0, W, H, 0.02, ContrastColour(rng, rng.Bernoulli(0.5)));
  c.Mottle(Hash(seed, 7), 0.2, 0.2, 0.2);
}

void PaintCabinet(Canvas& c, Rng& rng, uint64_t seed) {
  const double W = c.width_m(), H = c.height_m();
  const Vector3f base = ContrastColour(rng, rng.Bernoulli(0.6));
  c.Fill(base);
  const int doors = std::max(1, static_cast<int>(std::round(W / 0.45)));
  const double dw = W / doors;
  const Vector3f frame = ContrastColour(rng, base.mean() < 0.5f);
  for (int i = 0; i < doors; ++i) {
    const double x = i * dw;
    c.Outline(x + 0.02, 0.02, x + dw - 0.02, H - 0.02, 0.015, frame);
    c.Outline(x + 0.07, 0.07, x + dw - 0.07, H - 0.07, 0.008, frame);
    const double hx = (i % 2 == 0) ? x + dw - 0.1 : x + 0.06;
    c.Rect(hx, 0.45 * H, hx + 0.04, 0.45 * H + 0.12, ContrastColour(rng, false));
  }
  ScatterRects(c, rng, 0, 0, W, H, 0.08, 0.12, 0.3);
  ScatterRects(c, rng, 0, 0, W, H, 0.03, 0.08, 0.2);
  c.Mottle(Hash(seed, 8), 0.3, 0.3, 0.2);
}

void PaintScreen(Canvas& c, Rng& rng, uint64_t seed) {
  const double W = c.width_m(), H = c.height_m();
  c.Fill(HsvToRgb(0.6, 0.3, 0.1));
  const int windows = rng.UniformInt(2, 4);
  for (int i = 0; i < windows; ++i) {
    const double ww = rng.Uniform(0.3, 0.7) * W, wh = rng.Uniform(0.3, 0.7) * H;
    const double x = rng.Uniform(0.0, W - ww), y = rng.Uniform(0.0, H - wh);
    c.Rect(x, y, x + ww, y + wh, HsvToRgb(rng.Uniform(), 0.1, 0.92));
    c.Rect(x, y, x + ww, y + 0.04 * H, ContrastColour(rng, false));
    TextLines(c, rng, x + 0.01, y + 0.06 * H, x + ww - 0.01, y + wh - 0.01, 0.006,
              ContrastColour(rng, false));
  }
  c.Mottle(Hash(seed, 9), 0.2, 0.2, 0.1);
}

void PaintShirt(Canvas& c, Rng& rng, uint64_t seed, const Vector3f& base, int variant) {
  const double W = c.width_m(), H = c.height_m();
  c.Fill(base);
  const Vector3f stripe = (base * 0.35f).cwiseMin(1.0f);
  const Vector3f light = (base * 0.4f + Vector3f::Constant(0.6f)).cwiseMin(1.0f);
  if (variant % 3 == 0) {  // horizontal stripes
    for (double y = 0; y < H; y += 0.08) c.Rect(0, y, W, y + 0.03, stripe);
  } else if (variant % 3 == 1) {  // plaid
    for (double y = 0; y < H; y += 0.09) c.Rect(0, y, W, y + 0.025, stripe);
    for (double x = 0; x < W; x += 0.09) c.Rect(x, 0, x + 0.02, H, light);
  } else {  // checker
    c.Checker(0, 0, W, H, 0.06, base, stripe);
  }
  ScatterRects(c, rng, 0, 0, W, H, 0.05, 0.08, 0.3);
  c.Mottle(Hash(seed, 10), 0.1, 0.1, 0.25);
}

void PaintPants(Canvas& c, Rng& rng, uint64_t seed, const Vector3f& base) {
  const double W = c.width_m(), H = c.height_m();
  c.Fill(base);
  const Vector3f seam = (base * 1.8f).cwiseMin(1.0f);
  c.Rect(0.5 * W - 0.004, 0, 0.5 * W + 0.004, H, seam);
  c.Outline(0.15 * W, 0.05 * H, 0.85 * W, 0.25 * H, 0.006, seam);
  c.Checker(0.2 * W, 0.6 * H, 0.8 * W, 0.7 * H, 0.02, seam, base * 0.5f);
  ScatterRects(c, rng, 0, 0, W, H, 0.04, 0.05, 0.4);
  c.Mottle(Hash(seed, 11), 0.05, 0.3, 0.4);
}

void PaintHead(Canvas& c, Rng& rng, uint64_t seed, const Vector3f& skin, const Vector3f& hair, bool face) {
  const double W = c.width_m(), H = c.height_m();
  c.Fill(skin);
  c.Mottle(Hash(seed, 12), 0.03, 0.03, 0.15);
  c.Rect(0, 0, W, (face ? 0.22 : 0.45) * H, hair);
  if (face) {
    const Vector3f dark(0.08f, 0.06f, 0.05f);
    c.Rect(0.2 * W, 0.3 * H, 0.42 * W, 0.34 * H, dark);  // brows
    c.Rect(0.58 * W, 0.3 * H, 0.8 * W, 0.34 * H, dark);
    c.Rect(0.25 * W, 0.4 * H, 0.38 * W, 0.47 * H, Vector3f(0.95f, 0.95f, 0.95f));  // eyes
    c.Rect(0.62 * W, 0.4 * H, 0.75 * W, 0.47 * H, Vector3f(0.95f, 0.95f, 0.95f));
    c.Rect(0.29 * W, 0.41 * H, 0.34 * W, 0.46 * H, dark);
    c.Rect(0.66 * W, 0.41 * H, 0.71 * W, 0.46 * H, dark);
    c.Rect(0.45 * W, 0.5 * H, 0.55 * W, 0.64 * H, skin * 0.75f);                   // nose
    c.Rect(0.33 * W, 0.72 * H, 0.67 * W, 0.78 * H, Vector3f(0.6f, 0.15f, 0.15f));  // mouth
  }
  (void)rng;
}

}  // namespace

Texture PaintTexture(const PaintStyle& style, double width_m, double height_m, double texels_per_m,
                     uint64_t seed) {
  DYPHO_CHECK(width_m > 0 && height_m > 0 && texels_per_m > 0) << "bad texture size";
  auto texels = [&](double m) {
    return static_cast<int>(std::min(2048.0, std::max(4.0, std::ceil(m * texels_per_m))));
  };
  const int w = texels(width_m), h = texels(height_m);
  // The canvas spans the surface exactly (texels may be slightly non-square).
  Canvas canvas(w, h, w / width_m, h / height_m);
  Rng rng(Hash(seed, 0x7e47u));
  switch (style.material) {
    case Material::kWall:
      PaintWall(canvas, rng, seed);
      break;
    case Material::kFloor:
      PaintFloor(canvas, rng, seed);
      break;
    case Material::kCeiling:
      PaintCeiling(canvas, rng, seed);
      break;
    case Material::kWood:
      PaintWood(canvas, rng, seed);
      break;
    case Material::kBooks:
      PaintBooks(canvas, rng, seed);
      break;
    case Material::kCube:
      PaintCube(canvas, rng, seed);
      break;
    case Material::kCabinet:
      PaintCabinet(canvas, rng, seed);
      break;
    case Material::kScreen:
      PaintScreen(canvas, rng, seed);
      break;
    case Material::kShirt:
      PaintShirt(canvas, rng, seed, style.base, style.variant);
      break;
    case Material::kPants:
      PaintPants(canvas, rng, seed, style.base);
      break;
    case Material::kFace:
      PaintHead(canvas, rng, seed, style.base, style.accent, true);
      break;
    case Material::kHead:
      PaintHead(canvas, rng, seed, style.base, style.accent, false);
      break;
    case Material::kHair:
      canvas.Fill(style.accent);
      canvas.Mottle(Hash(seed, 13), 0.01, 0.05, 0.6);
      break;
    case Material::kSkin:
      canvas.Fill(style.base);
      canvas.Mottle(Hash(seed, 14), 0.03, 0.03, 0.2);
      break;
    case Material::kShoe:
      canvas.Fill(Vector3f(0.08f, 0.07f, 0.07f));
      canvas.Rect(0, 0.75 * canvas.height_m(), canvas.width_m(), canvas.height_m(),
                  Vector3f(0.85f, 0.85f, 0.8f));
      break;
  }
  return Texture(w, h, canvas.rgb());
}

}  // namespace dypho::synth
