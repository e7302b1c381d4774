// Exact tests of the latent-image chain (MODEL.md 3).
#include "kinetics.h"

#include <gtest/gtest.h>

#include "rng.h"

namespace filmgrain {
namespace {

constexpr double kShutter_s = 1.0 / 48.0;

LatentImage run(uint64_t photons, const KineticsRates& rates, uint64_t seed,
                double shutter_s = kShutter_s, uint64_t* events = nullptr)
{
    Rng rng(hash_ids(seed, 12345), Stage::kinetics);
    return simulate_latent_image(photons, shutter_s, rates, rng, events);
}

TEST(Kinetics, NoPhotonsNoCentres)
{
    const KineticsRates rates { 1e7, 1e6, 10 };
    EXPECT_EQ(run(0, rates, 1), LatentImage {});
}

TEST(Kinetics, OnePhotonCannotFormACentre)
{
    const KineticsRates rates { 1e7, 1e6, 0 };
    for (uint64_t seed = 0; seed < 100; ++seed)
        EXPECT_EQ(run(1, rates, seed), LatentImage {});
}

TEST(Kinetics, TwoPhotonsWithoutLossMakeExactlyOneTwoCentre)
{
    // With no loss the lone first electron waits for the second; they pair,
    // and no electron is left to grow the centre.
    const KineticsRates rates { 1e7, 1e6, 0 };
    for (uint64_t seed = 0; seed < 200; ++seed) {
        const LatentImage c = run(2, rates, seed);
        EXPECT_EQ(c.n2, 1u) << "seed " << seed;
        EXPECT_EQ(c.n3, 0u);
        EXPECT_EQ(c.n4, 0u);
    }
}

TEST(Kinetics, FourPhotonsFastGrowthMakeOneFourCentre)
{
    // Growth 1e12 times faster than pairing: the first pair is the only
    // pair, and the other two electrons grow it to four atoms.
    const KineticsRates rates { 1.0, 1e12, 0 };
    for (uint64_t seed = 0; seed < 200; ++seed) {
        const LatentImage c = run(4, rates, seed);
        EXPECT_EQ(c.n2, 0u) << "seed " << seed;
        EXPECT_EQ(c.n3, 0u) << "seed " << seed;
        EXPECT_EQ(c.n4, 1u) << "seed " << seed;
    }
}

TEST(Kinetics, HugeLossLeavesNoCentres)
{
    // Loss 1e15/s against pairing 1e7/s: the chance that any of 1000
    // electrons pairs is about 1000 * 1e7 / 1e15 = 1e-5 per grain.
    const KineticsRates rates { 1e7, 1e6, 1e15 };
    for (uint64_t seed = 0; seed < 100; ++seed)
        EXPECT_EQ(run(1000, rates, seed), LatentImage {}) << "seed " << seed;
}

TEST(Kinetics, PairingOnlyPairsEveryElectronButAnOddOne)
{
    const KineticsRates rates { 1e7, 0, 0 };
    for (uint64_t n : { 2u, 3u, 10u, 11u, 1001u }) {
        const LatentImage c = run(n, rates, n);
        EXPECT_EQ(c.n2, n / 2);
        EXPECT_EQ(c.n3, 0u);
        EXPECT_EQ(c.n4, 0u);
    }
}

TEST(Kinetics, AllRatesZeroFreezesTheElectrons)
{
    uint64_t events = 99;
    EXPECT_EQ(run(50, KineticsRates { 0, 0, 0 }, 3, kShutter_s, &events), LatentImage {});
    EXPECT_EQ(events, 0u);
}

TEST(Kinetics, EventsNeverExceedPhotons)
{
    // Each event consumes at least one electron: events <= photons.
    const KineticsRates rates { 1e7, 1e6, 10 };
    for (uint64_t n : { 5u, 50u, 5000u }) {
        uint64_t events = 0;
        const LatentImage c = run(n, rates, n, kShutter_s, &events);
        EXPECT_LE(events, n);
        // Atoms are conserved: every atom came from one photon.
        EXPECT_LE(2 * c.n2 + 3 * c.n3 + 4 * c.n4, n);
    }
}

TEST(Kinetics, SameStreamSameResult)
{
    const KineticsRates rates { 1e7, 1e6, 10 };
    EXPECT_EQ(run(300, rates, 7), run(300, rates, 7));
}

TEST(Kinetics, ExtremeShuttersTerminate)
{
    const KineticsRates rates { 1e7, 1e6, 10 };
    for (double shutter : { 1e-9, 1e6 }) {
        uint64_t events = 0;
        const LatentImage c = run(10000, rates, 5, shutter, &events);
        EXPECT_LE(2 * c.n2 + 3 * c.n3 + 4 * c.n4, 10000u);
        EXPECT_LE(events, 10000u);
    }
}

TEST(Kinetics, RateScaleFollowsArea)
{
    EXPECT_DOUBLE_EQ(rate_scale_for_area(2.0, 1.0, 0.0), 1.0);
    EXPECT_DOUBLE_EQ(rate_scale_for_area(4.0, 1.0, 1.0), 0.25);
    EXPECT_DOUBLE_EQ(rate_scale_for_area(4.0, 1.0, -0.5), 2.0);
}

}  // namespace
}  // namespace filmgrain
