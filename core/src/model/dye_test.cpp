// Tests of MODEL.md 8 (dye layers): the clouds' blocking area, the sampled
// image of one cloud, uniform patches against the expected value, the
// silver limit, the sampling's convergence, and determinism.
#include "model/dye.h"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "filmgrain/expected_curve.h"
#include "filmgrain/render.h"
#include "testing/test_render.h"
#include "testing/test_layers.h"

namespace filmgrain {
namespace {

/// integral over the plane of (1 - 10^-D_1(x)) over the grain's area, by
/// the midpoint rule in the radius (20000 steps to the cloud's reach).
double blocking_numeric(const Layer& layer)
{
    const double r = 1.0, rc = layer.cloud_diameter_ratio * r;
    const double reach = layer.cloud_profile == CloudProfile::gaussian ? 6.0 * rc : rc;
    const int n = 20000;
    double sum  = 0.0;
    for (int i = 0; i < n; ++i) {
        const double rho = (i + 0.5) * reach / n;
        const double d   = layer.cloud_density
                         * (layer.cloud_profile == CloudProfile::gaussian
                                ? std::exp(-2.0 * rho * rho / (rc * rc))
                                : 1.0);
        sum += (1.0 - std::pow(10.0, -d)) * 2.0 * M_PI * rho * reach / n;
    }
    return sum / (M_PI * r * r);
}

/// integral of (1 - 10^-D_1(x)) (1 - 10^-D_1(x + h)) over the plane, grain
/// radius 1, by the midpoint rule on a grid of step 1/200 cloud radii.
double overlap_numeric(const Layer& layer, double h)
{
    const double rc = layer.cloud_diameter_ratio;
    const bool gaussian = layer.cloud_profile == CloudProfile::gaussian;
    const double reach  = gaussian ? 3.0 * rc : rc;
    const auto f = [&](double x, double y) {
        const double q = (x * x + y * y) / (rc * rc);
        if (q > (reach / rc) * (reach / rc))
            return 0.0;
        return 1.0 - std::pow(10.0, -layer.cloud_density * (gaussian ? std::exp(-2.0 * q) : 1.0));
    };
    const double step = rc / 200.0;
    const int n       = static_cast<int>(std::ceil(2.0 * reach / step));
    double sum        = 0.0;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const double x = -reach + (i + 0.5) * step, y = -reach + (j + 0.5) * step;
            sum += f(x, y) * f(x + h, y);
        }
    return sum * step * step;
}

// ImageOverlap (the Boolean statistics of one grain's image, which the
// sensitometry's granularity and the pixel scale use): blocking area and
// overlap against brute-force integrals, the silver limit, and the identity
// integral of k(h) over the plane = b^2.
TEST(Dye, ImageOverlapAgainstIntegrals)
{
    const ImageOverlap silver;
    EXPECT_DOUBLE_EQ(silver.blocking_um2(1.5), M_PI * 2.25);
    EXPECT_DOUBLE_EQ(silver.overlap_um2(1.5, 0.7), lens_area_um2(1.5, 0.7));
    EXPECT_EQ(silver.overlap_range_um(1.5), 3.0);
    EXPECT_EQ(silver.correlation_range_um(1.5), 3.0);
    for (const CloudProfile profile : { CloudProfile::disc, CloudProfile::gaussian })
        for (const double density : { 0.3, 1.0, 5.0 }) {
            Layer layer;
            layer.image                = LayerImage::dye;
            layer.cloud_profile        = profile;
            layer.cloud_diameter_ratio = 1.6;
            layer.cloud_density        = density;
            const ImageOverlap image(layer);
            const std::string what = std::string(name_of(profile)) + " density "
                                     + std::to_string(density);
            EXPECT_NEAR(image.blocking_um2(1.0), M_PI * blocking_numeric(layer),
                        1e-6 * image.blocking_um2(1.0)) << what;
            // Radius 1 here; radius 0.5 is the same shape at a quarter the area.
            const double k0 = image.overlap_um2(1.0, 0.0);
            EXPECT_LT(k0, image.blocking_um2(1.0)) << what;
            for (const double h : { 0.0, 0.4, 1.1, 2.0, 3.9 }) {
                // Tolerance: the grid sums' error (far below) plus the
                // table's linear interpolation in h, (step^2 / 8) max |k''|
                // with step = rc / 32 and |k''| < 4 k0 / rc^2: 5e-4 k0.
                EXPECT_NEAR(image.overlap_um2(1.0, h), overlap_numeric(layer, h), 5e-4 * k0)
                    << what << " h " << h;
                EXPECT_NEAR(image.overlap_um2(0.5, 0.5 * h), 0.25 * image.overlap_um2(1.0, h),
                            1e-12 * k0) << what;
            }
            EXPECT_EQ(image.overlap_um2(1.0, image.overlap_range_um(1.0)), 0.0) << what;
            // Where the neighbour correlations end (the pixel scale's rule):
            // k below 1e-3 k(0) from there on, above it a table step (rc /
            // 32) before; for disc clouds the overlap range itself.
            const double cr = image.correlation_range_um(1.0);
            if (profile == CloudProfile::disc) {
                EXPECT_EQ(cr, image.overlap_range_um(1.0)) << what;
            } else {
                for (double h = cr; h < image.overlap_range_um(1.0); h += 0.01)
                    EXPECT_LE(image.overlap_um2(1.0, h), 1e-3 * k0) << what << " h " << h;
                EXPECT_GT(image.overlap_um2(1.0, cr - 1.01 * 1.6 / 32), 1e-3 * k0) << what;
                EXPECT_LT(cr, 0.6 * image.overlap_range_um(1.0)) << what;
            }
            // integral over the plane of k(h) d^2h = b^2.
            const double range = image.overlap_range_um(1.0);
            const int n        = 20000;
            double integral    = 0.0;
            for (int i = 0; i < n; ++i) {
                const double h = (i + 0.5) * range / n;
                integral += image.overlap_um2(1.0, h) * 2.0 * M_PI * h * range / n;
            }
            const double b = image.blocking_um2(1.0);
            EXPECT_NEAR(integral, b * b, 2e-3 * b * b) << what;
        }
}

TEST(Dye, StockKeys)
{
    Stock s;
    ASSERT_TRUE(parse_stock_json(R"({"layers": [{"name": "Y", "image": "dye",
        "cloud_profile": "gaussian", "cloud_diameter_ratio": 1.5, "cloud_density": 0.7}]})",
                                 "t", s));
    EXPECT_EQ(s.layers[0].image, LayerImage::dye);
    EXPECT_EQ(s.layers[0].cloud_profile, CloudProfile::gaussian);
    EXPECT_EQ(s.layers[0].cloud_diameter_ratio, 1.5);
    EXPECT_EQ(s.layers[0].cloud_density, 0.7);
    Stock back;
    ASSERT_TRUE(parse_stock_json(stock_to_json(s), "round trip", back));
    EXPECT_EQ(stock_to_json(back), stock_to_json(s));
    const auto error = [](const std::string& text) {
        Stock out;
        const Status st = parse_stock_json(text, "t", out);
        EXPECT_FALSE(st) << text;
        return st.message();
    };
    EXPECT_NE(error(R"({"layers": [{"image": "colour"}]})")
                  .find("layers[0].image = 'colour': must be one of 'silver', 'dye'"),
              std::string::npos);
    EXPECT_NE(error(R"({"layers": [{"cloud_profile": "box"}]})").find("'disc', 'gaussian'"),
              std::string::npos);
    EXPECT_NE(error(R"({"layers": [{"cloud_density": 0}]})").find("cloud_density = 0"),
              std::string::npos);
    EXPECT_NE(error(R"({"layers": [{"cloud_diameter_ratio": 11}]})").find("cloud_diameter_ratio = 11: must be in"),
              std::string::npos);
    // The coupler limit (a population's key): dye layers with disc clouds
    // only, at most one cloud's density.
    ASSERT_TRUE(parse_stock_json(R"({"layers": [{"image": "dye", "cloud_density": 0.7,
        "populations": [{"max_dye_density": 0.5}, {}]}]})", "t", s));
    EXPECT_EQ(s.layers[0].populations[0].max_dye_density, 0.5);
    EXPECT_TRUE(s.layers[0].populations[0].coupler_limited());
    EXPECT_FALSE(s.layers[0].populations[1].coupler_limited());
    ASSERT_TRUE(parse_stock_json(stock_to_json(s), "round trip", back));
    EXPECT_EQ(stock_to_json(back), stock_to_json(s));
    EXPECT_NE(error(R"({"layers": [{"populations": [{"max_dye_density": 0.5}]}]})")
                  .find("layers[0].populations[0].max_dye_density = 0.5 needs a dye layer with "
                        "disc clouds"),
              std::string::npos);
    EXPECT_NE(error(R"({"layers": [{"image": "dye", "cloud_profile": "gaussian",
                  "populations": [{"max_dye_density": 0.5}]}]})")
                  .find("needs a dye layer with disc clouds"),
              std::string::npos);
    EXPECT_NE(error(R"({"layers": [{"image": "dye", "cloud_density": 0.4,
                  "populations": [{"max_dye_density": 0.5}]}]})")
                  .find("max_dye_density = 0.5 is above the layer's cloud_density (0.4"),
              std::string::npos);
    EXPECT_NE(error(R"({"layers": [{"image": "dye", "populations": [{"max_dye_density": -1}]}]})")
                  .find("max_dye_density = -1: must be in [0, 20]"),
              std::string::npos);
}

// A coupler-limited population's clouds fill (FilledImage): where two of
// its clouds overlap the density is max_dye_density, not twice a cloud's;
// a population without the limit adds (MODEL.md 8), and the two
// populations' densities add. Three concentric disc clouds of radius 3 um
// in a 20 um pixel: f is the fraction of the pixel the 256 rows' chords
// cover (the rows are sampled, the levels along them exact: to rounding).
TEST(Dye, CouplerLimitedCloudsFill)
{
    Layer l;
    l.image                = LayerImage::dye;
    l.cloud_profile        = CloudProfile::disc;
    l.cloud_density        = 0.6;
    l.populations          = { Population(), Population() };
    l.populations[0].max_dye_density = 0.4;
    const std::vector<Disc> grains = { { 10.0, 10.0, 3.0 }, { 10.0, 10.0, 3.0 },
                                       { 10.0, 10.0, 3.0 } };
    double f = 0.0;
    for (int j = 0; j < 256; ++j) {
        const double dy = (j + 0.5) * 20.0 / 256.0 - 10.0;
        f += dy * dy < 9.0 ? 2.0 * std::sqrt(9.0 - dy * dy) / 20.0 / 256.0 : 0.0;
    }
    EXPECT_NEAR(f, 9.0 * M_PI / 400.0, 1e-4);
    DyeScratch scratch;
    const auto render = [&](std::vector<size_t> population_end) {
        double t = 0.0;
        dye_transmittance(grains, population_end, l, 4.0, 0, 0, 1, 1, 20.0, 20.0, 256, scratch,
                          &t);
        return t;
    };
    // Two clouds of the limited population and one of the other: 0.4 + 0.6.
    EXPECT_NEAR(render({ 2, 3 }), 1.0 - f + f * std::pow(10.0, -1.0), 1e-12);
    // All three limited: 0.4.
    EXPECT_NEAR(render({ 3, 3 }), 1.0 - f + f * std::pow(10.0, -0.4), 1e-12);
    // Without the limit all three add: 1.8.
    l.populations[0].max_dye_density = 0.0;
    EXPECT_NEAR(render({ 2, 3 }), 1.0 - f + f * std::pow(10.0, -1.8), 1e-12);
}

TEST(Dye, CloudAreaFactorIsTheBlockingIntegral)
{
    Layer silver;
    EXPECT_EQ(cloud_area_factor(silver), 1.0);
    EXPECT_EQ(image_reach_factor(silver), 1.0);
    for (CloudProfile profile : { CloudProfile::disc, CloudProfile::gaussian })
        for (double ratio : { 0.5, 1.0, 2.5 })
            for (double density : { 1e-7, 0.05, 0.7, 3.0, 20.0 }) {
                Layer l;
                make_dye(l, profile, ratio, density);
                const double expected = blocking_numeric(l);
                EXPECT_NEAR(cloud_area_factor(l), expected, 1e-6 * expected + 1e-12)
                    << name_of(profile) << " ratio " << ratio << " density " << density;
            }
}

TEST(Dye, OneCloudInAPixel)
{
    // One gaussian cloud in the middle of a 20 um pixel: the sampled mean of
    // 10^-D against the blocking integral (the cloud lies well inside).
    Layer l;
    make_dye(l, CloudProfile::gaussian, 1.5, 0.8);
    const std::vector<Disc> grains = { { 10.0, 10.0, 1.0 } };
    DyeScratch scratch;
    double t_coarse = 0.0, t_fine = 0.0;
    dye_transmittance(grains, { grains.size() }, l, 4.0, 0, 0, 1, 1, 20.0, 20.0, 64, scratch, &t_coarse);
    dye_transmittance(grains, { grains.size() }, l, 4.0, 0, 0, 1, 1, 20.0, 20.0, 256, scratch, &t_fine);
    const double expected = 1.0 - cloud_area_factor(l) * M_PI / 400.0;
    // The midpoint rule on a smooth cloud: error ~ (spacing / radius)^2.
    EXPECT_NEAR(t_fine, expected, 1e-5);
    EXPECT_NEAR(t_coarse, expected, 1e-4);
}

/// The paper preset as a dye layer, on a 1.2 mm square of 12.5 um input
/// pixels at `value` (scene-linear).
TestScene dye_scene(CloudProfile profile, double ratio, double density, float value)
{
    TestScene s;
    EXPECT_TRUE(load_stock("paper", s.stock));
    make_dye(s.stock.layers[0], profile, ratio, density);
    s.scene.width_mm = 1.2;
    s.pixels.assign(96 * 96, value);
    s.view = ImageView { s.pixels.data(), 96, 96, 1 };
    return s;
}

/// Mean transmittance of a render and its standard error (pixels in 4x4
/// blocks as the unit: clouds span neighbouring pixels).
std::pair<double, double> mean_transmittance(const std::vector<float>& d, int64_t n)
{
    std::vector<double> blocks;
    for (int64_t by = 0; by < n; by += 4)
        for (int64_t bx = 0; bx < n; bx += 4) {
            double t = 0.0;
            for (int64_t y = by; y < by + 4; ++y)
                for (int64_t x = bx; x < bx + 4; ++x)
                    t += std::pow(10.0, -d[static_cast<size_t>(y * n + x)]);
            blocks.push_back(t / 16.0);
        }
    return mean_and_standard_error(blocks);
}

TEST(Dye, UniformPatchesHaveTheExpectedTransmittance)
{
    // MODEL.md 8: E[T] = exp(-sum n E[P a] * cloud_area_factor), i.e. the
    // expected curve of the dye layer; within 4 standard errors plus the
    // curve's error bound (as a transmittance). Exact engine and auto, both
    // profiles, clouds smaller and larger than the grain. The frame's edge
    // (grains outside the frame have no light) stays out of the mean: all
    // grains reaching it are inside (the margins are outside the pixels).
    // Coupler-limited clouds (max_dye_density > 0: dye.h FilledImage,
    // layer_mean_transmittance) too, clouds 1.5 grain radii wide at grey,
    // where they overlap (the additive reading is checked to differ).
    struct Case {
        CloudProfile profile;
        double ratio, density;
        Engine engine;
        double limit = 0.0;
    };
    for (const Case& c : { Case { CloudProfile::disc, 1.0, 0.6, Engine::exact },
                           Case { CloudProfile::gaussian, 1.5, 0.8, Engine::exact },
                           Case { CloudProfile::disc, 0.7, 1.5, Engine::automatic },
                           Case { CloudProfile::gaussian, 2.0, 0.4, Engine::automatic },
                           Case { CloudProfile::disc, 1.5, 0.9, Engine::exact, 0.7 },
                           Case { CloudProfile::disc, 1.5, 0.9, Engine::automatic, 0.7 } }) {
        TestScene s = dye_scene(c.profile, c.ratio, c.density, 0.18f);
        s.stock.layers[0].populations[0].max_dye_density = c.limit;
        RenderSettings settings;
        settings.engine = c.engine;
        const auto [mean, se] = mean_transmittance(render_scene(s, settings), 96);
        std::vector<ExpectedCurve> curves;
        ASSERT_TRUE(expected_curves(s.stock, s.scene, ExpectedCurveOptions {}, curves));
        const double t = curves[0].transmittance_at(0.18);
        const double t_error = t * std::log(10.0) * curves[0].density_error;
        EXPECT_LT(std::fabs(mean - t), 4.0 * se + t_error)
            << name_of(c.profile) << " ratio " << c.ratio << " " << name_of(c.engine)
            << " limit " << c.limit << ": measured " << mean << " +- " << se << ", expected " << t;
        if (c.limit > 0.0) {  // not what the same clouds give adding
            TestScene added = s;
            added.stock.layers[0].populations[0].max_dye_density = 0.0;
            std::vector<ExpectedCurve> a;
            ASSERT_TRUE(expected_curves(added.stock, added.scene, ExpectedCurveOptions {}, a));
            EXPECT_GT(std::fabs(mean - a[0].transmittance_at(0.18)), 4.0 * se + t_error);
        }
    }
}

// An inhibited layer with a coupler-limited population (MODEL.md 10 and
// docs/model.md): inhibition thins every P by exp(-log_factor), which
// scales each population's cover; the expected curve recomputes E[T] from
// the thinned covers (a coupler-limited layer's E[T] is not a power of its
// uninhibited one, as an additive layer's is). A rendered uniform patch
// against it, tolerance as above; and the power the additive reading
// would give is outside that tolerance (so the test can tell them apart).
TEST(Dye, InhibitedCouplerLimitedPatchesHaveTheExpectedTransmittance)
{
    TestScene s = dye_scene(CloudProfile::disc, 1.5, 0.9, 0.18f);
    s.stock.layers[0].populations[0].max_dye_density = 0.9;
    s.stock.inhibition             = { { 1.5 } };
    s.stock.inhibitor_diffusion_um = 20.0;
    std::vector<ExpectedCurve> plain, curves;
    Stock uninhibited = s.stock;
    uninhibited.inhibition.clear();
    ASSERT_TRUE(expected_curves(uninhibited, s.scene, ExpectedCurveOptions {}, plain));
    ASSERT_TRUE(expected_curves(s.stock, s.scene, ExpectedCurveOptions {}, curves));
    const double t       = curves[0].transmittance_at(0.18);
    const double t_error = t * std::log(10.0) * curves[0].density_error;
    const double factor
        = std::exp(-1.5 * (plain[0].density_at(0.18) - plain[0].base_density));
    const double power = std::pow(plain[0].transmittance_at(0.18), factor);
    for (Engine engine : { Engine::exact, Engine::automatic }) {
        RenderSettings settings;
        settings.engine       = engine;
        const auto [mean, se] = mean_transmittance(render_scene(s, settings), 96);
        EXPECT_LT(std::fabs(mean - t), 4.0 * se + t_error)
            << name_of(engine) << ": measured " << mean << " +- " << se << ", expected " << t;
        EXPECT_GT(std::fabs(power - t), 4.0 * se + t_error)
            << name_of(engine) << ": the additive reading " << power << " is as close";
    }
}

TEST(Dye, TheSilverLimitIsSilver)
{
    // Disc clouds of the grain's size and a density far above max_density
    // cover as opaque discs do: the same grains (same seed and layer) give
    // per pixel the silver transmittance, to the dye's sampling across rows
    // (the exact engine's 34 rows in a 12.5 um pixel for 6 um grains) and
    // the 10^-4 a covered point keeps.
    TestScene dye    = dye_scene(CloudProfile::disc, 1.0, 20.0, 0.18f);
    TestScene silver = dye;
    silver.stock.layers[0].image = LayerImage::silver;
    RenderSettings exact;
    exact.engine = Engine::exact;
    const auto a = render_scene(dye, exact), b = render_scene(silver, exact);
    double rms = 0.0;
    std::vector<double> blocks;
    for (int64_t by = 0; by < 96; by += 4)
        for (int64_t bx = 0; bx < 96; bx += 4) {
            double block = 0.0;
            for (int64_t y = by; y < by + 4; ++y)
                for (int64_t x = bx; x < bx + 4; ++x) {
                    const size_t i  = static_cast<size_t>(y * 96 + x);
                    const double tb = std::pow(10.0, -b[i]);
                    // The uncovered fraction (silver clamps T at 10^-4: a
                    // pixel at the clamp is taken as fully covered) and
                    // what the dye makes of it: covered points keep 10^-4.
                    const double open = tb > 1.0001e-4 ? tb : 0.0;
                    const double d    = std::pow(10.0, -a[i]) - (open + 1e-4 * (1.0 - open));
                    block += d / 16.0;
                    rms += d * d;
                }
            blocks.push_back(block);
        }
    const double n = 96.0 * 96.0;
    rms            = std::sqrt(rms / n);
    EXPECT_LT(rms, 0.05);
    // The sampling is unbiased (grain centres are uniform relative to the
    // rows): the mean difference is 0 within 4 standard errors (4x4 blocks
    // as the unit).
    const auto [mean, se] = mean_and_standard_error(blocks);
    EXPECT_LT(std::fabs(mean), 4.0 * se) << mean << " +- " << se;
}

TEST(Dye, BitIdenticalForThreadsTilesAndRois)
{
    // Gaussian clouds 2.5 grain radii wide (reaching 7.5 radii): grains of
    // neighbouring tiles and outside a ROI paint into it.
    TestScene s = dye_scene(CloudProfile::gaussian, 2.5, 0.5, 0.18f);
    for (size_t i = 0; i < s.pixels.size(); ++i)
        s.pixels[i] = static_cast<float>(0.18 * std::exp2((static_cast<double>(i % 96) - 48) / 12));
    for (Engine engine : { Engine::exact, Engine::automatic })
        expect_deterministic(s, engine, Roi { 30, 40, 47, 61 });
    // Coupler-limited disc clouds (docs/model.md) 2.5 grain radii wide, a
    // limited population beside one whose clouds add.
    TestScene limited = dye_scene(CloudProfile::disc, 2.5, 0.5, 0.18f);
    limited.pixels    = s.pixels;
    Layer& layer      = limited.stock.layers[0];
    layer.populations.push_back(layer.populations[0]);
    layer.populations[1].diameter_um *= 0.5;
    layer.populations[0].max_dye_density = 0.3;
    for (Engine engine : { Engine::exact, Engine::automatic })
        expect_deterministic(limited, engine, Roi { 30, 40, 47, 61 });
}

TEST(Dye, SamplingConverges)
{
    // The same grains (auto: the fast kernel) imaged at auto's samples and
    // at 64 x 64 per pixel: the per-pixel density difference shrinks as the
    // samples grow, and auto's is reported in its stats' path.
    const TestScene s = dye_scene(CloudProfile::disc, 1.0, 0.8, 0.18f);
    RenderSettings fine;
    fine.samples = 64;
    const auto ref        = render_scene(s, fine);
    double previous       = 1e300;
    for (int samples : { 2, 4, 8, 16 }) {
        RenderSettings settings;
        settings.samples = samples;
        const auto d              = render_scene(s, settings);
        double rms                = 0.0;
        for (size_t i = 0; i < d.size(); ++i)
            rms += (d[i] - ref[i]) * (d[i] - ref[i]);
        rms = std::sqrt(rms / d.size());
        RecordProperty("rms_density_difference_at_" + std::to_string(samples),
                       std::to_string(rms));
        EXPECT_LT(rms, previous) << samples;
        previous = rms;
    }
    RenderStats stats;
    render_scene(s, RenderSettings {}, &stats);
    EXPECT_NE(stats.layers[0].path.find("image=dye:"), std::string::npos) << stats.layers[0].path;
}

// scale=pixel draws a dye layer from its clouds' pixel statistics
// (PixelModel with ImageOverlap; checked against grain-by-grain dye images
// in PixelModel.DyeMomentsMatchTheCloudsGrainByGrain): the path says so.
TEST(Dye, PixelScaleDrawsDyeFromItsStatistics)
{
    const TestScene s = dye_scene(CloudProfile::disc, 1.0, 0.8, 0.18f);
    RenderSettings settings;
    settings.scale = ScaleMethod::pixel;
    std::vector<float> out(96 * 96);
    RenderStats stats;
    const Status st = render_negative(s.stock, s.scene, s.view, settings, out.data(), &stats);
    ASSERT_TRUE(st) << st.message();
    EXPECT_NE(stats.layers[0].path.find("image=dye scale=pixel"), std::string::npos)
        << stats.layers[0].path;
}

}  // namespace
}  // namespace filmgrain
