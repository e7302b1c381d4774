// The Boolean-model machinery against closed forms: one size of disc, all
// developed, where K(h) = n lens(r, h) exactly, and an aperture sampled on a
// fine grid, whose variance must approach the ideal disc's
// (1/A^2) integral of C(h) lens(R, h) 2 pi h dh.
#include <cmath>

#include <gtest/gtest.h>

#include "boolean_model.h"
#include "expected_curve_model.h"

namespace filmgrain::sensitometry {
namespace {

BooleanLayer monodisperse(double n_per_um2, double d_um, double p_develop)
{
    PopulationDevelopment pop;
    pop.grains_per_um2 = n_per_um2;
    pop.nodes          = { SizeNode { d_um, 1.0, p_develop } };
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
