// The photon-count sampler at the means that extreme exposures produce
// (MODEL.md 2: N ~ Poisson(quantum_efficiency * 4.09e3 * integral of H)).
#include <cmath>
#include <cstdint>
#include <limits>

#include <gtest/gtest.h>

#include "util/rng.h"
#include "util/sampling.h"

namespace filmgrain::stability {
namespace {

TEST(StabilitySampling, PoissonAcrossTheValidRange)
{
    // Up to the documented 1e15: Poisson(m) has sd sqrt(m); kSigmas = 5 of
    // it (one draw per mean), and never a count that a double would not
    // round to near m.
    for (double mean : { 0.0, 1e-300, 1e-17, 0.5, 9.99, 10.0, 1e3, 1e7, 1e12, 1e15 }) {
        for (uint64_t i = 0; i < 20; ++i) {
            Rng rng(hash_ids(0x9015, i), Stage::photons);
            const double n = static_cast<double>(sample_poisson(mean, rng));
            ASSERT_LE(std::fabs(n - mean), 5.0 * std::sqrt(mean) + 1.0) << "mean " << mean;
        }
    }
    // Not a positive number: zero photons.
    for (double mean : { -1.0, -HUGE_VAL, std::nan("") }) {
        Rng rng(1, Stage::photons);
        EXPECT_EQ(sample_poisson(mean, rng), 0u) << mean;
    }
}

// Beyond the exact range the count must never fall as the mean rises and
// never be 0 for a huge mean: +inf (a float-max pixel at +64 stops) and
// means of 2^63 or more saturate at UINT64_MAX. (First failure: the final
// static_cast<uint64_t>(kf) was undefined behaviour for kf >= 2^64; x86
// gave 0 above ~2.8e19, and +inf gave NaN.)
TEST(StabilitySampling, PoissonBeyondTheValidRangeSaturates)
{
    for (double mean : { 1e19, 1e20, 1e25, 1e32, 1e300, HUGE_VAL }) {
        Rng rng(hash_ids(0xb16, 1), Stage::photons);
        const uint64_t n = sample_poisson(mean, rng);
        EXPECT_GE(n, uint64_t(1000000000000000)) << "mean " << mean << " gave " << n;
        if (mean >= 9223372036854775808.0) {
            EXPECT_EQ(n, std::numeric_limits<uint64_t>::max()) << "mean " << mean;
        }
    }
}

}  // namespace
}  // namespace filmgrain::stability
