// The Boolean-model machinery against closed forms: one size of disc, all
// developed, where K(h) = n lens(r, h) exactly, and an aperture sampled on a
// fine grid, whose variance must approach the ideal disc's
// (1/A^2) integral of C(h) lens(R, h) 2 pi h dh.
#include <cmath>

#include <gtest/gtest.h>

#include "expect/boolean_model.h"
#include "expect/expected_curve_model.h"
#include "testing/test_layers.h"

namespace filmgrain::sensitometry {
namespace {

BooleanLayer monodisperse(double n_per_um2, double d_um, double p_develop)
{
    PopulationDevelopment pop;
    pop.grains_per_um2 = n_per_um2;
    pop.nodes          = { DevelopedSize { d_um, 1.0, p_develop } };
    const double a     = M_PI / 4.0 * d_um * d_um;
    pop.develop_fraction    = p_develop;
    pop.area_developed_um2  = a * p_develop;
    pop.area2_developed_um4 = a * a * p_develop;
    return BooleanLayer({ pop }, ImageOverlap(), 0.005);
}

TEST(BooleanModel, MonodisperseCovarianceIsClosedForm)
{
    const BooleanLayer b = monodisperse(0.1, 6.0, 0.5);
    const double k0      = 0.1 * 0.5 * M_PI * 9.0;
    EXPECT_NEAR(b.coverage(), k0, 1e-12);
    EXPECT_NEAR(b.net_density(), k0 / std::log(10.0), 1e-12);
    EXPECT_NEAR(b.mean_developed_area_um2(), M_PI * 9.0, 1e-12);
    for (double h : { 0.5, 2.0, 4.1, 5.9 }) {
        const double k = 0.05 * lens_area_um2(3.0, h);
        // Linear interpolation of a table with 0.005 um steps.
        EXPECT_NEAR(b.overlap(h), k, 1e-4 * k0) << "h " << h;
        EXPECT_NEAR(b.covariance(h), std::exp(-2 * k0) * std::expm1(k), 1e-4 * k0) << "h " << h;
    }
    EXPECT_EQ(b.overlap(6.5), 0.0);
}

// A coupler-limited population (core dye.h FilledImage) beside one whose
// clouds add: the mean is the product of the additive part's exp(-B) and
// the limited one's 1 - o (1 - e^-m); the covariance is T^2 (e^K(h) (1 +
// o^2 q^2 (e^s(h) - 1) / T_p^2) - 1). At h = 0 with the additive part
// absent this is the point variance of T = 1 - o 1{covered}:
// o^2 q (1 - q), an independent closed form.
TEST(BooleanModel, CouplerLimitedCovarianceIsClosedForm)
{
    Layer layer;
    make_dye(layer, CloudProfile::disc, 1.5, 0.8);
    Population limited;
    limited.max_dye_density = 0.6;
    const ImageOverlap image(layer);
    const auto population = [&](double n, double d_um, bool fill) {
        PopulationDevelopment pop;
        pop.grains_per_um2   = n;
        pop.nodes            = { DevelopedSize { d_um, 1.0, 1.0 } };
        pop.develop_fraction = 1.0;
        pop.filled           = fill ? image.filled(limited) : FilledImage {};
        return pop;
    };
    const double o = 1.0 - std::pow(10.0, -0.6);
    // Clouds of radius 1.5 um at 0.2 per um^2: m = 0.2 pi 2.25.
    const double m = 0.2 * M_PI * 2.25, q = std::exp(-m);
    const BooleanLayer alone({ population(0.2, 2.0, true) }, image, 0.005);
    EXPECT_NEAR(alone.mean_transmittance(), 1.0 - o * (1.0 - q), 1e-12);
    EXPECT_NEAR(alone.net_density(), -std::log10(1.0 - o * (1.0 - q)), 1e-12);
    EXPECT_NEAR(alone.covariance(0.0), o * o * q * (1.0 - q), 1e-12);
    for (double h : { 0.5, 2.0 }) {
        const double s = 0.2 * lens_area_um2(1.5, h);
        EXPECT_NEAR(alone.covariance(h), o * o * q * q * std::expm1(s), 1e-4 * o * o * q)
            << "h " << h;
    }
    EXPECT_EQ(alone.covariance(3.1), 0.0);  // beyond two cloud radii
    // With an additive population of 1 um grains (clouds 1.5 x, density
    // 0.8) at 0.5 per um^2.
    const BooleanLayer both({ population(0.2, 2.0, true), population(0.5, 1.0, false) }, image,
                            0.005);
    const double b  = 0.5 * image.blocking_um2(0.5);
    const double tp = 1.0 - o * (1.0 - q), t = std::exp(-b) * tp;
    EXPECT_NEAR(both.mean_transmittance(), t, 1e-12);
    for (double h : { 0.0, 0.5, 1.2 }) {
        const double k = 0.5 * image.overlap_um2(0.5, h), s = 0.2 * lens_area_um2(1.5, h);
        const double expected
            = t * t * std::expm1(k + std::log1p(o * o * q * q * std::expm1(s) / (tp * tp)));
        EXPECT_NEAR(both.covariance(h), expected, 1e-4 * expected) << "h " << h;
    }
}

TEST(BooleanModel, FineGridApertureVarianceApproachesTheIdealDisc)
{
    const BooleanLayer b = monodisperse(0.1, 6.0, 0.7);
    const double r_ap    = 12.0;
    // Ideal disc: Var = (1/A^2) integral C(h) lens(R, h) 2 pi h dh (what
    // the datasheet figures read, datasheet.h).
    const double ideal = disc_aperture_transmittance_variance(b, 2.0 * r_ap);
    const double dh    = 0.001;
    // 0.25 um pixels: the pixel-weighted aperture differs from the disc only
    // in a band of one pixel around its rim (1/48 of the radius), which
    // changes the variance by well under 1%.
    const double grid = aperture_transmittance_variance(b, make_circular_aperture(2 * r_ap, 0.25));
    EXPECT_NEAR(grid / ideal, 1.0, 0.01);
    // Coarse pixels lose variance at the rim: less, never more.
    const double coarse = aperture_transmittance_variance(b, make_circular_aperture(2 * r_ap, 4.0));
    EXPECT_LT(coarse, grid);
    // A large square: Var * A tends to the integral of C(h) (Selwyn).
    double integral = 0.0;
    for (double h = 0.5 * dh; h < 6.0; h += dh)
        integral += b.covariance(h) * 2.0 * M_PI * h * dh;
    const int64_t side_px = 500;
    const double var_sq   = square_transmittance_variance(b, side_px, 2.0);
    // Edge loss ~ perimeter * mean overlap distance / area ~ 4 * 3 um / 1000 um.
    EXPECT_NEAR(var_sq * std::pow(side_px * 2.0, 2) / integral, 1.0, 0.02);
}

TEST(BooleanModel, LayerFromTheExpectedCurvesPiecesHasTheirCoverage)
{
    // boolean_layer_at composes the core's size quadrature and P(develop |
    // mean photons): its K(0) is coverage_exponent's, term for term.
    Stock stock;
    ASSERT_TRUE(load_stock("paper", stock));
    ExpectedCurveOptions o;
    o.target_standard_error = 1e-2;
    o.max_photons           = 256;
    DevelopModels models(stock, o);
    const LayerModel model(stock, 0, SceneSettings(), models);
    for (double v : { 0.0, 0.05, 0.18, 0.7 }) {
        const BooleanLayer b = boolean_layer_at(model.populations(), v);
        EXPECT_NEAR(b.coverage(), coverage_exponent(model.populations(), v),
                    1e-12 * (1.0 + b.coverage()))
            << "v " << v;
    }
}

}  // namespace
}  // namespace filmgrain::sensitometry
