// Longer development gives a higher gamma, and more fog.
#include <cmath>

#include <gtest/gtest.h>

#include "analysis.h"
#include "model/development.h"
#include "strip.h"
#include "test_support.h"

namespace filmgrain::sensitometry {
namespace {

struct Developed {
    CurveMetrics metrics;
    double fog_se = 0.0;
};

Developed develop(double time_s, uint64_t seed)
{
    Stock stock              = testing::load_test_stock("paper");
    stock.development_time_s = time_s;
    const Curve c
        = testing::measure_strip(stock, testing::test_strip(-3.0, -1.4, 0.15, 4.0e6, seed));
    return { analyse_curve(c.layers[0]), c.layers[0].fog_density_se };
}

TEST(Development, LongerDevelopmentRaisesGammaAndFog)
{
    const Developed shorter = develop(120.0, 41);
    const Developed longer  = develop(480.0, 42);
    // Gamma is a weighted regression slope over 0.6 log10 H; its error is
    // that regression's (from the patch errors). Independent strips: 3
    // sigma on the difference.
    EXPECT_GT(longer.metrics.gamma - shorter.metrics.gamma,
              3.0 * std::hypot(longer.metrics.gamma_se, shorter.metrics.gamma_se))
        << "gamma at 120 s " << shorter.metrics.gamma << ", at 480 s " << longer.metrics.gamma;
    // Fog: unexposed 4 mm^2 patches, batch-means errors; 3 sigma.
    EXPECT_GT(longer.metrics.base_fog_density - shorter.metrics.base_fog_density,
              3.0 * std::hypot(longer.fog_se, shorter.fog_se))
        << "fog at 120 s " << shorter.metrics.base_fog_density << ", at 480 s "
        << longer.metrics.base_fog_density;
    // And fog is what MODEL.md 4 says: 0.434 n E[a] (1 - exp(-t / fog_tau)),
    // within 4 sigma of the measurement.
    const Stock stock     = testing::load_test_stock("paper");
    const Population& pop = stock.layers[0].populations[0];
    const double ea       = M_PI / 4.0 * pop.diameter_um * pop.diameter_um
                      * std::exp(pop.diameter_log_sigma * pop.diameter_log_sigma);
    for (const auto& [t, d] : { std::pair { 120.0, shorter }, std::pair { 480.0, longer } }) {
        const double f = -std::expm1(-t / stock.fog_tau_s);
        EXPECT_NEAR(d.metrics.base_fog_density, pop.grains_per_um2 * ea * f / std::log(10.0),
                    4.0 * d.fog_se)
            << "development " << t << " s";
    }
}

}  // namespace
}  // namespace filmgrain::sensitometry
