#include "engine/stereo/dense_match.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "engine/stereo/descriptor.h"

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace dypho::stereo {

namespace {

constexpr int kMaxCost = kDescriptorBytes * 255;  // largest L1 descriptor distance
constexpr uint16_t kNoEnergy = 0xFFFF;            // padding and excluded candidates

// The energy in 16-bit fixed point (see the header): the cost scale S and the
// prior table Q[k] for k = |d - round(mu)|.
struct FixedEnergy {
  int shift = 0;                 // S = 2^shift
  std::vector<uint16_t> prior;   // Q[k], k = 0 .. nd + 2 plane_radius + 1
};

FixedEnergy MakeFixedEnergy(const ElasOptions& o, int nd) {
  std::vector<double> p(size_t(nd + 2 * o.plane_radius + 2));
  for (size_t k = 0; k < p.size(); ++k)
    p[k] = -std::log(double(o.gamma) + std::exp(-double(k * k) / (2.0 * o.sigma * o.sigma))) / o.beta;
  const double lowest = *std::min_element(p.begin(), p.end());
  const double range = *std::max_element(p.begin(), p.end()) - lowest;
  FixedEnergy f;
  // The largest S = 2^shift (at most 2^8) with S (kMaxCost + range) below kNoEnergy.
  while (f.shift < 8 && double(1 << (f.shift + 1)) * (kMaxCost + range) < kNoEnergy - 1) ++f.shift;
  const int prior_cap = kNoEnergy - 1 - (kMaxCost << f.shift);
  f.prior.resize(p.size());
  for (size_t k = 0; k < p.size(); ++k)
    f.prior[k] = uint16_t(std::min<double>(prior_cap, std::lround((p[k] - lowest) * (1 << f.shift))));
  return f;
}

// The first lowest energy and its index; then the lowest at |d - d_best| > 1.
struct Choice {
  int best_d = 0;
  uint16_t best = kNoEnergy, second = kNoEnergy;
};

// The reference: candidates in order (plane neighbourhood, then the grid's
// disparities outside it), one at a time.
Choice ChooseScalar(const uint8_t* f, const uint8_t* other, ptrdiff_t stride, const int16_t* cand, int n,
                    int mu, const FixedEnergy& fixed) {
  const int last_prior = int(fixed.prior.size()) - 1;
  uint16_t energy[512];
  Choice c;
  for (int i = 0; i < n; ++i) {
    energy[i] = uint16_t((DescriptorDistance(f, other + cand[i] * stride) << fixed.shift) +
                         fixed.prior[std::min(std::abs(cand[i] - mu), last_prior)]);
    if (energy[i] < c.best) c.best = energy[i], c.best_d = cand[i];
  }
  for (int i = 0; i < n; ++i)
    if (std::abs(cand[i] - c.best_d) > 1 && energy[i] < c.second) c.second = energy[i];
  return c;
}

#if defined(__AVX2__)
// Eight candidates at a time. Lanes whose disparity is not a candidate (mask
// set) get kNoEnergy; their descriptors are read at a clamped disparity.
class EnergyBatches {
 public:
  // The prior by a 16-entry byte shuffle (prior_lo/hi: the low and high bytes
  // of Q[0..15]) when lookup16, that is Q flat beyond |d - mu| = 15.
  struct PriorTable {
    bool lookup16 = false;
    __m128i lo{}, hi{};
  };
  static PriorTable MakePriorTable(const FixedEnergy& fixed) {
    PriorTable t;
    t.lookup16 = fixed.prior.size() > 16;
    for (size_t k = 16; k < fixed.prior.size() && t.lookup16; ++k) t.lookup16 = fixed.prior[k] == fixed.prior[15];
    if (t.lookup16) {
      alignas(16) uint8_t lo[16], hi[16];
      for (int k = 0; k < 16; ++k) lo[k] = uint8_t(fixed.prior[k] & 0xFF), hi[k] = uint8_t(fixed.prior[k] >> 8);
      t.lo = _mm_load_si128(reinterpret_cast<const __m128i*>(lo));
      t.hi = _mm_load_si128(reinterpret_cast<const __m128i*>(hi));
    }
    return t;
  }

  // mu is clamped to -1000: |d - mu| then exceeds every table index either way.
  EnergyBatches(const uint8_t* f, const uint8_t* other, ptrdiff_t stride, int mu, const FixedEnergy& fixed,
                const PriorTable& table)
      : f256_(_mm256_broadcastsi128_si256(_mm_loadu_si128(reinterpret_cast<const __m128i*>(f)))),
        other_(other), stride_(stride), mu_(_mm_set1_epi16(int16_t(std::max(mu, -1000)))), fixed_(fixed),
        table_(table) {}

  // d: eight disparities; invalid: 0xFFFF lanes to ignore; d_addr: d clamped
  // to disparities that are safe to read.
  void Add(__m128i d, __m128i invalid, __m128i d_addr) {
    alignas(16) int16_t a[8];
    _mm_store_si128(reinterpret_cast<__m128i*>(a), d_addr);
    __m256i s[4];
    for (int k = 0; k < 4; ++k) {
      const __m128i lo = _mm_loadu_si128(reinterpret_cast<const __m128i*>(other_ + a[2 * k] * stride_));
      const __m128i hi = _mm_loadu_si128(reinterpret_cast<const __m128i*>(other_ + a[2 * k + 1] * stride_));
      s[k] = _mm256_sad_epu8(_mm256_inserti128_si256(_mm256_castsi128_si256(lo), hi, 1), f256_);
    }
    // 64-bit lanes [a_lo, a_hi | b_lo, b_hi] of candidates a = 2k, b = 2k+1:
    // the four registers' lanes as 16-bit words, then the halves added.
    const __m256i t = _mm256_or_si256(_mm256_or_si256(s[0], _mm256_slli_epi64(s[1], 16)),
                                      _mm256_or_si256(_mm256_slli_epi64(s[2], 32), _mm256_slli_epi64(s[3], 48)));
    const __m256i u = _mm256_add_epi16(t, _mm256_shuffle_epi32(t, _MM_SHUFFLE(1, 0, 3, 2)));
    // Low lane word k: candidate 2k; high lane word k: 2k+1.
    const __m128i cost = _mm_unpacklo_epi16(_mm256_castsi256_si128(u), _mm256_extracti128_si256(u, 1));
    // Unsigned minimum: the kPad lanes may wrap (they are invalid anyway).
    const __m128i k = _mm_min_epu16(_mm_abs_epi16(_mm_sub_epi16(d, mu_)), _mm_set1_epi16(int16_t(fixed_.prior.size() - 1)));
    __m128i prior;
    if (table_.lookup16) {
      const __m128i k8 = _mm_packus_epi16(_mm_min_epu16(k, _mm_set1_epi16(15)), _mm_setzero_si128());
      prior = _mm_unpacklo_epi8(_mm_shuffle_epi8(table_.lo, k8), _mm_shuffle_epi8(table_.hi, k8));
    } else {
      alignas(16) int16_t kk[8];
      alignas(16) uint16_t p[8];
      _mm_store_si128(reinterpret_cast<__m128i*>(kk), k);
      for (int i = 0; i < 8; ++i) p[i] = fixed_.prior[uint16_t(kk[i])];
      prior = _mm_load_si128(reinterpret_cast<const __m128i*>(p));
    }
    d_[n_] = d;
    e_[n_++] = _mm_or_si128(_mm_add_epi16(_mm_sll_epi16(cost, _mm_cvtsi32_si128(fixed_.shift)), prior), invalid);
  }

  Choice Choose() const {
    Choice c;
    int best_b = 0, best_lane = 0;
    for (int b = 0; b < n_; ++b) {
      const uint32_t m = uint32_t(_mm_cvtsi128_si32(_mm_minpos_epu16(e_[b])));
      if (uint16_t(m) < c.best) c.best = uint16_t(m), best_b = b, best_lane = int(m >> 16);
    }
    if (c.best == kNoEnergy) return c;
    alignas(16) int16_t d[8];
    _mm_store_si128(reinterpret_cast<__m128i*>(d), d_[best_b]);
    c.best_d = d[best_lane];
    const __m128i best_d = _mm_set1_epi16(int16_t(c.best_d)), two = _mm_set1_epi16(2);
    for (int b = 0; b < n_; ++b) {
      const __m128i adjacent = _mm_cmplt_epi16(_mm_abs_epi16(_mm_sub_epi16(d_[b], best_d)), two);
      const uint16_t m = uint16_t(_mm_cvtsi128_si32(_mm_minpos_epu16(_mm_or_si128(e_[b], adjacent))));
      if (m < c.second) c.second = m;
    }
    return c;
  }

 private:
  static constexpr int kMaxBatches = 64;
  __m256i f256_;
  const uint8_t* other_;
  ptrdiff_t stride_;
  __m128i mu_;
  const FixedEnergy& fixed_;
  const PriorTable& table_;
  __m128i d_[kMaxBatches], e_[kMaxBatches];
  int n_ = 0;
};
#endif

DenseMatch MatchDenseImpl(const cv::Mat& desc_ref, const cv::Mat& desc_other, const cv::Mat& texture_ref,
                          const cv::Mat& prior, const std::vector<SupportPoint>& points, bool right_image,
                          const ElasOptions& o, bool simd) {
  const int w = desc_ref.cols, h = desc_ref.rows, g = o.grid_size;
  const int gw = (w + g - 1) / g, gh = (h + g - 1) / g, nd = o.max_disparity + 1;
  // Grid of candidate disparities (a flag per cell and disparity, then lists
  // in ascending order, each padded to a multiple of 8 with kPad).
  std::vector<uint8_t> flags(size_t(gw) * gh * nd, 0);
  for (const SupportPoint& p : points) {
    const int u = right_image ? std::clamp(p.u - p.d, 0, w - 1) : p.u;
    const int ci = u / g, cj = p.v / g;
    for (int jj = std::max(0, cj - o.grid_radius); jj <= std::min(gh - 1, cj + o.grid_radius); ++jj)
      for (int ii = std::max(0, ci - o.grid_radius); ii <= std::min(gw - 1, ci + o.grid_radius); ++ii)
        for (int d = std::max(o.min_disparity, p.d - 1); d <= std::min(o.max_disparity, p.d + 1); ++d)
          flags[(size_t(jj) * gw + ii) * nd + d] = 1;
  }
  constexpr int16_t kPad = std::numeric_limits<int16_t>::max();
  std::vector<int16_t> lists;
  std::vector<int> list_begin(size_t(gw) * gh + 1, 0);
  for (size_t c = 0; c + 1 < list_begin.size(); ++c) {
    list_begin[c] = int(lists.size());
    for (int d = 0; d < nd; ++d)
      if (flags[c * nd + d]) lists.push_back(int16_t(d));
    while (lists.size() % 8) lists.push_back(kPad);
  }
  list_begin.back() = int(lists.size());
  const FixedEnergy fixed = MakeFixedEnergy(o, nd);
  // Confidence 1 - exp(-(E_second - E_best)) by table (E = energy_unit x fixed energy).
  const double energy_unit = double(o.beta) / double(1 << fixed.shift);
  std::vector<float> confidence_of;
  for (int diff = 0; diff < int(kNoEnergy); ++diff) {
    confidence_of.push_back(float(1.0 - std::exp(-energy_unit * diff)));
    if (confidence_of.back() == 1.f) break;
  }
  const int last_confidence = int(confidence_of.size()) - 1;
#if defined(__AVX2__)
  const EnergyBatches::PriorTable prior_table = EnergyBatches::MakePriorTable(fixed);
  simd = simd && (2 * o.plane_radius + 8) / 8 + (nd + 7) / 8 <= 64;
#else
  simd = false;
  (void)simd;
#endif
  DenseMatch out;
  out.disparity.create(h, w, CV_32F);
  out.confidence.create(h, w, CV_32F);
  const int sign = right_image ? 1 : -1;  // other-image column = u + sign * d
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& rows) {
    std::vector<int16_t> candidates(size_t(nd + 2 * o.plane_radius + 1));
    for (int v = rows.start; v < rows.end; ++v) {
      const uint8_t* ref_row = desc_ref.ptr<uint8_t>(v);
      const uint8_t* other_row = desc_other.ptr<uint8_t>(v);
      const float* mu_row = prior.ptr<float>(v);
      const uint16_t* tex_row = texture_ref.ptr<uint16_t>(v);
      float* d_out = out.disparity.ptr<float>(v);
      float* c_out = out.confidence.ptr<float>(v);
      for (int u = 0; u < w; ++u) {
        d_out[u] = -1.f, c_out[u] = 0.f;
        if (std::isnan(mu_row[u]) || tex_row[u] < o.match_texture) continue;
        // Disparities whose match lies inside the other image, 2 px from its border
        // (where descriptors see replicated pixels).
        const int d_hi = std::min(o.max_disparity, right_image ? w - 3 - u : u - 2);
        if (d_hi < o.min_disparity) continue;
        const int mu = int(std::lround(mu_row[u]));
        // The prior puts the match outside the other image: no estimate here
        // (a choice clipped to d_hi would pass the left-right check).
        if (mu > d_hi) continue;
        // Candidates: the plane's neighbourhood, then the grid's disparities
        // outside it.
        const int p_lo = std::max(o.min_disparity, mu - o.plane_radius), p_hi = std::min(d_hi, mu + o.plane_radius);
        const size_t cell = size_t(v / g) * gw + u / g;
        const uint8_t* f = ref_row + u * kDescriptorBytes;
        const uint8_t* other = other_row + u * kDescriptorBytes;
        const ptrdiff_t stride = sign * kDescriptorBytes;
        Choice c;
#if defined(__AVX2__)
        if (simd) {
          EnergyBatches batches(f, other, stride, mu, fixed, prior_table);
          const __m128i lane = _mm_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7);
          const __m128i lo = _mm_set1_epi16(int16_t(p_lo)), hi = _mm_set1_epi16(int16_t(p_hi));
          const __m128i top = _mm_set1_epi16(int16_t(d_hi));
          for (int d0 = p_lo; d0 <= p_hi; d0 += 8) {
            const __m128i d = _mm_add_epi16(_mm_set1_epi16(int16_t(d0)), lane);
            batches.Add(d, _mm_cmpgt_epi16(d, hi), _mm_min_epi16(d, hi));
          }
          for (int i = list_begin[cell]; i < list_begin[cell + 1]; i += 8) {
            const __m128i d = _mm_loadu_si128(reinterpret_cast<const __m128i*>(lists.data() + i));
            const __m128i inside = _mm_andnot_si128(_mm_cmplt_epi16(d, lo), _mm_cmpgt_epi16(_mm_add_epi16(hi, _mm_set1_epi16(1)), d));
            const __m128i invalid = _mm_or_si128(_mm_cmpgt_epi16(d, top), inside);
            batches.Add(d, invalid, _mm_min_epi16(d, top));
          }
          c = batches.Choose();
        } else
#endif
        {
          int n = 0;
          for (int d = p_lo; d <= p_hi; ++d) candidates[n++] = int16_t(d);
          for (int i = list_begin[cell]; i < list_begin[cell + 1]; ++i) {
            const int d = lists[size_t(i)];
            if (d > d_hi) break;  // also at the padding (kPad)
            if (d < p_lo || d > p_hi) candidates[n++] = int16_t(d);
          }
          c = ChooseScalar(f, other, stride, candidates.data(), n, mu, fixed);
        }
        if (c.best == kNoEnergy) continue;
        const int best_d = c.best_d;
        float disparity = float(best_d);
        if (o.subpixel && !right_image && best_d > o.min_disparity && best_d < d_hi) {
          const float cm = float(DescriptorDistance(f, other_row + (u - best_d + 1) * kDescriptorBytes));
          const float c0 = float(DescriptorDistance(f, other_row + (u - best_d) * kDescriptorBytes));
          const float cp = float(DescriptorDistance(f, other_row + (u - best_d - 1) * kDescriptorBytes));
          const float curvature = cm - 2 * c0 + cp;
          if (curvature > 0) disparity += std::clamp(0.5f * (cm - cp) / curvature, -0.5f, 0.5f);
        }
        d_out[u] = disparity;
        c_out[u] = c.second == kNoEnergy ? 0.f : confidence_of[std::min<int>(c.second - c.best, last_confidence)];
      }
    }
  });
  return out;
}

}  // namespace

DenseMatch MatchDense(const cv::Mat& desc_ref, const cv::Mat& desc_other, const cv::Mat& texture_ref,
                      const cv::Mat& prior, const std::vector<SupportPoint>& points,
                      bool right_image, const ElasOptions& o) {
  return MatchDenseImpl(desc_ref, desc_other, texture_ref, prior, points, right_image, o, true);
}

DenseMatch MatchDenseReference(const cv::Mat& desc_ref, const cv::Mat& desc_other, const cv::Mat& texture_ref,
                               const cv::Mat& prior, const std::vector<SupportPoint>& points,
                               bool right_image, const ElasOptions& o) {
  return MatchDenseImpl(desc_ref, desc_other, texture_ref, prior, points, right_image, o, false);
}

bool MatchDenseIsVectorised() {
#if defined(__AVX2__)
  return true;
#else
  return false;
#endif
}

}  // namespace dypho::stereo
