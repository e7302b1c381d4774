// Exact unit tests of the curve analysis and the model helpers: known
// inputs, known answers (no rendering).
#include <cmath>

#include <gtest/gtest.h>

#include "analysis.h"
#include "expect/boolean_model.h"

namespace filmgrain::sensitometry {
namespace {

TEST(Analysis, LineFitRecoversAnExactLine)
{
    const std::vector<double> x { 0, 1, 2, 3 }, y { 1, 3, 5, 7 };
    const LineFit f = fit_line(x, y, {});
    EXPECT_NEAR(f.slope, 2.0, 1e-12);
    EXPECT_NEAR(f.intercept, 1.0, 1e-12);
    EXPECT_NEAR(f.slope_se, 0.0, 1e-9);
}

TEST(Analysis, CrossingAndInterpolation)
{
    const std::vector<double> x { 0, 1, 2 }, y { 0.1, 0.3, 0.9 };
    EXPECT_NEAR(first_crossing(x, y, 0.2), 0.5, 1e-12);
    EXPECT_NEAR(first_crossing(x, y, 0.6), 1.5, 1e-12);
    EXPECT_TRUE(std::isnan(first_crossing(x, y, 2.0)));
    EXPECT_NEAR(interpolate(x, y, 1.25), 0.45, 1e-12);
    EXPECT_EQ(interpolate(x, y, 9.0), 0.9);
}

/// A synthetic curve with known numbers: fog 0.2, then a straight line of
/// slope 0.7 from log H = -2 to 0, flat above (D-max 1.6).
LayerCurve synthetic_curve()
{
    LayerCurve c;
    c.fog_density = 0.2;
    for (int i = 0; i <= 60; ++i) {
        const double x = -4.0 + 0.1 * i;
        c.log10_h.push_back(x);
        c.density.push_back(0.2 + 0.7 * std::clamp(x + 2.0, 0.0, 2.0));
        c.density_se.push_back(0.01);
    }
    return c;
}

TEST(Analysis, CurveMetricsOfAKnownCurve)
{
    const CurveMetrics m = analyse_curve(synthetic_curve());
    EXPECT_NEAR(m.d_max, 1.6, 1e-12);
    // D = 0.3 at log H = -2 + 0.1 / 0.7.
    EXPECT_NEAR(m.speed_log10_h, -2.0 + 0.1 / 0.7, 1e-9);
    EXPECT_NEAR(m.iso_speed, 0.8 / std::pow(10.0, -2.0 + 0.1 / 0.7), 1e-6);
    EXPECT_NEAR(m.gamma, 0.7, 1e-9);
    // 1.30 log H above the speed point is still on the line.
    EXPECT_NEAR(m.iso_delta_density, 0.7 * 1.3, 1e-9);
    EXPECT_NEAR(m.toe_slope, 0.0, 1e-9);
    EXPECT_NEAR(m.shoulder_slope, 0.0, 1e-9);
    // Within 20% of gamma: the line, less the +-0.2 smoothing at each end
    // (at -1.9 and -0.1 the 5-point regression gives exactly 0.8 gamma, so
    // rounding decides whether they are in).
    EXPECT_NEAR(m.straight_log10_h_lo, -1.85, 0.05 + 1e-9);
    EXPECT_NEAR(m.straight_log10_h_hi, -0.15, 0.05 + 1e-9);
}

TEST(Analysis, GammaTimeFitRecoversItsParameters)
{
    std::vector<double> t, g;
    for (double s : { 30.0, 60.0, 120.0, 240.0, 480.0, 960.0 }) {
        t.push_back(s);
        g.push_back(1.4 * (1.0 - std::exp(-s / 150.0)));
    }
    const GammaTimeFit f = fit_gamma_vs_time(t, g, {});
    EXPECT_NEAR(f.gamma_inf, 1.4, 1e-6);
    EXPECT_NEAR(f.k_per_s, 1.0 / 150.0, 1e-8);
}

TEST(BooleanModel, LensArea)
{
    EXPECT_NEAR(lens_area_um2(2.0, 0.0), M_PI * 4.0, 1e-12);
    EXPECT_EQ(lens_area_um2(2.0, 4.0), 0.0);
    // Two unit discs at distance 1: 2 acos(1/2) - sqrt(3)/2.
    EXPECT_NEAR(lens_area_um2(1.0, 1.0), 2.0 * std::acos(0.5) - std::sqrt(3.0) / 2.0, 1e-12);
}

TEST(BooleanModel, ApertureWeightsSumToTheDiscArea)
{
    for (double pitch : { 2.0, 3.0, 4.0 }) {
        const ApertureTemplate a = make_circular_aperture(48.0, pitch);
        EXPECT_NEAR(a.area_um2(), M_PI * 24.0 * 24.0, 1e-6) << "pitch " << pitch;
    }
}

TEST(BooleanModel, SiedentopfFormula)
{
    // sigma^2 = 0.434 a D / A.
    EXPECT_NEAR(siedentopf_sigma_density(30.0, 0.5, 1800.0),
                std::sqrt(std::log10(std::exp(1.0)) * 30.0 * 0.5 / 1800.0), 1e-15);
}

}  // namespace
}  // namespace filmgrain::sensitometry
