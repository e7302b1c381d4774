// Tests of the expected characteristic curve (filmgrain/expected_curve.h)
// against the independent expectation of expectations.h (the exact chain
// run per photon count, over grain_counts.h's sizes and counts, whose
// quadrature grain_counts_test.cpp holds to closed-form moments), and of
// its inverse.
#include "filmgrain/expected_curve.h"

#include <gtest/gtest.h>

#include <cmath>

#include "model/development.h"
#include "expect/expectations.h"
#include "model/exposure.h"

namespace filmgrain {
namespace {

const std::vector<ExpectedCurve>& paper_curves()
{
    static const std::vector<ExpectedCurve> curves = [] {
        Stock stock;
        EXPECT_TRUE(load_stock("paper", stock));
        std::vector<ExpectedCurve> c;
        const Status s = expected_curves(stock, SceneSettings(), ExpectedCurveOptions(), c);
        EXPECT_TRUE(s) << s.message();
        return c;
    }();
    return curves;
}

TEST(ExpectedCurve, AgreesWithTheIndependentExpectationWithinItsStatedError)
{
    Stock stock;
    ASSERT_TRUE(load_stock("paper", stock));
    const std::vector<ExpectedCurve>& curves = paper_curves();
    ASSERT_EQ(curves.size(), 1u);
    const ExpectedCurve& c = curves[0];
    EXPECT_EQ(c.layer, "Y");
    EXPECT_GT(c.density_error, 0.0);
    EXPECT_LT(c.density_error, 0.01) << "a curve too coarse to invert";
    const Population& pop = stock.layers[0].populations[0];
    const SceneSettings scene;
    const Development dev(stock);
    DevelopGivenPhotons p_given_n({ pop.k_pair_per_s, pop.k_join_per_s, pop.k_loss_per_s },
                                  scene.shutter_s, dev, 1000, 77);
    const double lxs_per_value = exposure_lxs_per_unit_value(stock.exposure_at_grey_lxs, 0.0);
    // Fog, the toe and the straight part (paper: log10 H -2.45 to -2.0,
    // grey at its top). The reference runs the chain for every photon
    // count of every grain size: at grey and above it takes minutes.
    for (double stops : { -6.0, -3.0, -2.0, -1.0 }) {
        const double v = kGreyValue * std::exp2(stops);
        const DevelopmentMoments m = expected_development(pop, v * lxs_per_value, p_given_n);
        // MODEL.md 5: D = base + 0.434 n E[a P].
        const double d_ref  = stock.base_density
                             + 0.43429448190325176 * pop.grains_per_um2 * m.area_developed_um2.value;
        const double se_ref = 0.43429448190325176 * pop.grains_per_um2
                              * m.area_developed_um2.standard_error;
        // The curve's stated bound plus 4 standard errors of the reference
        // (a Monte Carlo estimate; two-sided 4 sigma fails by chance with
        // probability 6e-5 per point).
        EXPECT_NEAR(c.density_at(v), d_ref, c.density_error + 4.0 * se_ref)
            << "stops " << stops << " (bound " << c.density_error << ", reference se " << se_ref
            << ")";
    }
}

TEST(ExpectedCurve, DMinIsBasePlusFogAndTheCurveRises)
{
    Stock stock;
    ASSERT_TRUE(load_stock("paper", stock));
    const ExpectedCurve& c = paper_curves()[0];
    // v = 0: every grain develops with the fog probability f, exactly:
    // D = base + 0.434 n E[a] f (E[a] = pi/4 d^2 exp(s^2)), up to the
    // quadrature's truncation, inside the stated bound.
    const Population& pop = stock.layers[0].populations[0];
    const double ea       = M_PI / 4.0 * pop.diameter_um * pop.diameter_um
                      * std::exp(pop.diameter_log_sigma * pop.diameter_log_sigma);
    const double f        = Development(stock).fog_probability();
    const double d_min    = stock.base_density + 0.43429448190325176 * pop.grains_per_um2 * ea * f;
    EXPECT_NEAR(c.min_density(), d_min, c.density_error);
    EXPECT_EQ(c.points.front().value, 0.0);
    // fog_only gives the same point without running the chain.
    std::vector<ExpectedCurve> fog;
    ExpectedCurveOptions o;
    o.fog_only = true;
    ASSERT_TRUE(expected_curves(stock, SceneSettings(), o, fog));
    ASSERT_EQ(fog.size(), 1u);
    ASSERT_EQ(fog[0].points.size(), 1u);
    EXPECT_NEAR(fog[0].min_density(), c.min_density(), 1e-12);
    // Three stops over grey is far denser than fog.
    EXPECT_GT(c.density_at(kGreyValue * 8.0), c.min_density() + 1.0);
}

TEST(ExpectedCurve, InverseRoundTripsOverTheLatitude)
{
    const ExpectedCurve& c = paper_curves()[0];
    // Between the curve's points (16 per octave): the slope is one
    // segment's there.
    for (double stops = -4.0 + 1.0 / 32.0; stops <= 2.0; stops += 0.25) {
        const double v = kGreyValue * std::exp2(stops);
        EXPECT_NEAR(c.value_at_density(c.density_at(v)) / v, 1.0, 1e-9) << "stops " << stops;
        // The slope is the derivative of the interpolated curve.
        const double h   = 1e-6 * v;
        const double num = (c.transmittance_at(v + h) - c.transmittance_at(v - h)) / (2.0 * h);
        EXPECT_NEAR(c.transmittance_slope_at(v), num, 1e-5 * std::fabs(num) + 1e-12);
        EXPECT_GT(c.gamma_at(v), 0.0);
    }
    EXPECT_EQ(c.value_at_density(c.min_density()), 0.0);
    EXPECT_EQ(c.value_at_density(c.min_density() - 0.5), 0.0);
    EXPECT_EQ(c.value_at_density(NAN), 0.0);
    EXPECT_EQ(c.value_at_density(10.0), c.points.back().value);
}

TEST(ExpectedCurve, ErrorsNameTheValue)
{
    Stock stock;
    ASSERT_TRUE(load_stock("paper", stock));
    stock.layers[0].populations[0].rate_area_exponent = 0.5;
    std::vector<ExpectedCurve> c;
    const Status s = expected_curves(stock, SceneSettings(), ExpectedCurveOptions(), c);
    ASSERT_FALSE(s);
    EXPECT_NE(s.message().find("layers[0].populations[0].rate_area_exponent = 0.5"),
              std::string::npos)
        << s.message();
    ExpectedCurveOptions o;
    o.fog_only = true;
    EXPECT_TRUE(expected_curves(stock, SceneSettings(), o, c)) << "fog needs no table";
    o = ExpectedCurveOptions();
    o.target_standard_error = 0.0;
    stock.layers[0].populations[0].rate_area_exponent = 0.0;
    const Status t = expected_curves(stock, SceneSettings(), o, c);
    ASSERT_FALSE(t);
    EXPECT_NE(t.message().find("target_standard_error = 0"), std::string::npos) << t.message();
}

}  // namespace
}  // namespace filmgrain
