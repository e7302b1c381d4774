// Nutting: the mean (macro) density of a uniform patch equals
// 0.434 n E[a P] from D = 0.1 to 3 (exact in the mean for the Boolean model
// of overlapping discs, T = exp(-n E[aP])). E[aP] comes from
// expectations.h (quadrature over diameters, Poisson photon counts, the
// chain run on its own): independent of the render pipeline.
#include <cmath>

#include <gtest/gtest.h>

#include "expect/boolean_model.h"
#include "model/development.h"
#include "expect/expectations.h"
#include "strip.h"
#include "test_support.h"

namespace filmgrain::sensitometry {
namespace {

class Nutting : public ::testing::TestWithParam<double> {};

TEST_P(Nutting, MacroDensityIsPoint434TimesCoveredArea)
{
    const double target = GetParam();
    const Stock stock   = testing::load_test_stock("dense");
    const Population& pop = stock.layers[0].populations[0];
    double log10_h = 0.0;
    Status s = exposure_for_predicted_density(stock, 0, target, 1e-2, -2.0, log10_h);
    ASSERT_TRUE(s) << s.message();
    // The layer's exposure (its sensitivities sum to 1).
    const double h_lxs = std::pow(10.0, log10_h);

    const Development dev(stock);
    DevelopGivenPhotons given_n({ pop.k_pair_per_s, pop.k_join_per_s, pop.k_loss_per_s }, 1e-2,
                                dev, 3000, 0xa77);
    const DevelopmentMoments m = expected_development(pop, h_lxs, given_n);
    const double nutting = pop.grains_per_um2 * m.area_developed_um2.value / std::log(10.0);

    PatchBudget budget;
    budget.max_area_um2 = 1.0e6;
    budget.max_cost_s   = 0.3;
    const PatchSpec p = plan_patch(stock, h_lxs, 1e-2, budget, 90 + static_cast<uint64_t>(target * 10));
    PatchReading r;
    s = expose_patch(stock, p, testing::exact_settings(), r);
    ASSERT_TRUE(s) << s.message();
    // Fully covered pixels read 10^-20 instead of 0: negligible.
    ASSERT_LT(r.layers[0].clamp_density_bound, 1e-9);

    // Tolerance from the model, known before rendering: the variance of the
    // patch's mean transmittance under the Boolean model (exact, for this
    // square of pixels), through the delta method, 0.434 sigma_T / T; plus
    // the Monte Carlo error of E[aP]. 4 sigma (8 cases).
    BooleanLayer model;
    s = predict_layer(stock, 0, h_lxs, 1e-2, 1000, 0xa78, model);
    ASSERT_TRUE(s) << s.message();
    const double sigma_render = std::sqrt(square_transmittance_variance(model, r.side_px, r.pitch_um))
                                / model.mean_transmittance() / std::log(10.0);
    const double sigma_model = pop.grains_per_um2 * m.area_developed_um2.standard_error / std::log(10.0);
    const double sigma       = std::hypot(sigma_render, sigma_model);
    EXPECT_NEAR(r.layers[0].density, nutting, 4.0 * sigma)
        << "target " << target << ", sigma render " << sigma_render << ", model " << sigma_model
        << ", batch-means se " << r.layers[0].density_se;
    // The a-priori error and the batch-means error describe the same
    // scatter: they agree within the latter's own uncertainty (16 blocks:
    // about 18% relative; allow 3 times that).
    EXPECT_NEAR(r.layers[0].density_se / sigma_render, 1.0, 0.55);
}

INSTANTIATE_TEST_SUITE_P(Densities, Nutting, ::testing::Values(0.1, 0.3, 0.7, 1.0, 1.5, 2.0, 2.5, 3.0),
                         [](const auto& info) {
                             return "D" + std::to_string(static_cast<int>(info.param * 10));
                         });

}  // namespace
}  // namespace filmgrain::sensitometry
