// Exact tests of the latent-image chain (MODEL.md 3).
#include "model/kinetics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "model/development.h"
#include "util/rng.h"
#include "testing/test_render.h"  // mean_and_standard_error

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

TEST(Kinetics, SpacingsSamplerHasTheExactChainsLaw)
{
    // sample_latent_image_by_spacings (the tables' sampler) against
    // simulate_latent_image (the exact engine's) on independent streams:
    // P(n4 >= 1), P(n4 >= 2) and the mean n2, n3, n4 of 20000 runs each.
    // Each difference is compared with its standard error from the two
    // samples' standard errors (their hypotenuse); |z| <= 5 has a false
    // alarm rate of 6e-7 per comparison, 2e-5 over the 30 below. Regimes
    // where arrival timing decides the outcome: the paper's rates, events
    // as fast as arrivals (k t ~ 1), a 1 us shutter (all photons at once:
    // high-intensity failure) and a 100 s one (low-intensity: electrons
    // lost between arrivals). Checked: scaling the spacings to 1 s instead
    // of the shutter fails it (|z| up to 470); n spacings instead of n + 1
    // (the last photon at the shutter's end) fails it at |z| 5.8.
    struct Case {
        uint64_t n;
        KineticsRates rates;
        double shutter_s;
    };
    const std::vector<Case> cases {
        { 20, { 1e7, 1e6, 10 }, kShutter_s },
        { 50, { 2e3, 4e2, 100 }, kShutter_s },
        { 12, { 1e7, 1e6, 10 }, 1e-6 },
        { 40, { 1e7, 1e6, 0.2 }, 100.0 },
        { 200, { 1e7, 1e6, 10 }, kShutter_s },
        { 8, { 1e5, 1e5, 1e3 }, 1e-3 },
    };
    constexpr int kRuns = 20000;
    std::vector<double> spacings;
    for (size_t k = 0; k < cases.size(); ++k) {
        const Case& cs = cases[k];
        // Per sampler and run: n4 >= 1, n4 >= 2, n2, n3, n4.
        std::vector<double> x[2][5];
        for (int r = 0; r < kRuns; ++r) {
            Rng a(hash_ids(0xa11, k, r), Stage::kinetics);
            Rng b(hash_ids(0xb22, k, r), Stage::kinetics);
            const LatentImage c[2] = {
                simulate_latent_image(cs.n, cs.shutter_s, cs.rates, a),
                sample_latent_image_by_spacings(cs.n, cs.shutter_s, cs.rates, b, spacings)
            };
            for (int s = 0; s < 2; ++s) {
                x[s][0].push_back(c[s].n4 >= 1 ? 1.0 : 0.0);
                x[s][1].push_back(c[s].n4 >= 2 ? 1.0 : 0.0);
                x[s][2].push_back(static_cast<double>(c[s].n2));
                x[s][3].push_back(static_cast<double>(c[s].n3));
                x[s][4].push_back(static_cast<double>(c[s].n4));
            }
        }
        for (int q = 0; q < 5; ++q) {
            const auto [m0, se0] = mean_and_standard_error(x[0][q]);
            const auto [m1, se1] = mean_and_standard_error(x[1][q]);
            const double se      = std::hypot(se0, se1);
            SCOPED_TRACE("case " + std::to_string(k) + ", statistic " + std::to_string(q));
            if (se == 0.0)
                EXPECT_EQ(m0, m1);  // both samplers deterministic here
            else
                EXPECT_LE(std::fabs(m0 - m1) / se, 5.0) << m0 << " vs " << m1;
        }
    }
}

TEST(Kinetics, SpacingsSamplerStopsWhereDecided)
{
    // Stopped at n4 == k: the same "n4 >= k" as the full run of the same
    // stream, and never beyond k.
    const KineticsRates rates { 1e7, 1e6, 10 };
    std::vector<double> spacings;
    for (uint64_t r = 0; r < 200; ++r) {
        Rng a(hash_ids(0xc33, r), Stage::kinetics), b(hash_ids(0xc33, r), Stage::kinetics);
        const LatentImage full = sample_latent_image_by_spacings(300, kShutter_s, rates, a, spacings);
        const LatentImage cut  = sample_latent_image_by_spacings(300, kShutter_s, rates, b, spacings,
                                                                 nullptr, 3);
        EXPECT_EQ(full.n4 >= 3, cut.n4 >= 3);
        EXPECT_LE(cut.n4, 3u);
    }
}

TEST(Kinetics, StoppedChainDecidesAsTheFullChain)
{
    // The exact engine's grains (render.cpp): the develop uniform u first,
    // then the chain of the same stream stopped once n4 reaches
    // n4_needed(u). Whether the grain develops must be the full chain's
    // develops(n4, u) for every grain, and the stopped chain must take no
    // more events (and fewer in many grains, else nothing was tested).
    Stock stock;
    const Development dev(stock);
    const KineticsRates regimes[] = { { 1e7, 1e6, 10 }, { 1e5, 1e7, 1e4 }, { 1e8, 1e3, 1e6 } };
    uint64_t grains = 0, shortened = 0, developed = 0;
    for (const KineticsRates& rates : regimes)
        for (uint64_t n : { 4u, 20u, 300u, 5000u })
            for (uint64_t r = 0; r < 300; ++r) {
                Rng develop(hash_ids(0x570, n, r), Stage::development);
                const double u        = develop.uniform();
                const uint64_t needed = dev.n4_needed(u);
                Rng a(hash_ids(0x571, n, r), Stage::kinetics), b(hash_ids(0x571, n, r), Stage::kinetics);
                uint64_t full_events = 0, cut_events = 0;
                const LatentImage full = simulate_latent_image(n, kShutter_s, rates, a, &full_events);
                bool cut_develops = needed == 0;
                if (needed != 0 && needed != std::numeric_limits<uint64_t>::max())
                    cut_develops = simulate_latent_image(n, kShutter_s, rates, b, &cut_events, needed)
                                       .n4
                                   >= needed;
                ASSERT_EQ(cut_develops, dev.develops(full.n4, u))
                    << "n " << n << " run " << r << " needed " << needed << " full n4 " << full.n4;
                EXPECT_LE(cut_events, full_events);
                ++grains;
                shortened += cut_events < full_events;
                developed += cut_develops;
            }
    EXPECT_GT(shortened, grains / 4);
    EXPECT_GT(developed, grains / 4);
    EXPECT_LT(developed, grains);
}

TEST(Kinetics, RateScaleFollowsArea)
{
    EXPECT_DOUBLE_EQ(rate_scale_for_area(2.0, 1.0, 0.0), 1.0);
    EXPECT_DOUBLE_EQ(rate_scale_for_area(4.0, 1.0, 1.0), 0.25);
    EXPECT_DOUBLE_EQ(rate_scale_for_area(4.0, 1.0, -0.5), 2.0);
}

}  // namespace
}  // namespace filmgrain
