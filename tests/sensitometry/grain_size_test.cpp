// Larger grains, everything else the same, give a higher ISO speed.
#include <cmath>

#include <gtest/gtest.h>

#include "analysis.h"
#include "strip.h"
#include "test_support.h"

namespace filmgrain::sensitometry {
namespace {

struct SpeedPoint {
    double log10_h = 0.0, se = 0.0;
};

/// Speed point (D = base + fog + 0.1) of the paper stock with mean grain
/// diameter d: a strip through the toe, 0.1 log10 H apart, and the
/// crossing interpolated. Its error: the density errors at the crossing
/// (fog and the two patches) divided by the local slope.
SpeedPoint speed_point(double d_um, uint64_t seed)
{
    Stock stock = testing::load_test_stock("paper");
    stock.layers[0].populations[0].diameter_um = d_um;
    const Curve c
        = testing::measure_strip(stock, testing::test_strip(-3.8, -1.8, 0.1, 2.0e6, seed));
    const LayerCurve& l = c.layers[0];
    SpeedPoint sp;
    sp.log10_h = first_crossing(l.log10_h, l.density, l.fog_density + 0.1);
    for (size_t i = 1; i < l.density.size(); ++i)
        if (l.density[i] >= l.fog_density + 0.1) {
            const double slope = (l.density[i] - l.density[i - 1]) / (l.log10_h[i] - l.log10_h[i - 1]);
            const double se_d  = std::sqrt(l.fog_density_se * l.fog_density_se
                                           + 0.5 * (l.density_se[i] * l.density_se[i]
                                                    + l.density_se[i - 1] * l.density_se[i - 1]));
            sp.se = se_d / slope;
            break;
        }
    return sp;
}

TEST(GrainSize, LargerGrainsAreFaster)
{
    const SpeedPoint small = speed_point(4.5, 31);
    const SpeedPoint base  = speed_point(6.0, 32);
    const SpeedPoint large = speed_point(8.0, 33);
    ASSERT_FALSE(std::isnan(small.log10_h));
    ASSERT_FALSE(std::isnan(large.log10_h));
    // ISO speed 0.8 / H_m rises as H_m falls. Independent strips: the
    // difference has error hypot(se1, se2); require 3 sigma.
    EXPECT_GT(small.log10_h - base.log10_h, 3.0 * std::hypot(small.se, base.se))
        << "log10 H_m: 4.5 um " << small.log10_h << ", 6 um " << base.log10_h;
    EXPECT_GT(base.log10_h - large.log10_h, 3.0 * std::hypot(base.se, large.se))
        << "log10 H_m: 6 um " << base.log10_h << ", 8 um " << large.log10_h;
}

}  // namespace
}  // namespace filmgrain::sensitometry
