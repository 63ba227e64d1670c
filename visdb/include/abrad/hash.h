// A 64-bit mixing function for hash keys and deterministic draws.
#pragma once

#include <cstdint>

namespace abrad {

/// The splitmix64 finaliser (Steele, Lea & Flood 2014): a well-mixed 64-bit hash of a 64-bit
/// key, the same on every machine.
constexpr std::uint64_t mix_bits(std::uint64_t h) {
    h ^= h >> 30;
    h *= 0xbf58476d1ce4e5b9ULL;
    h ^= h >> 27;
    h *= 0x94d049bb133111ebULL;
    h ^= h >> 31;
    return h;
}

}  // namespace abrad
