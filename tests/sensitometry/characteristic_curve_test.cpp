// The characteristic curve of the paper stock, measured with the exact
// engine: non-decreasing within noise, with a toe and a shoulder (and, see
// below, the straight part the paper stock does not have).
#include <cmath>

#include <gtest/gtest.h>

#include "analysis.h"
#include "strip.h"
#include "test_support.h"

namespace filmgrain::sensitometry {
namespace {

/// The paper stock from its fog (log H = -3.6) to above its shoulder
/// (-0.9), 0.1 log H apart: 28 independent patches of up to 1 mm^2.
const Curve& paper_curve()
{
    static const Curve curve = [] {
        const Stock stock = testing::load_test_stock("paper");
        StripSpec spec           = testing::test_strip(-3.6, -0.9, 0.2, 2.0e6, 61);
        spec.budget.min_area_um2 = 1.0e5;
        return testing::measure_strip(stock, spec);
    }();
    return curve;
}

TEST(CharacteristicCurve, PaperStockIsNonDecreasingWithinNoise)
{
    const LayerCurve& l = paper_curve().layers.at(0);
    ASSERT_EQ(l.density.size(), 28u);
    // Patches are independent, so a step down D[i+1] - D[i] has standard
    // deviation sqrt(se_i^2 + se_i+1^2) (batch-means errors, themselves
    // uncertain by about 18% with 16 blocks). 4 sigma over 27 steps: a
    // monotone curve fails by chance with probability about 1e-3.
    for (size_t i = 0; i + 1 < l.density.size(); ++i) {
        const double step  = l.density[i + 1] - l.density[i];
        const double sigma = std::hypot(l.density_se[i], l.density_se[i + 1]);
        EXPECT_GE(step, -4.0 * sigma) << "log10 H " << l.log10_h[i] << " -> " << l.log10_h[i + 1];
    }
    // And it does rise: from fog to D-max, by far more than the noise.
    EXPECT_GT(l.density.back() - l.fog_density, 1.0);
}

TEST(CharacteristicCurve, PaperStockHasAToeAndAShoulder)
{
    const CurveMetrics m = analyse_curve(paper_curve().layers.at(0));
    // Operational definitions (analysis.h): gamma = steepest 0.6 log H
    // regression slope; toe / shoulder = the local slope (regression over
    // +-0.2 log H, 5 patches) at the lowest / highest exposure below
    // 0.3 gamma. The local slope's error is se_D / sqrt(sum (x - mean)^2)
    // = se_D / 0.32, under 0.03 here, against a margin of 0.3 gamma ~ 0.4.
    EXPECT_GT(m.gamma, 0.5);
    EXPECT_LT(std::fabs(m.toe_slope), 0.3 * m.gamma) << "gamma " << m.gamma;
    EXPECT_LT(std::fabs(m.shoulder_slope), 0.3 * m.gamma) << "gamma " << m.gamma;
    // The toe is a toe: the curve leaves fog gradually. Between the fog and
    // the steepest part the local slope passes through intermediate values
    // (at least one patch with a slope between 0.3 and 0.8 gamma).
    bool intermediate = false;
    for (size_t i = 0; i < m.slopes.size(); ++i)
        intermediate |= paper_curve().layers[0].log10_h[i] < m.gamma_log10_h_centre
                        && m.slopes[i] > 0.3 * m.gamma && m.slopes[i] < 0.8 * m.gamma;
    EXPECT_TRUE(intermediate);
    // D-max is the Boolean limit of every grain developing:
    // 0.434 n E[a] P_max with P_max <= 1.
    const Stock stock     = testing::load_test_stock("paper");
    const Population& pop = stock.layers[0].populations[0];
    const double ea = M_PI / 4.0 * pop.diameter_um * pop.diameter_um
                      * std::exp(pop.diameter_log_sigma * pop.diameter_log_sigma);
    EXPECT_LT(m.d_max, pop.grains_per_um2 * ea / std::log(10.0) + 0.03);
}

// The paper stock has no straight part of 0.6 log H: its local slope stays
// within 20% of gamma over about 0.45 log H only (measured: -2.45 to -2.0;
// gamma 1.27). One population of grains that develop after about four
// photons is a Poisson threshold detector whose curve is an S with no long
// straight line. Reported, not loosened: enable when the preset is
// recalibrated (e.g. with a second population, as the colour negative has).
TEST(CharacteristicCurve, PaperStockHasAStraightPartOf0p6LogH)
{
    const CurveMetrics m = analyse_curve(paper_curve().layers.at(0));
    EXPECT_GE(m.straight_log10_h_hi - m.straight_log10_h_lo, 0.6)
        << "straight part " << m.straight_log10_h_lo << " to " << m.straight_log10_h_hi
        << ", gamma " << m.gamma;
}

}  // namespace
}  // namespace filmgrain::sensitometry
