// Deterministic random numbers for the synthetic sequence generator.
//
// The standard library's distributions are implementation-defined, so the
// same seed could give different sequences with another standard library.
// Everything here is spelled out: SplitMix64 for sequential draws (Steele,
// Lea, Flood 2014, "Fast splittable pseudorandom number generators") and the
// same mixer as a counter-based hash for per-pixel draws, which makes the
// result independent of the thread count and of the order pixels are visited.
#pragma once

#include <cmath>
#include <cstdint>

namespace dypho::synth {

// SplitMix64 output function: a bijective 64-bit mixer.
inline uint64_t Mix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// Hash of a key sequence; order matters.
inline uint64_t Hash(uint64_t a, uint64_t b) { return Mix64(Mix64(a) ^ (b + 0x632be59bd9b4e019ULL)); }
inline uint64_t Hash(uint64_t a, uint64_t b, uint64_t c) { return Hash(Hash(a, b), c); }
inline uint64_t Hash(uint64_t a, uint64_t b, uint64_t c, uint64_t d) { return Hash(Hash(a, b, c), d); }

// Uniform in [0, 1) from the top 53 bits.
inline double UnitFromBits(uint64_t bits) { return static_cast<double>(bits >> 11) * 0x1.0p-53; }

// Standard normal from two hash words (Box-Muller, the cosine branch).
// Single precision inside (enough for noise, and twice as fast); u1 keeps
// 24 bits, so the tails end near 5.8 sigma.
inline double NormalFromBits(uint64_t bits_a, uint64_t bits_b) {
  const float u1 = static_cast<float>((bits_a >> 40) + 1) * 0x1.0p-24f;  // (0, 1]
  const float u2 = static_cast<float>(bits_b >> 40) * 0x1.0p-24f;        // [0, 1)
  return std::sqrt(-2.0f * std::log(u1)) * std::cos(6.2831853071795864769f * u2);
}

// Sequential generator (SplitMix64).
class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(seed) {}
  uint64_t Next() {
    state_ += 0x9e3779b97f4a7c15ULL;
    uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1).
  double Uniform() { return UnitFromBits(Next()); }
  // Uniform in [lo, hi).
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // Uniform integer in [lo, hi] (inclusive).
  int UniformInt(int lo, int hi) {
    return lo + static_cast<int>(Uniform() * (static_cast<double>(hi) - lo + 1.0));
  }
  bool Bernoulli(double p) { return Uniform() < p; }
  double Normal() {
    const uint64_t a = Next();
    return NormalFromBits(a, Next());
  }

 private:
  uint64_t state_;
};

}  // namespace dypho::synth
