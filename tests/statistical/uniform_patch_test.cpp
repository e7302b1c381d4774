// A uniformly exposed patch rendered by the exact engine agrees with the
// model in distribution (MODEL.md 2-5), at shutters spanning both
// reciprocity regimes:
//  - the developed fraction of the grains equals E[P], evaluated
//    independently (expectations.h: quadrature over diameters, Poisson over
//    photon counts, P(develop | N) from separate runs of the chain);
//  - the mean transmittance equals exp(-n E[a P]) (Boolean model).
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "expect/expectations.h"
#include "model/exposure.h"
#include "filmgrain/render.h"

namespace filmgrain {
namespace {

struct PatchResult {
    double developed_fraction = 0;
    double grains             = 0;
    double mean_transmittance = 0;
    double area_um2           = 0;
    double error_estimate     = 0;  ///< the engine's own density error bound
};

/// Renders a uniform grey frame of 2 mm and measures a central region
/// (inset 250 um from every edge, far more than any grain radius that
/// matters, so every measured grain sees the uniform exposure).
PatchResult render_patch(const Stock& stock, double stops, double shutter_s, uint64_t seed,
                         Engine engine, bool table)
{
    SceneSettings scene;
    scene.exposure_stops = stops;
    scene.shutter_s      = shutter_s;
    scene.width_mm = 2.0;
    scene.seed           = seed;
    std::vector<float> input(8 * 8, 0.18f);
    const ImageView view { input.data(), 8, 8, 1 };
    RenderSettings settings;
    settings.engine     = engine;
    // Grain by grain: the test counts developed grains (auto would draw this
    // patch at pixel scale once it builds a table; that scale has its own
    // tests, core PixelModel.* and docs/performance). The exact engine is
    // always grain by grain (and takes no override).
    if (engine != Engine::exact)
        settings.scale = ScaleMethod::grain;
    if (table)
        settings.kinetics = KineticsMethod::table;
    settings.scan_width = 64;  // 31.25 um pixels
    settings.roi        = Roi { 8, 8, 56, 56 };
    std::vector<float> density(48 * 48);
    RenderStats stats;
    const Status st = render_negative(stock, scene, view, settings, density.data(), &stats);
    EXPECT_TRUE(st) << st.message();
    PatchResult r;
    r.grains             = static_cast<double>(stats.layers[0].grains);
    r.developed_fraction = stats.layers[0].developed / r.grains;
    double sum_t = 0;
    for (float d : density)
        sum_t += std::pow(10.0, -(d - stock.base_density));
    r.mean_transmittance = sum_t / density.size();
    r.area_um2           = std::pow(48 * 31.25, 2);
    r.error_estimate     = stats.layers[0].error_estimate;
    return r;
}

struct Case {
    double shutter_s;
    double stops;
    Engine engine;
    /// kinetics=table: the tabulated path even where auto, on a frame this
    /// small (~4e5 grains), would find the chain cheaper.
    bool table = false;
};

void PrintTo(const Case& c, std::ostream* os)
{
    *os << "shutter " << c.shutter_s << " s, " << c.stops << " stops, engine "
        << name_of(c.engine) << (c.table ? " kinetics=table" : "");
}

class UniformPatch : public ::testing::TestWithParam<Case> {};

TEST_P(UniformPatch, AgreesWithTheModelInDistribution)
{
    const Case c = GetParam();
    // The paper's scale, frozen here so that calibrating the presets does
    // not move the test off the part of the curve it is meant to probe.
    Stock stock;
    stock.exposure_at_grey_lxs = 0.003;
    stock.max_density          = 20;  // keep the clamp out of the mean transmittance
    Population& p0             = stock.layers[0].populations[0];
    p0 = Population {};  // 0.1 grains/um^2, 6 um, sigma 0.3, MODEL.md 7 rates
    p0.quantum_efficiency = 0.05;
    const Population& pop = stock.layers[0].populations[0];
    const double exposure_lxs
        = 0.18 * exposure_lxs_per_unit_value(stock.exposure_at_grey_lxs, c.stops);

    const Development dev(stock);
    DevelopGivenPhotons p_given_n({ pop.k_pair_per_s, pop.k_join_per_s, pop.k_loss_per_s },
                                  c.shutter_s, dev, 3000, 0xfeed);
    const DevelopmentMoments m = expected_development(pop, exposure_lxs, p_given_n);
    const PatchResult r = render_patch(stock, c.stops, c.shutter_s, 11, c.engine, c.table);
    // The exact engine adds no error of its own, nor does the early-stopped
    // chain. A table reports a bound on the bias it may add to a patch
    // density; in transmittance that is T ln(10) times it, and in the
    // developed fraction about bound / (0.434 n E[a]) (the density bias is
    // an area-weighted mean of the P errors).
    if (c.engine == Engine::exact) {
        EXPECT_EQ(r.error_estimate, 0.0);
    }
    if (c.table) {
        EXPECT_GT(r.error_estimate, 0.0);
    }
    const double n_mean_area = pop.grains_per_um2 * m.area_developed_um2.value
                               / std::max(1e-12, m.develop_fraction.value);

    // Developed fraction: the grains develop independently given their
    // sizes, so the count is a sum of independent Bernoullis whose variance
    // is at most G p(1 - p); add the Monte Carlo variance of E[P]. 5 sigma.
    const double p     = m.develop_fraction.value;
    const double sigma = std::sqrt(p * (1 - p) / r.grains
                                   + std::pow(m.develop_fraction.standard_error, 2));
    EXPECT_NEAR(r.developed_fraction, p,
                5 * sigma + r.error_estimate / (0.43429448190325176 * n_mean_area))
        << "shutter " << c.shutter_s << " s, " << c.stops << " stops, mean photons "
        << m.mean_photons;
    // The test must be able to see development: P strictly inside (0, 1).
    EXPECT_GT(p, 0.05);
    EXPECT_LT(p, 0.95);

    // Mean transmittance of the region: T = exp(-n E[aP]). Its variance is
    // (1/A^2) double integral of the covariance C(h) = T^2 (exp(n k(h)) - 1)
    // of the uncovered indicator, k(h) the expected overlap of a developed
    // disc with its shift by h. Since exp(x) - 1 <= x exp(x) and k(h) <=
    // k(0) = E[aP], C(h) <= T n k(h), and the integral of k is E[a^2 P]:
    // Var <= T n E[a^2 P] / A. Add the Monte Carlo error of E[aP]. 5 sigma.
    const double n  = pop.grains_per_um2;
    const double t  = std::exp(-n * m.area_developed_um2.value);
    const double st = std::sqrt(t * n * m.area2_developed_um4.value / r.area_um2
                                + std::pow(t * n * m.area_developed_um2.standard_error, 2));
    EXPECT_NEAR(r.mean_transmittance, t, 5 * st + t * std::log(10.0) * r.error_estimate)
        << "shutter " << c.shutter_s << " s";
}

INSTANTIATE_TEST_SUITE_P(Shutters, UniformPatch,
                         // Exposures near the middle of each shutter's curve.
                         ::testing::Values(Case { 1e-6, -0.5, Engine::exact },
                                           Case { 1e-2, -2.0, Engine::exact },
                                           Case { 100.0, 1.0, Engine::exact },
                                           Case { 1e-6, -0.5, Engine::automatic },
                                           Case { 1e-2, -2.0, Engine::automatic },
                                           Case { 100.0, 1.0, Engine::automatic },
                                           Case { 1e-6, -0.5, Engine::automatic, true },
                                           Case { 1e-2, -2.0, Engine::automatic, true },
                                           Case { 100.0, 1.0, Engine::automatic, true }),
                         [](const auto& info) {
                             const double s = info.param.shutter_s;
                             return (s < 1e-3 ? std::string("Shutter1us")
                                     : s < 1  ? std::string("Shutter10ms")
                                              : std::string("Shutter100s"))
                                    + "_" + name_of(info.param.engine)
                                    + (info.param.table ? "_table" : "");
                         });

}  // namespace
}  // namespace filmgrain
