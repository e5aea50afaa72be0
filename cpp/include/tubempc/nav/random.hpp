/// @file random.hpp
/// The project's random stream for the sensors (docs/model.md, "Navigation"): xoshiro256** seeded by
/// SplitMix64, uniform doubles from the top 53 bits and standard normals by the Box-Muller transform.
/// Every step is defined here (no std:: distribution), so a seed gives the same numbers on every
/// platform and standard library.
#pragma once

#include <cstdint>

namespace tubempc::nav {

/// A seeded generator of uniform and standard normal numbers; allocation-free, not thread-safe (one
/// per sensor).
class Random {
 public:
  /// @param seed any 64-bit seed (expanded into the 256-bit state by SplitMix64).
  explicit Random(std::uint64_t seed = 0) { reseed(seed); }

  /// Restarts the stream of a seed.
  /// @param seed any 64-bit seed.
  void reseed(std::uint64_t seed);
  /// @return the next 64 random bits (xoshiro256**).
  std::uint64_t next_u64();
  /// @return a uniform number in [0, 1) with 53 random bits.
  double uniform();
  /// @return a standard normal number (Box-Muller; the second value of a pair is kept for the next
  ///         call).
  double normal();

 private:
  std::uint64_t s_[4]{};
  double spare_{0.0};
  bool has_spare_{false};
};

}  // namespace tubempc::nav
