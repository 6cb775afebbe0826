// hash.h -- the one 64-bit mixer the project's hashes share.
#pragma once

#include <cstdint>

namespace lm {

/// SplitMix64's output function (Steele, Lea & Flood 2014): a strong 64-bit mixer.
constexpr uint64_t Mix64(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

}  // namespace lm
