// Stability of every kinetics engine (engines.h) over the extremes of the
// latent-image chain (MODEL.md 3) and of development (MODEL.md 4):
// rate constants from 1e-9 to 1e12 per second and zero, in every
// combination (ratios up to 1e21); 0 to 1e7 absorbed photons; shutters from
// 1e-9 s to 1e6 s; development efficiency d -> 0 and d -> 1.
//
// Asserted: every output finite and a probability; the chain's bookkeeping
// (events <= photons: it cannot hang; atoms conserved); the analytic limits
// (N < 4, infinite loss, no pairing: fog only; no loss with instantaneous
// growth: one centre); time scaling (shutter s with rates r is the chain of
// shutter 1 with rates r s); P(develop | N) non-decreasing in N within
// noise; every approximate engine agrees with the exact one within its
// stated error.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "checks.h"
#include "engines.h"

namespace filmgrain::stability {
namespace {

/// Every rate constant of the grid, per second.
const std::vector<double> kRateGrid = { 0.0, 1e-9, 1e-6, 1e-3, 1.0, 1e3, 1e6, 1e9, 1e12 };
/// A coarser grid for the statistical tests (each point costs hundreds of
/// chain runs per engine): still zero, both ends and the middle.
const std::vector<double> kCoarseRateGrid = { 0.0, 1e-9, 1.0, 1e6, 1e12 };
/// The corners only (zero, both ends), for engines that build a table per
/// rate set (KineticsEngine::tabulates): ~0.1 s per table.
const std::vector<double> kCornerRateGrid = { 0.0, 1e-9, 1e12 };
/// The coarse grid, or the corners for tabulating engines.
const std::vector<double>& rate_grid(const KineticsEngine& engine)
{
    return engine.tabulates ? kCornerRateGrid : kCoarseRateGrid;
}
/// Runs per estimate in the statistical tests (a table's node estimates
/// cost samples x nodes chain runs, so it gets fewer; its stated standard
/// error accounts for that).
int runs_for(const KineticsEngine& engine) { return engine.tabulates ? 64 : 256; }
/// Shutters, seconds.
const std::vector<double> kShutters = { 1e-9, 1e-3, 1.0 / 48.0, 1.0, 1e6 };

std::vector<KineticsRates> rate_combinations(const std::vector<double>& grid)
{
    std::vector<KineticsRates> out;
    for (double k_pair : grid)
        for (double k_join : grid)
            for (double k_loss : grid)
                out.push_back({ k_pair, k_join, k_loss });
    return out;
}

std::string describe(const KineticsQuery& q)
{
    std::ostringstream s;
    s << "N " << q.photons << ", shutter " << q.shutter_s << " s, k_pair "
      << q.rates.k_pair_per_s << ", k_join " << q.rates.k_join_per_s << ", k_loss "
      << q.rates.k_loss_per_s;
    return s.str();
}

/// Calls f(engine, query) for every engine that samples grains and the
/// query of `photons` photons with each combination of rates from `grid`
/// and each shutter of `shutters`.
template<typename F>
void for_each_sampled_case(const std::vector<double>& grid, const std::vector<double>& shutters,
                           uint64_t photons, const F& f)
{
    for (const KineticsEngine& engine : kinetics_engines()) {
        if (!engine.sample)
            continue;
        for (const KineticsRates& rates : rate_combinations(grid))
            for (double shutter_s : shutters)
                f(engine, KineticsQuery { photons, shutter_s, rates });
    }
}

/// Developments at the extremes of MODEL.md 4 (stock ranges allow them).
struct NamedDevelopment {
    const char* name;
    Stock stock;
};
std::vector<NamedDevelopment> developments()
{
    return {
        // d = 1 - e^-3 = 0.95, f = 1 - e^-0.072 = 0.069 (the defaults).
        { "typical", development_stock(360, 120, 5000) },
        // d = 1e-18, f = 1e-36: nothing develops in practice.
        { "d_to_0", development_stock(1e-6, 1e12, 1e30) },
        // d = 1 - e^-1e10 = 1 in double, f = 1e-23: a 4-centre always develops.
        { "d_to_1", development_stock(1e7, 1e-3, 1e30) },
    };
}

// ---------------------------------------------------------------------------

TEST(StabilityKinetics, EveryRateCombinationKeepsItsBookkeeping)
{
    // 729 rate combinations x 5 shutters x 9 photon counts, a few grains
    // each, for every engine that samples grains.
    const Stock stock = development_stock(360, 120, 5000);
    const Development dev(stock);
    const std::vector<uint64_t> photon_counts = { 0, 1, 2, 3, 4, 5, 9, 64, 1000 };
    for (const KineticsEngine& engine : kinetics_engines()) {
        if (!engine.sample)
            continue;
        uint64_t failures = 0;
        for (const KineticsRates& rates : rate_combinations(kRateGrid))
            for (double shutter_s : kShutters)
                for (uint64_t n : photon_counts) {
                    const int runs = n <= 64 ? 3 : 1;
                    for (int i = 0; i < runs; ++i) {
                        const KineticsQuery q { n, shutter_s, rates };
                        Rng rng(hash_ids(0xb00c, n, static_cast<uint64_t>(i)), Stage::kinetics);
                        uint64_t events     = 0;
                        const LatentImage c = engine.sample(q, dev, rng, &events);
                        const auto ok = chain_bookkeeping(c, events, n, rates, engine.exact);
                        if (!ok && ++failures <= 10)
                            ADD_FAILURE() << engine.name << ": " << describe(q) << ": "
                                          << ok.message();
                    }
                }
        EXPECT_EQ(failures, 0u) << engine.name;
    }
}

TEST(StabilityKinetics, SameStreamSameGrain)
{
    // Determinism at the extremes: the stream alone decides the outcome.
    const Development dev(development_stock(360, 120, 5000));
    const auto same = [&](const KineticsEngine& engine, const KineticsQuery& q) {
        Rng a(hash_ids(0xde7, 1), Stage::kinetics), b(hash_ids(0xde7, 1), Stage::kinetics);
        uint64_t ea = 0, eb = 0;
        const LatentImage ca = engine.sample(q, dev, a, &ea);
        const LatentImage cb = engine.sample(q, dev, b, &eb);
        EXPECT_TRUE(ca == cb && ea == eb) << engine.name << ": " << describe(q);
    };
    for_each_sampled_case(kCoarseRateGrid, { 1e-9, 1e6 }, 200, same);
}

TEST(StabilityKinetics, LargePhotonCountsStayBoundedAndQuick)
{
    // 1e5 photons on every corner of the rate grid (0, 1e-9, 1e12), at both
    // shutter extremes; then 1e7 photons (about 0.5 s per run of the exact
    // chain) twice. The ctest TIMEOUT catches a hang; the per-run budget
    // below catches a run that is merely far too slow (events <= N bounds
    // the work at ~2N chain steps).
    const Development dev(development_stock(360, 120, 5000));
    const auto bounded = [&](const KineticsEngine& engine, const KineticsQuery& q) {
        Rng rng(hash_ids(0x1e5, 1), Stage::kinetics);
        uint64_t events     = 0;
        const LatentImage c = engine.sample(q, dev, rng, &events);
        EXPECT_TRUE(chain_bookkeeping(c, events, q.photons, q.rates, engine.exact))
            << engine.name << ": " << describe(q);
    };
    for_each_sampled_case(kCornerRateGrid, { 1e-9, 1e6 }, 100000, bounded);
    for (const KineticsEngine& engine : kinetics_engines()) {
        if (!engine.sample)
            continue;
        for (const KineticsQuery& q :
             { KineticsQuery { 10000000, 1e-9, { 1e7, 1e6, 10 } },
               KineticsQuery { 10000000, 1e6, { 1e12, 1e-9, 1e3 } } }) {
            const auto start    = std::chrono::steady_clock::now();
            Rng rng(hash_ids(0x1e7, 1), Stage::kinetics);
            uint64_t events     = 0;
            const LatentImage c = engine.sample(q, dev, rng, &events);
            const double seconds
                = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            EXPECT_TRUE(chain_bookkeeping(c, events, q.photons, q.rates, engine.exact))
                << engine.name << ": " << describe(q);
            EXPECT_TRUE(std::isfinite(dev.develop_probability(c.n4)));
            // ~0.5 s in Release here; sanitizers and a loaded machine are
            // allowed 60x that before this counts as a hang.
            EXPECT_LT(seconds, 30.0) << engine.name << ": " << describe(q);
        }
    }
}

TEST(StabilityKinetics, FewerThanFourPhotonsGiveFogOnly)
{
    // Atoms are conserved and a centre develops only with 4 of them: with
    // N < 4 every grain has n4 = 0, so P = 1 - (1 - f)(1 - d)^0 = f exactly,
    // whatever the rates and shutter. Every engine, every development.
    for (const NamedDevelopment& nd : developments()) {
        const Development dev(nd.stock);
        for (const KineticsEngine& engine : kinetics_engines())
            for (const KineticsRates& rates : rate_combinations(rate_grid(engine)))
                for (double shutter_s : { 1e-9, 1.0, 1e6 })
                    for (uint64_t n = 0; n < 4; ++n) {
                        const KineticsQuery q { n, shutter_s, rates };
                        const EngineEstimate e = engine.develop_probability(q, dev, 16, 1);
                        ASSERT_TRUE(is_probability(e)) << engine.name << ": " << describe(q);
                        ASSERT_TRUE(equals_exactly_or_within_error(e, dev.fog_probability()))
                            << engine.name << ", " << nd.name << ": " << describe(q);
                    }
    }
}

/// Upper bound on the expected number of pairing events of a grain whose
/// electrons are lost at rate k_loss each (MODEL.md 3). The free electrons
/// are dominated by an M/M/infinity queue (arrivals N / T during the
/// shutter, each leaving at rate k_loss; pairing and growth only remove
/// more), whose count at time t is Poisson(m(t)) with m(t) <= rho =
/// N / (T k_loss), so E[e (e - 1)] = m^2 <= rho^2. Pairing happens at
/// k_pair e (e - 1) / 2: during the shutter at most k_pair rho^2 T / 2
/// pairs; after it m decays as rho exp(-k_loss t), adding
/// k_pair rho^2 / (4 k_loss).
double expected_pairs_bound(const KineticsQuery& q)
{
    const double rho = static_cast<double>(q.photons) / (q.shutter_s * q.rates.k_loss_per_s);
    return q.rates.k_pair_per_s * rho * rho
           * (0.5 * q.shutter_s + 0.25 / q.rates.k_loss_per_s);
}

TEST(StabilityKinetics, InfiniteLossGivesFogOnly)
{
    // Loss at 1e12 per second and beyond: an electron lives ~1e-12 s, two
    // almost never meet, no centre forms, P = f. Asserted wherever the
    // bound above makes a pairing in any of the runs unlikely (expected
    // pairs over all runs < 1e-3); a pairing can only raise P, so exact
    // equality is the test. Every engine at 4 and 100 photons and every
    // development; the exact one also at 1e3 photons on the full grid and at
    // 1e5 photons on the corners.
    const int runs = 32;
    int tested     = 0;
    const auto check = [&](const KineticsEngine& engine, const NamedDevelopment& nd,
                           const KineticsQuery& q) {
        if (expected_pairs_bound(q) * runs >= 1e-3)
            return;
        ++tested;
        const Development dev(nd.stock);
        const EngineEstimate e = engine.develop_probability(q, dev, runs, 2);
        ASSERT_TRUE(is_probability(e)) << engine.name << ": " << describe(q);
        ASSERT_TRUE(equals_exactly_or_within_error(e, dev.fog_probability()))
            << engine.name << ", " << nd.name << ": " << describe(q);
    };
    for (const NamedDevelopment& nd : developments())
        for (const KineticsEngine& engine : kinetics_engines())
            for (double k_loss : { 1e12, 1e15 })
                for (double k_pair : engine.tabulates ? kCornerRateGrid : kRateGrid)
                    for (double k_join : engine.tabulates ? kCornerRateGrid : kRateGrid)
                        for (double shutter_s : { 1e-9, 1e-3, 1e6 })
                            for (uint64_t n : { 4u, 100u })
                                check(engine, nd, { n, shutter_s, { k_pair, k_join, k_loss } });
    for (double k_pair : kRateGrid)
        for (double k_join : kRateGrid)
            for (double shutter_s : { 1e-9, 1e-3, 1e6 })
                check(exact_engine(), developments()[0],
                      { 1000, shutter_s, { k_pair, k_join, 1e12 } });
    for (double k_pair : kCornerRateGrid)
        for (double k_join : kCornerRateGrid)
            for (double shutter_s : { 1e-9, 1e6 })
                check(exact_engine(), developments()[0],
                      { 100000, shutter_s, { k_pair, k_join, 1e12 } });
    EXPECT_GT(tested, 100);  // the limit was actually reached on the grid
}

TEST(StabilityKinetics, NoPairingGivesFogOnly)
{
    // k_pair = 0: the only way to create a centre is gone; growth and loss
    // need a centre or only remove electrons. n4 = 0 and P = f, exactly.
    const Development dev(development_stock(360, 120, 5000));
    for (const KineticsEngine& engine : kinetics_engines())
        for (double k_join : rate_grid(engine))
            for (double k_loss : rate_grid(engine))
                for (double shutter_s : { 1e-9, 1e6 })
                    for (uint64_t n : { 4u, 1000u }) {
                        const KineticsQuery q { n, shutter_s, { 0.0, k_join, k_loss } };
                        const EngineEstimate e = engine.develop_probability(q, dev, 16, 3);
                        ASSERT_TRUE(equals_exactly_or_within_error(e, dev.fog_probability()))
                            << engine.name << ": " << describe(q);
                    }
}

TEST(StabilityKinetics, NoLossWithInstantGrowthMakesOneCentre)
{
    // k_loss = 0 and k_join >> k_pair. No electron is ever lost, so the
    // chain (which runs on after the shutter until e = 0) eventually pairs
    // two electrons: one centre. From then on, with c >= 1 centres and e
    // free electrons, the next event is another pairing with probability
    // k_pair e(e-1)/2 / (k_pair e(e-1)/2 + k_join e c) <= k_pair N / (2 k_join);
    // over at most N events a second pairing has probability at most
    // eps = N^2 k_pair / (2 k_join). Without one, every electron joins the
    // single centre, which ends with all N atoms: n4 = 1 if N >= 4 (and 0
    // for N < 4). Hence P = 1 - (1 - f)(1 - d)^n4 with n4 = [N >= 4].
    // Asserted exactly where eps over all runs < 1e-3.
    const int runs = 64;
    int tested     = 0;
    for (const NamedDevelopment& nd : developments()) {
        const Development dev(nd.stock);
        for (const KineticsEngine& engine : kinetics_engines())
            for (double k_pair : engine.tabulates ? kCornerRateGrid : kRateGrid)
                for (double k_join : engine.tabulates ? kCornerRateGrid : kRateGrid)
                    for (double shutter_s : kShutters)
                        for (uint64_t n : { 2u, 3u, 4u, 5u, 40u, 1000u }) {
                            if (k_pair <= 0.0 || k_join <= 0.0)
                                continue;
                            const double nn = static_cast<double>(n);
                            if (nn * nn * k_pair / (2.0 * k_join) * runs >= 1e-3)
                                continue;
                            if (n == 1000 && !engine.exact)
                                continue;
                            ++tested;
                            const KineticsQuery q { n, shutter_s, { k_pair, k_join, 0.0 } };
                            const double expected = dev.develop_probability(n >= 4 ? 1 : 0);
                            const EngineEstimate e = engine.develop_probability(q, dev, runs, 4);
                            ASSERT_TRUE(equals_exactly_or_within_error(e, expected))
                                << engine.name << ", " << nd.name << ": " << describe(q);
                            if (engine.sample && engine.exact) {
                                Rng rng(hash_ids(0x1c, n), Stage::kinetics);
                                const LatentImage c = engine.sample(q, dev, rng, nullptr);
                                const LatentImage one { n == 2 ? 1u : 0u, n == 3 ? 1u : 0u,
                                                        n >= 4 ? 1u : 0u };
                                ASSERT_EQ(c, one) << engine.name << ": " << describe(q);
                            }
                        }
    }
    EXPECT_GT(tested, 100);
}

/// P and the mean n4 at (shutter, rates), exact engine.
struct ChainMoments {
    EngineEstimate p;
    double mean_n4 = 0, se_n4 = 0;
};
ChainMoments chain_moments(const KineticsQuery& q, const Development& dev, int runs,
                           uint64_t seed)
{
    ChainMoments m;
    double s = 0, s2 = 0, sp = 0, sp2 = 0;
    for (int i = 0; i < runs; ++i) {
        Rng rng(hash_ids(0x5ca1e, seed, static_cast<uint64_t>(i)), Stage::kinetics);
        const LatentImage c = exact_engine().sample(q, dev, rng, nullptr);
        const double n4 = static_cast<double>(c.n4), p = dev.develop_probability(c.n4);
        s += n4;
        s2 += n4 * n4;
        sp += p;
        sp2 += p * p;
    }
    const double r = runs;
    m.mean_n4      = s / r;
    m.se_n4        = std::sqrt(std::max(0.0, s2 / r - m.mean_n4 * m.mean_n4) / r) + 1.0 / r;
    m.p            = { sp / r,
                       std::sqrt(std::max(0.0, sp2 / r - (sp / r) * (sp / r)) / r) + 1.0 / r, 0.0 };
    return m;
}

TEST(StabilityKinetics, TimeScalingLeavesTheChainUnchanged)
{
    // Multiplying every time by s (shutter s T, rates r / s) changes only
    // the clock: the sequence of events is the same in distribution. The
    // chain at shutter 1e6 s and at 1e-9 s must match the chain at 1 s with
    // rescaled rates; time sums that lose precision in double (event times
    // near 1e6 s against waits of 1e-12 s) would reorder events and move P
    // and the mean n4. Regimes are chosen where the outcome depends on the
    // race between arrivals, pairing, growth and loss (n4 varies from grain
    // to grain). A weak development (d = 0.30) keeps P sensitive to n4.
    // Independent runs: the difference of two means has sd
    // sqrt(se_a^2 + se_b^2); kSigmas of it.
    const Development dev(development_stock(360, 1000, 5000));
    struct Regime {
        uint64_t photons;
        KineticsRates at_one_second;
    };
    const Regime regimes[] = {
        { 8, { 10, 10, 10 } },      // all three comparable: P(n4 > 0) ~ 0.4
        { 15, { 1, 30, 8 } },       // growth wins, loss competes: ~0.6
        { 100, { 1e3, 10, 1 } },    // pairing wins (high-intensity failure): n4 ~ 13
        { 40, { 10, 10, 0 } },      // no loss: pairing races growth
    };
    const int runs = 4000;
    for (const Regime& r : regimes) {
        const KineticsQuery base { r.photons, 1.0, r.at_one_second };
        const ChainMoments m1 = chain_moments(base, dev, runs, 1);
        // The regime is not trivial: n4 varies (its sd is se * sqrt(runs)).
        EXPECT_GT(m1.se_n4 * std::sqrt(double(runs)), 0.2) << describe(base);
        for (double scale : { 1e6, 1e-9 }) {
            const KineticsQuery q { r.photons, scale,
                                    { r.at_one_second.k_pair_per_s / scale,
                                      r.at_one_second.k_join_per_s / scale,
                                      r.at_one_second.k_loss_per_s / scale } };
            const ChainMoments ms = chain_moments(q, dev, runs, 2);
            EXPECT_TRUE(agree(ms.p, m1.p)) << describe(q) << " vs " << describe(base);
            EXPECT_NEAR(ms.mean_n4, m1.mean_n4, kSigmas * std::hypot(ms.se_n4, m1.se_n4))
                << describe(q) << " vs " << describe(base);
        }
    }
}

TEST(StabilityKinetics, DevelopProbabilityRisesWithPhotons)
{
    // More photons, at the same shutter and rates, should never make a
    // grain less likely to develop (the model has no solarisation; an
    // independent sweep of the full grid found no decrease). Checked within
    // noise (non_decreasing: kSigmas of the difference of two independent
    // estimates, plus stated biases) for every engine, on the coarse grid.
    const Development dev(development_stock(360, 120, 5000));
    const std::vector<uint64_t> photon_counts = { 4, 8, 16, 64, 256 };
    for (const KineticsEngine& engine : kinetics_engines())
        for (const KineticsRates& rates : rate_combinations(rate_grid(engine)))
            for (double shutter_s : { 1e-9, 1.0 / 48.0, 1e6 }) {
                if (rates.k_pair_per_s <= 0.0)
                    continue;  // fog only (NoPairingGivesFogOnly)
                std::vector<EngineEstimate> seq;
                for (uint64_t n : photon_counts) {
                    seq.push_back(engine.develop_probability({ n, shutter_s, rates }, dev,
                                                             engine.tabulates ? 64 : 128, 5));
                    ASSERT_TRUE(is_probability(seq.back()));
                }
                EXPECT_TRUE(non_decreasing(seq))
                    << engine.name << ": " << describe({ 0, shutter_s, rates });
            }
}

TEST(StabilityKinetics, EveryEngineAgreesWithTheExactOne)
{
    // Every engine (the exact one included, on independent streams: that
    // checks the tolerance itself) against the exact engine, within the
    // engine's stated bias plus kSigmas of the combined standard error, on
    // the coarse grid (the corners for tabulating engines) and at the
    // development extremes.
    // (d -> 0 is left out here: P ~ 1e-18 there, nothing to compare.)
    const std::vector<uint64_t> photon_counts = { 4, 5, 16, 100, 256 };
    const auto on_grid = [](const std::vector<double>& grid, const KineticsRates& r) {
        const auto in = [&](double k) { return std::find(grid.begin(), grid.end(), k) != grid.end(); };
        return in(r.k_pair_per_s) && in(r.k_join_per_s) && in(r.k_loss_per_s);
    };
    for (const NamedDevelopment& nd : developments()) {
        if (std::string(nd.name) == "d_to_0")
            continue;
        const Development dev(nd.stock);
        for (const KineticsRates& rates : rate_combinations(kCoarseRateGrid))
            for (double shutter_s : { 1e-9, 1.0 / 48.0, 1e6 }) {
                if (rates.k_pair_per_s <= 0.0)
                    continue;  // fog only: NoPairingGivesFogOnly
                for (uint64_t n : photon_counts) {
                    const KineticsQuery q { n, shutter_s, rates };
                    const EngineEstimate x = exact_engine().develop_probability(q, dev, 256, 7);
                    for (const KineticsEngine& engine : kinetics_engines()) {
                        if (!on_grid(rate_grid(engine), rates))
                            continue;
                        const EngineEstimate e
                            = engine.develop_probability(q, dev, runs_for(engine), 6);
                        ASSERT_TRUE(is_probability(e)) << engine.name << ": " << describe(q);
                        EXPECT_TRUE(agree(e, x))
                            << engine.name << " vs exact, " << nd.name << ": " << describe(q);
                    }
                }
            }
    }
}

TEST(StabilityDevelopment, ExtremeEfficiencyStaysAProbability)
{
    // MODEL.md 4 at its extremes, n4 up to 2^64 - 1: the survival
    // (1 - f)(1 - d)^n4 stays in [0, 1], finite, non-increasing in n4, and
    // hits the limits: d -> 0 gives P = f, d -> 1 gives P = 1 for n4 >= 1.
    const std::vector<uint64_t> counts = { 0, 1, 2, 4, 1000, 10000000, uint64_t(1) << 40,
                                           std::numeric_limits<uint64_t>::max() };
    for (const NamedDevelopment& nd : developments()) {
        const Development dev(nd.stock);
        double previous = 1.0;
        for (uint64_t n4 : counts) {
            const double s = dev.survival_probability(n4);
            ASSERT_TRUE(std::isfinite(s) && s >= 0.0 && s <= 1.0) << nd.name << " n4 " << n4;
            ASSERT_LE(s, previous) << nd.name << " n4 " << n4;
            previous = s;
        }
    }
    const Development none(development_stock(0, 120, 5000));  // d = f = 0
    EXPECT_EQ(none.develop_probability(std::numeric_limits<uint64_t>::max()), 0.0);
    const Development d0(development_stock(1e-6, 1e12, 1e30));
    EXPECT_LT(d0.develop_probability(1000), 1e-14);
    const Development d1(development_stock(1e7, 1e-3, 1e30));
    EXPECT_EQ(d1.develop_probability(1), 1.0);
    EXPECT_LT(d1.develop_probability(0), 1e-22);
}

}  // namespace
}  // namespace filmgrain::stability
