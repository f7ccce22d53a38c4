// Portable draws from std::mt19937_64 (the std:: distributions are
// implementation-defined, so the same seed could give different episodes on
// different standard libraries), seed mixing, and the float rounding the
// datasets store. Shared by the environments and the dataset makers.
#ifndef MSSPR_SIM_RANDOM_UTIL_H_
#define MSSPR_SIM_RANDOM_UTIL_H_

#include <cmath>
#include <cstdint>
#include <random>

namespace msspr::sim {

// splitmix64 finaliser.
inline uint64_t Mix64(uint64_t z) {
  z += 0x9E3779B97F4A7C15ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// U[0, 1).
inline double Uniform01(std::mt19937_64& rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}
// U[lo, hi).
inline double Uniform(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * Uniform01(rng);
}
// Uniform integer in [0, n), n > 0.
inline size_t UniformIndex(std::mt19937_64& rng, size_t n) {
  return static_cast<size_t>(Uniform01(rng) * static_cast<double>(n)) % n;
}
// N(0, 1) by Box-Muller (one draw per call, two uniforms consumed).
inline double StandardNormal(std::mt19937_64& rng) {
  const double u1 = 1.0 - Uniform01(rng);  // (0, 1]
  const double u2 = Uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

// double -> float32 rounding that the optimiser cannot drop: GCC 12 -O2 was
// seen to fold (double)(float)x back to x in a loop (no conversion
// instruction emitted), which broke replay of stored data.
inline float RoundToFloat(double x) {
  volatile float f = static_cast<float>(x);
  return f;
}

}  // namespace msspr::sim

#endif  // MSSPR_SIM_RANDOM_UTIL_H_
