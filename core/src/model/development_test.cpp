// Tests of development (MODEL.md 4).
#include "model/development.h"

#include <cmath>
#include <limits>

#include "util/rng.h"

#include <gtest/gtest.h>

namespace filmgrain {
namespace {

TEST(Development, EfficiencyFogAndSurvival)
{
    Stock stock;
    stock.development_time_s = 100;
    stock.development_tau_s  = 50;
    stock.fog_tau_s          = 1000;
    const Development dev(stock);
    const double d = 1 - std::exp(-2.0), f = 1 - std::exp(-0.1);
    EXPECT_NEAR(dev.efficiency(), d, 1e-15);
    EXPECT_NEAR(dev.fog_probability(), f, 1e-15);
    EXPECT_NEAR(dev.develop_probability(0), f, 1e-15);
    EXPECT_NEAR(dev.develop_probability(3), 1 - (1 - f) * std::pow(1 - d, 3), 1e-15);
    // develops(u) iff u >= survival: the boundary is exact.
    const double s = dev.survival_probability(1);
    EXPECT_FALSE(dev.develops(1, std::nextafter(s, 0.0)));
    EXPECT_TRUE(dev.develops(1, s));
}

TEST(Development, LimitsOfEfficiency)
{
    Stock stock;
    stock.development_time_s = 0;  // d = 0 and f = 0: nothing develops
    Development none(stock);
    EXPECT_EQ(none.develop_probability(1000), 0.0);
    stock.development_time_s = 1e7;
    stock.development_tau_s  = 1e-3;  // d -> 1: any 4-centre develops
    stock.fog_tau_s          = 1e30;
    Development full(stock);
    EXPECT_EQ(full.develop_probability(1), 1.0);
    EXPECT_NEAR(full.fog_probability(), 1e-23, 1e-36);
    EXPECT_EQ(full.develop_probability(uint64_t(1) << 62), 1.0);
}

TEST(Development, NeededCentresAgreeWithDevelops)
{
    Stock stock;
    const Development dev(stock);
    Rng rng(3, Stage::development);
    for (int i = 0; i < 100000; ++i) {
        const double u   = rng.uniform();
        const uint64_t k = dev.n4_needed(u);
        ASSERT_LT(k, 1000u);
        for (uint64_t n : { uint64_t(0), k > 0 ? k - 1 : 0, k, k + 1, k + 5 })
            ASSERT_EQ(dev.develops(n, u), n >= k) << "u " << u << " n " << n << " k " << k;
    }
    stock.development_time_s = 0;  // d = 0, f = 0: nothing ever develops
    EXPECT_EQ(Development(stock).n4_needed(0.5), std::numeric_limits<uint64_t>::max());
}

}  // namespace
}  // namespace filmgrain
