// The stability checks can fail: each is fed a wrong answer of the kind it
// exists to catch (a biased engine, a clock that ignores the shutter, a
// falling curve, a chain that loses count) and must reject it.
#include <cmath>

#include <gtest/gtest.h>

#include "checks.h"
#include "engines.h"

namespace filmgrain::stability {
namespace {

TEST(StabilityChecks, RejectWrongAnswers)
{
    EXPECT_FALSE(is_probability({ NAN, 0.0, 0.0 }));
    EXPECT_FALSE(is_probability({ 1.5, 0.0, 0.0 }));
    EXPECT_FALSE(is_probability({ 0.5, INFINITY, 0.0 }));
    EXPECT_TRUE(is_probability({ 0.5, 0.01, 0.0 }));

    // 6 sigma apart: rejected; 4 sigma: accepted; a stated bias widens it.
    const double sd = std::hypot(0.01, 0.01);
    EXPECT_FALSE(agree({ 0.5, 0.01, 0.0 }, { 0.5 + 6 * sd, 0.01, 0.0 }));
    EXPECT_TRUE(agree({ 0.5, 0.01, 0.0 }, { 0.5 + 4 * sd, 0.01, 0.0 }));
    EXPECT_TRUE(agree({ 0.5, 0.01, 0.05 }, { 0.5 + 6 * sd, 0.01, 0.0 }));

    EXPECT_FALSE(equals_exactly_or_within_error({ 0.1 + 1e-9, 0.0, 0.0 }, 0.1));
    EXPECT_TRUE(equals_exactly_or_within_error({ 0.1 + 1e-13, 0.0, 0.0 }, 0.1));

    EXPECT_FALSE(non_decreasing({ { 0.5, 0.01, 0 }, { 0.4, 0.01, 0 } }));
    EXPECT_TRUE(non_decreasing({ { 0.5, 0.01, 0 }, { 0.48, 0.01, 0 }, { 0.9, 0.01, 0 } }));

    const KineticsRates loss { 1, 1, 1 }, no_loss { 1, 1, 0 }, pair_only { 1, 0, 0 };
    EXPECT_FALSE(chain_bookkeeping({ 0, 0, 1 }, 2, 3, loss, true));    // n4 from 3 photons
    EXPECT_FALSE(chain_bookkeeping({ 3, 0, 0 }, 3, 5, loss, true));    // 6 atoms from 5
    EXPECT_FALSE(chain_bookkeeping({ 0, 0, 0 }, 6, 5, loss, true));    // events > photons
    EXPECT_FALSE(chain_bookkeeping({ 1, 0, 0 }, 1, 5, loss, true));    // 3 electrons left
    EXPECT_FALSE(chain_bookkeeping({ 1, 0, 0 }, 2, 5, no_loss, true)); // 2 left, a centre waits
    EXPECT_TRUE(chain_bookkeeping({ 2, 0, 0 }, 2, 5, pair_only, true)); // 1 left: cannot pair
    EXPECT_TRUE(chain_bookkeeping({ 1, 0, 0 }, 4, 5, loss, true));
    EXPECT_TRUE(chain_bookkeeping({ 1, 0, 0 }, 1, 5, loss, false));    // stopped early
}

TEST(StabilityChecks, CatchABiasedEngineAndABrokenClock)
{
    // Engines with the two bugs the suite exists for, against the exact one.
    const Development dev(development_stock(360, 120, 5000));
    const KineticsQuery q { 8, 1.0, { 10, 10, 10 } };  // P ~ 0.45
    const EngineEstimate exact = exact_engine().develop_probability(q, dev, 4000, 1);
    ASSERT_GT(exact.p, 0.05);
    ASSERT_LT(exact.p, 0.95);

    // A table that is off by 0.05 but claims 0.01: rejected.
    EngineEstimate biased = exact_engine().develop_probability(q, dev, 4000, 2);
    biased.p += 0.05;
    biased.bias_bound = 0.01;
    EXPECT_FALSE(agree(biased, exact));

    // A clock that ignores the shutter (runs every chain over 1 s): at
    // 1e6 s with rates / 1e6 it must differ from the 1 s chain.
    const KineticsQuery slow { 8, 1e6, { 1e-5, 1e-5, 1e-5 } };
    const KineticsQuery broken_clock { 8, 1.0, slow.rates };
    EXPECT_FALSE(agree(exact_engine().develop_probability(broken_clock, dev, 4000, 3), exact));
    EXPECT_TRUE(agree(exact_engine().develop_probability(slow, dev, 4000, 3), exact));
}

}  // namespace
}  // namespace filmgrain::stability
