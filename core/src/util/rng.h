// filmgrain: random streams keyed by stable identities.
//
// Every random value in filmgrain comes from a PCG32 stream selected by a
// hash of (seed, stable entity id, stage), never from thread, tile or call
// order (STYLE rule 3). The same grain therefore gets the same random
// numbers whichever tile, thread or ROI asks for it.
#pragma once

#include <cstdint>
#include <pcg_random.hpp>

namespace filmgrain {

/// 64-bit finaliser (MurmurHash3 fmix64): a bijection with full avalanche.
inline constexpr uint64_t mix64(uint64_t x)
{
    x ^= x >> 33;
    x *= 0xff51afd7ed558ccdULL;
    x ^= x >> 33;
    x *= 0xc4ceb9fe1a85ec53ULL;
    x ^= x >> 33;
    return x;
}

/// Order-dependent combination of a running hash with one more value.
inline constexpr uint64_t hash_combine(uint64_t h, uint64_t v)
{
    return mix64(h ^ (mix64(v) + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2)));
}

/// Hash of any number of 64-bit identity components, in order.
template<typename... T> inline constexpr uint64_t hash_ids(uint64_t first, T... rest)
{
    uint64_t h = mix64(first ^ 0x5851f42d4c957f2dULL);
    ((h = hash_combine(h, static_cast<uint64_t>(rest))), ...);
    return h;
}

/// Word k of a counter-based stream keyed by `key`: SplitMix64 (Steele,
/// Lea and Flood 2014) at position k, i.e. the key advanced k + 1 steps of
/// the golden-ratio increment, then mixed. For kernels that draw a fixed
/// number of values per item in a tight loop: no state, no seeding cost.
inline constexpr uint64_t counter_u64(uint64_t key, uint64_t k)
{
    uint64_t z = key + (k + 1) * 0x9e3779b97f4a7c15ULL;
    z          = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z          = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/// The uniform in (0, 1) that 32 random bits stand for: the centre of
/// their interval of width 2^-32 (never 0 or 1).
inline constexpr double uniform_from_bits(uint32_t bits)
{
    return (static_cast<double>(bits) + 0.5) * 0x1.0p-32;
}

/// The uniform in (0, 1) that the top 53 bits of a 64-bit draw stand for:
/// the centre of their interval of width 2^-53 (never 0 or 1; a double's
/// full precision, for quantiles far in a tail).
inline constexpr double uniform_from_bits53(uint64_t bits)
{
    return (static_cast<double>(bits >> 11) + 0.5) * 0x1.0p-53;
}

/// Stages of a grain's life; each draws from its own stream so that a fast
/// path that skips one stage does not shift the random numbers of another.
enum class Stage : uint64_t {
    cell        = 1,  ///< grain count, positions and diameters of a film cell
    photons     = 2,  ///< absorbed photon count (MODEL.md 2)
    kinetics    = 3,  ///< arrival times and latent-image events (MODEL.md 3)
    development = 4,  ///< develop or not (MODEL.md 4)
    fast_cell   = 5,  ///< grain count of a cell in the fast kernel (its
                      ///< grains then use counter_u64 of the cell's id)
};

/// A PCG32 stream for one (identity, stage). Not thread-safe: one per use.
class Rng {
public:
    /// identity: a hash of the entity's stable id (see hash_ids).
    Rng(uint64_t identity, Stage stage)
        : m_pcg(hash_combine(identity, static_cast<uint64_t>(stage)),
                mix64(identity + static_cast<uint64_t>(stage)))
    {
    }

    /// Uniform 32-bit integer.
    uint32_t next_u32() { return m_pcg(); }

    /// Uniform double in [0, 1) with 53 random bits.
    double uniform()
    {
        const uint64_t hi = m_pcg() >> 5;  // 27 bits
        const uint64_t lo = m_pcg() >> 6;  // 26 bits
        return static_cast<double>((hi << 26) | lo) * 0x1.0p-53;
    }

    /// Uniform double in (0, 1]: safe to take the logarithm of.
    double uniform_open0() { return 1.0 - uniform(); }

private:
    pcg32 m_pcg;
};

}  // namespace filmgrain
