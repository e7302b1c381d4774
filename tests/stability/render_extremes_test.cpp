// Stability of render_negative (MODEL.md 1-5) on tiny frames at the
// extremes: grain diameters 0.01 to 100 um, grain densities 1e-6 to 50 per
// um^2, exposures from black (-64 stops) to thousands of photons per grain,
// shutters 1e-9 s to 1e6 s, development efficiency d -> 0 and d -> 1, the
// max_density clamp reached. Every render engine that kEngineNames lists is
// driven.
//
// Asserted: the render succeeds; every density is finite and within
// [base_density, base_density + max_density]; the statistics are
// consistent (developed <= grains, kinetics events <= absorbed photons: the
// chain's no-hang bound summed over grains); the analytic limits (no
// development: base density everywhere; everything develops over a covered
// frame: the clamp exactly; no light: fog only); density non-decreasing in
// exposure within noise; each render finishes within its deadline.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "checks.h"
#include "deadline.h"
#include "model/exposure.h"
#include "filmgrain/render.h"

namespace filmgrain::stability {
namespace {

/// The render engines this build knows (kEngineNames lists them, so
/// engines added to core are picked up here).
std::vector<Engine> render_engines()
{
    std::vector<Engine> out;
    for (const Named<Engine>& e : kEngineNames)
        out.push_back(e.value);
    return out;
}

/// One layer, one population of the given size and density (MODEL.md 7
/// rates, typical development).
Stock one_population_stock(double diameter_um, double grains_per_um2)
{
    Stock stock;
    stock.name       = "stability";
    Population& pop  = stock.layers[0].populations[0];
    pop.diameter_um  = diameter_um;
    pop.grains_per_um2 = grains_per_um2;
    pop.diameter_log_sigma = 0.3;
    pop.quantum_efficiency = 0.05;
    return stock;
}

/// Exposure offset (stops) that gives a grey pixel's grains of mean area
/// `target` absorbed photons on average (MODEL.md 2), within [-64, 64].
double stops_for_photons(const Stock& stock, double target)
{
    const Population& pop = stock.layers[0].populations[0];
    const double mean_area_um2 = M_PI / 4.0 * pop.diameter_um * pop.diameter_um
                                 * std::exp(pop.diameter_log_sigma * pop.diameter_log_sigma);
    const double at_zero = pop.quantum_efficiency * kPhotonsPerUm2PerLxs
                           * stock.exposure_at_grey_lxs * mean_area_um2;
    if (target <= 0.0)
        return -64.0;
    return std::clamp(std::log2(target / at_zero), -64.0, 64.0);
}

struct Outcome {
    Status status;
    std::vector<float> density;
    RenderStats stats;
};

/// A uniform grey (0.18) frame `frame_um` wide and high (a 2x2 input),
/// scanned at scan_px x scan_px.
Outcome render_uniform(const Stock& stock, Engine engine, double stops, double frame_um,
                       int64_t scan_px, double shutter_s = 1.0 / 48.0, uint64_t seed = 1,
                       int64_t roi_px = 0)
{
    SceneSettings scene;
    scene.exposure_stops = stops;
    scene.shutter_s      = shutter_s;
    scene.width_mm = frame_um / 1000.0;
    scene.seed           = seed;
    std::vector<float> input(4, 0.18f);
    const ImageView view { input.data(), 2, 2, 1 };
    RenderSettings settings;
    settings.engine      = engine;
    settings.scan_width  = scan_px;
    settings.scan_height = scan_px;
    settings.nthreads    = 2;
    int64_t out_px       = scan_px;
    if (roi_px > 0 && roi_px < scan_px) {
        const int64_t c = (scan_px - roi_px) / 2;  // centred
        settings.roi    = Roi { c, c, c + roi_px, c + roi_px };
        out_px          = roi_px;
    }
    Outcome out;
    out.density.assign(static_cast<size_t>(out_px * out_px * stock.layers.size()), -1.0f);
    out.status = render_negative(stock, scene, view, settings, out.density.data(), &out.stats);
    return out;
}

/// Finite densities within [base, base + max_density] and consistent
/// statistics.
::testing::AssertionResult sane(const Outcome& o, const Stock& stock)
{
    if (!o.status)
        return ::testing::AssertionFailure() << "render failed: " << o.status.message();
    const float lo = static_cast<float>(stock.base_density);
    const float hi = static_cast<float>(stock.base_density + stock.max_density);
    for (size_t i = 0; i < o.density.size(); ++i)
        if (!std::isfinite(o.density[i]) || o.density[i] < lo || o.density[i] > hi)
            return ::testing::AssertionFailure() << "density[" << i << "] = " << o.density[i]
                                                 << " outside [" << lo << ", " << hi << "]";
    for (const LayerStats& l : o.stats.layers) {
        if (l.developed > l.grains)
            return ::testing::AssertionFailure() << l.developed << " developed of " << l.grains;
        if (l.kinetics_events > l.absorbed_photons)
            return ::testing::AssertionFailure() << l.kinetics_events << " events from "
                                                 << l.absorbed_photons << " photons";
        if (!std::isfinite(l.mean_density))
            return ::testing::AssertionFailure() << "mean density " << l.mean_density;
    }
    return ::testing::AssertionSuccess();
}

/// Side of a square frame holding about `grains` grain centres.
double frame_for_grains(double grains_per_um2, double grains)
{
    return std::sqrt(grains / grains_per_um2);
}

void grain_size_and_density_grid(const std::vector<Engine>& engines)
{
    // 5 diameters x 4 densities x {black, ~30, ~3000 photons per grain}.
    // Frames hold ~1000 grain centres (at least one diameter across): up to
    // 32 mm for 1e-6 grains per um^2. Scan pixels are at most 16 diameters
    // (coarser scans of fine grains: DISABLED_ScanPixelsFarLargerThanGrains
    // below), and an 8x8 ROI in the middle is rendered. The densest large
    // grains still reach ~4e5 grains into one pixel, so the brightest
    // exposure is skipped where it would cost more than ~2e7 chain steps.
    for (Engine engine : engines)
        for (double diameter_um : { 0.01, 0.1, 1.0, 10.0, 100.0 })
            for (double grains_per_um2 : { 1e-6, 1e-3, 1.0, 50.0 }) {
                const Stock stock = one_population_stock(diameter_um, grains_per_um2);
                const double frame_um
                    = std::max(frame_for_grains(grains_per_um2, 1000.0), diameter_um);
                const int64_t scan_px = std::clamp<int64_t>(
                    static_cast<int64_t>(std::ceil(frame_um / (16.0 * diameter_um))), 8, 1 << 20);
                const double pitch_um = frame_um / static_cast<double>(scan_px);
                const double touching
                    = grains_per_um2 * std::pow(8.0 * pitch_um + 2.0 * diameter_um, 2.0);
                for (double photons : { 0.0, 30.0, 3000.0 }) {
                    if (touching * photons > 2e7)
                        continue;
                    const double stops = stops_for_photons(stock, photons);
                    // In a child process with a deadline: a hang fails the
                    // test instead of stalling the suite until its TIMEOUT.
                    EXPECT_TRUE(finishes_within(60.0, [&] {
                        const auto ok = sane(render_uniform(stock, engine, stops, frame_um,
                                                            scan_px, 1.0 / 48.0, 1, 8),
                                             stock);
                        if (!ok)
                            std::fprintf(stderr, "%s\n", ok.message());
                        return static_cast<bool>(ok);
                    })) << name_of(engine) << ": diameter " << diameter_um << " um, "
                        << grains_per_um2 << " per um^2, ~" << photons << " photons, frame "
                        << frame_um << " um, scan " << scan_px;
                }
            }
}

// Every engine, auto included. (First failure: auto tabulated P(develop|N)
// up to the largest photon count the scene could give whatever the number
// of grains the table served: 10 um grains at 1 per um^2 on a 45 um frame
// (1910 grains) took 45 s of table setup against 0.5 s for exact. Auto now
// builds a table only when it is predicted to cost fewer chain steps than
// the frame's grains would spend in the early-stopped chain, else runs
// that chain.)
TEST(StabilityRender, GrainSizesAndDensities) { grain_size_and_density_grid(render_engines()); }

// Scans whose pixels are far larger than the grains (thumbnails of fine
// grain) cost what their discs cost. (First failure: the exact block
// coverage bucketed discs on cells two mean radii wide over the whole tile
// block, (block / radius)^2 cells whatever the number of discs: an 8x8 scan
// of a 1.4 mm frame of 0.01 um grains failed with std::bad_alloc; 67 grains
// of 1 um on a 45 mm frame took minutes. The cells are now also at most
// about four per disc.)
TEST(StabilityRender, ScanPixelsFarLargerThanGrains)
{
    struct Case {
        double diameter_um, grains_per_um2, frame_um;
    };
    for (Engine engine : render_engines())
        for (const Case& c : { Case { 0.01, 1e-3, 1414.0 }, Case { 1.0, 1e-6, 44721.0 },
                               Case { 0.1, 1.0, 2000.0 } }) {
            const Stock stock = one_population_stock(c.diameter_um, c.grains_per_um2);
            EXPECT_TRUE(finishes_within(30.0, [&] {
                const auto ok = sane(render_uniform(stock, engine, stops_for_photons(stock, 30.0),
                                                    c.frame_um, 8),
                                     stock);
                if (!ok)
                    std::fprintf(stderr, "%s\n", ok.message());
                return static_cast<bool>(ok);
            })) << name_of(engine) << ": diameter " << c.diameter_um << " um, "
                << c.grains_per_um2 << " per um^2, frame " << c.frame_um << " um, 8x8 scan";
        }
}

TEST(StabilityRender, ShutterExtremes)
{
    // A 1e-9 s flash and a 1e6 s (11.6 day) exposure of the same film, at
    // ~300 photons per grain: both finish and stay sane.
    const Stock stock = one_population_stock(2.0, 0.2);
    for (Engine engine : render_engines())
        for (double shutter_s : { 1e-9, 1e-3, 1e6 }) {
            const Outcome o = render_uniform(stock, engine, stops_for_photons(stock, 300.0),
                                             100.0, 16, shutter_s);
            EXPECT_TRUE(sane(o, stock)) << name_of(engine) << " shutter " << shutter_s;
        }
}

TEST(StabilityRender, NoLightGivesFogOnly)
{
    // -64 stops: ~1e-17 photons per grain, so every grain has N < 4 and
    // develops with probability f (MODEL.md 4): the developed count is
    // Binomial(G, f) given G grains; kSigmas of its sd, plus 1/G (a count).
    const Stock stock = one_population_stock(1.0, 1.0);
    const double f = 1.0 - std::exp(-stock.development_time_s / stock.fog_tau_s);
    for (Engine engine : render_engines()) {
        const Outcome o = render_uniform(stock, engine, -64.0, 60.0, 8);
        ASSERT_TRUE(sane(o, stock));
        const LayerStats& l = o.stats.layers[0];
        const double g      = static_cast<double>(l.grains);
        ASSERT_GT(g, 1000.0);
        EXPECT_EQ(l.absorbed_photons, 0u);
        EXPECT_NEAR(l.developed / g, f, kSigmas * std::sqrt(f * (1 - f) / g) + 1.0 / g)
            << name_of(engine);
    }
}

TEST(StabilityRender, NoDevelopmentGivesBaseDensity)
{
    // development_time_s = 0: d = f = 0, no grain develops whatever its
    // latent image (MODEL.md 4), so every pixel has transmittance 1 and
    // density exactly base_density, at every exposure.
    Stock stock              = one_population_stock(3.0, 0.5);
    stock.development_time_s = 0.0;
    stock.base_density       = 0.25;
    for (Engine engine : render_engines())
        for (double photons : { 0.0, 30.0, 3000.0 }) {
            const Outcome o = render_uniform(stock, engine, stops_for_photons(stock, photons),
                                             60.0, 8);
            ASSERT_TRUE(sane(o, stock));
            EXPECT_EQ(o.stats.layers[0].developed, 0u);
            for (float d : o.density)
                ASSERT_EQ(d, 0.25f) << name_of(engine);
        }
}

TEST(StabilityRender, FullDevelopmentReachesTheClamp)
{
    // Fog certain (f = 1 - exp(-360 / 1e-3) = 1): every grain develops. At
    // 50 grains of 5 um per um^2 a point is uncovered with probability
    // exp(-50 * 19.6) = 0, so the transmittance is 0 and the density is the
    // clamp exactly: base + max_density (MODEL.md 5), for the smallest and
    // largest max_density allowed. d -> 1 at the same time.
    for (double max_density : { 1e-3, 4.0, 20.0 }) {
        Stock stock              = one_population_stock(5.0, 50.0);
        stock.fog_tau_s          = 1e-3;
        stock.development_tau_s  = 1e-3;
        stock.max_density        = max_density;
        stock.base_density       = 0.1;
        for (Engine engine : render_engines()) {
            const Outcome o = render_uniform(stock, engine, -64.0, 4.0, 4);
            ASSERT_TRUE(sane(o, stock));
            EXPECT_EQ(o.stats.layers[0].developed, o.stats.layers[0].grains);
            for (float d : o.density)
                ASSERT_EQ(d, static_cast<float>(0.1 + max_density))
                    << name_of(engine) << " max_density " << max_density;
        }
    }
}

TEST(StabilityRender, EfficiencyToZeroAndOne)
{
    // d -> 0 (1e-18) with no fog: P ~ 1e-18 per centre, nothing develops.
    // d -> 1 with no fog: a grain develops iff it holds a 4-centre; at
    // ~3000 photons per grain with the MODEL.md 7 rates nearly all do.
    Stock d0              = one_population_stock(2.0, 0.5);
    d0.development_time_s = 1e-6;
    d0.development_tau_s  = 1e12;
    d0.fog_tau_s          = 1e30;
    Stock d1              = one_population_stock(2.0, 0.5);
    d1.development_time_s = 1e7;
    d1.development_tau_s  = 1e-3;
    d1.fog_tau_s          = 1e30;
    for (Engine engine : render_engines()) {
        const Outcome o0 = render_uniform(d0, engine, stops_for_photons(d0, 3000), 60.0, 8);
        ASSERT_TRUE(sane(o0, d0));
        EXPECT_EQ(o0.stats.layers[0].developed, 0u);
        const Outcome o1 = render_uniform(d1, engine, stops_for_photons(d1, 3000), 60.0, 8);
        ASSERT_TRUE(sane(o1, d1));
        EXPECT_GT(o1.stats.layers[0].developed, o1.stats.layers[0].grains * 9 / 10);
    }
}

TEST(StabilityRender, DensityRisesWithExposure)
{
    // From black to ~1e4 photons per grain in steps of 3 stops, on three
    // grain scales: the developed fraction never falls by more than the
    // noise. Given G grains the developed count is Binomial(G, p) (the
    // exposure is uniform: grains are i.i.d.), sd sqrt(p(1-p)/G). Renders
    // share the seed, hence the grains: their fractions are positively
    // correlated and Var(a - b) <= Var(a) + Var(b), the allowance used
    // (kSigmas of it, plus 1/G per side for p at 0 or 1).
    for (Engine engine : render_engines())
        for (double diameter_um : { 0.2, 2.0, 20.0 }) {
            const Stock stock     = one_population_stock(diameter_um, 0.5 / (diameter_um * diameter_um));
            const double frame_um = frame_for_grains(stock.layers[0].populations[0].grains_per_um2,
                                                     3000.0);
            const double grey     = stops_for_photons(stock, 1.0);
            double prev_p = -1.0, prev_g = 1.0;
            for (double stops = grey - 4.0; stops <= grey + 14.0; stops += 3.0) {
                const Outcome o = render_uniform(stock, engine, stops, frame_um, 8);
                ASSERT_TRUE(sane(o, stock));
                const double g = static_cast<double>(o.stats.layers[0].grains);
                const double p = o.stats.layers[0].developed / g;
                if (prev_p >= 0.0) {
                    const double noise
                        = kSigmas * std::sqrt(p * (1 - p) / g + prev_p * (1 - prev_p) / prev_g)
                          + 1.0 / g + 1.0 / prev_g;
                    EXPECT_GE(p, prev_p - noise) << name_of(engine) << " d " << diameter_um
                                                 << " stops " << stops;
                }
                prev_p = p;
                prev_g = g;
            }
            EXPECT_GT(prev_p, 0.9) << "the sweep reaches the shoulder";
        }
}

// Exposures beyond the model's limit (1e10 absorbed photons per mean grain,
// docs/reference.md "Limits and guarantees") are refused with an error
// naming the exposure; up to it a render finishes with saturated grains.
// (First failure: the photon sampler's cast to uint64_t was undefined beyond
// 2^64: +64 stops on a grey pixel asked the chain for ~1e19 photons and
// never finished, and a 1e30 pixel gave N = 0, fog only.)
TEST(StabilityRender, HugeExposureSaturatesAndFinishes)
{
    const Stock stock = one_population_stock(6.0, 0.1);
    struct Case {
        float value;
        double stops;
        bool saturated;
    };
    // ~1e20 and ~1e32 photons per grain, and +Inf: past the largest
    // exposure the kinetics represent (1e10 a mean grain, MODEL.md 2), so
    // clamped to it, where every grain develops; ~1e4 and ~1e9 as they are.
    // Every engine, exact too, stops a grain's chain once it is decided:
    // its cost must not follow the photons (it took exact ~50 s a grain at
    // 1e9 before).
    const double grey = stops_for_photons(stock, 1.0);
    for (Engine engine : render_engines())
        for (const Case& c : { Case { 0.18f, 64.0, true }, Case { 1e30f, 0.0, true },
                               Case { std::numeric_limits<float>::infinity(), 0.0, true },
                               Case { 0.18f, grey + std::log2(1e4), false },
                               Case { 0.18f, grey + std::log2(1e9), false } }) {
            EXPECT_TRUE(finishes_within(30.0, [&] {
                SceneSettings scene;
                scene.exposure_stops = c.stops;
                scene.width_mm = 0.2;
                std::vector<float> input(4, c.value);
                const ImageView view { input.data(), 2, 2, 1 };
                RenderSettings settings;
                settings.engine = engine;
                std::vector<float> density(4);
                RenderStats stats;
                const Status s
                    = render_negative(stock, scene, view, settings, density.data(), &stats);
                if (!s) {
                    std::fprintf(stderr, "failed: %s\n", s.message().c_str());
                    return false;
                }
                if (stats.input.saturated_pixels != (c.saturated ? 4u : 0u))
                    return false;
                for (float d : density)
                    if (!std::isfinite(d))
                        return false;
                const LayerStats& l = stats.layers[0];
                std::fprintf(stderr, "value %g at %g stops: %llu of %llu grains developed\n",
                             c.value, c.stops, static_cast<unsigned long long>(l.developed),
                             static_cast<unsigned long long>(l.grains));
                return l.grains > 0 && l.developed * 10 >= l.grains * 9;
            })) << name_of(engine) << " value " << c.value << " stops " << c.stops;
        }
}

// MODEL.md 8-10 at their extremes, every engine: kernels far below and far
// above the pixel (a point-like halo, a 5 mm halo on a 0.2 mm frame, the
// base kernel of a 1 nm base and of a 2 mm glass plate (reach 164 mm), a
// near-zero scatter width), all light scattered or reflected, dye clouds a
// tenth and ten times their grain with a peak density far over the clamp,
// and the strongest inhibition with no and with the widest diffusion. The
// densities stay finite within [base, base + max_density] and the render
// ends within its deadline; the strongest inhibition without diffusion
// holds back more than half the development.
TEST(StabilityRender, LookExtremes)
{
    struct Case {
        const char* what;
        void (*apply)(Stock&);
    };
    const Case cases[] = {
        { "point-like halo", [](Stock& s) {
              s.layers[0].halation = 1.0;
              s.layers[0].halation_radius_um = 1e-9;
          } },
        { "5 mm ring halo", [](Stock& s) {
              s.layers[0].halation = 1.0;
              s.layers[0].halation_radius_um = 5000.0;
              s.layers[0].halation_kernel = HalationKernel::ring;
          } },
        { "base halo of a 1 nm base", [](Stock& s) {
              s.layers[0].halation = 1.0;
              s.layers[0].halation_kernel = HalationKernel::base;
              s.base_thickness_um = 1e-3;
          } },
        { "base halo of a 2 mm bare glass plate", [](Stock& s) {
              s.layers[0].halation = 1.0;
              s.layers[0].halation_kernel = HalationKernel::base;
              s.base_thickness_um = 2000.0;
              s.base_refractive_index = 2.0;
              s.rear_face = RearFace::bare;
          } },
        { "all light scattered, tiny width", [](Stock& s) {
              s.layers[0].scatter = 1.0;
              s.layers[0].scatter_sigma_um = 1e-300;
          } },
        { "small disc clouds over the clamp", [](Stock& s) {
              s.layers[0].image = LayerImage::dye;
              s.layers[0].cloud_diameter_ratio = 0.1;
              s.layers[0].cloud_density = 20.0;
              s.max_density = 0.01;
          } },
        { "wide gaussian clouds", [](Stock& s) {
              s.layers[0].image = LayerImage::dye;
              s.layers[0].cloud_profile = CloudProfile::gaussian;
              s.layers[0].cloud_diameter_ratio = 10.0;
              s.layers[0].cloud_density = 20.0;
          } },
        { "strongest inhibition, no diffusion", [](Stock& s) { s.inhibition = { { 10.0 } }; } },
        { "strongest inhibition, widest diffusion", [](Stock& s) {
              s.inhibition = { { 10.0 } };
              s.inhibitor_diffusion_um = 1000.0;
          } },
    };
    for (const Case& c : cases) {
        Stock stock = one_population_stock(1.0, 2.0);
        c.apply(stock);
        ASSERT_TRUE(stock.validate()) << c.what;
        const double grey = stops_for_photons(stock, 10.0);
        for (Engine engine : render_engines()) {
            // The work runs in a child process (finishes_within): it checks
            // and says what failed itself.
            EXPECT_TRUE(finishes_within(60.0, [&] {
                const Outcome o = render_uniform(stock, engine, grey, 200.0, 32);
                if (const auto ok = sane(o, stock); !ok) {
                    std::fprintf(stderr, "%s, %s: %s\n", c.what, name_of(engine),
                                 ok.message());
                    return false;
                }
                if (!stock.inhibits() || stock.inhibitor_diffusion_um > 0.0)
                    return true;
                // Without diffusion every grain is held back by exp(-10 D)
                // at the grey's density: far fewer develop than without.
                // (With 1 mm of diffusion on a 0.2 mm frame the unexposed
                // film around it dominates the blur: only sanity above.)
                Stock free = stock;
                free.inhibition.clear();
                const Outcome f = render_uniform(free, engine, grey, 200.0, 32);
                if (!f.status || o.stats.layers[0].developed * 2 >= f.stats.layers[0].developed) {
                    std::fprintf(stderr, "%s, %s: %llu developed inhibited, %llu without\n",
                                 c.what, name_of(engine),
                                 static_cast<unsigned long long>(o.stats.layers[0].developed),
                                 static_cast<unsigned long long>(
                                     f.status ? f.stats.layers[0].developed : 0));
                    return false;
                }
                return true;
            })) << c.what << " " << name_of(engine);
        }
    }
}

}  // namespace
}  // namespace filmgrain::stability
