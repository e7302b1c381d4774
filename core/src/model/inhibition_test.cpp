// Tests of MODEL.md 10 (development inhibitors): the stock keys, the
// adjacency effect at a step edge and its width, zero inhibition = none,
// determinism, and the expected curve of a uniform patch under inhibition.
#include "model/inhibition.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "filmgrain/expected_curve.h"
#include "filmgrain/render.h"
#include "testing/test_render.h"

namespace filmgrain {
namespace {

TEST(Inhibition, StockKeys)
{
    Stock s;
    ASSERT_TRUE(load_stock("paper", s));
    std::string json = stock_to_json(s);
    // Every key present: an all-zero matrix, diffusion 0.
    EXPECT_NE(json.find("\"inhibition\":[[0.0]]"), std::string::npos) << json;
    EXPECT_NE(json.find("\"inhibitor_diffusion_um\":0.0"), std::string::npos) << json;
    Stock back;
    ASSERT_TRUE(parse_stock_json(json, "round trip", back));
    EXPECT_TRUE(back.inhibition.empty());  // all zero is stored empty
    EXPECT_FALSE(back.inhibits());

    s.inhibition             = { { 0.7 } };
    s.inhibitor_diffusion_um = 25.0;
    ASSERT_TRUE(parse_stock_json(stock_to_json(s), "round trip", back));
    EXPECT_TRUE(back.inhibits());
    EXPECT_EQ(back.inhibition, s.inhibition);
    EXPECT_EQ(back.inhibitor_diffusion_um, 25.0);

    const auto error = [](const std::string& text) {
        Stock out;
        const Status st = parse_stock_json(text, "t", out);
        EXPECT_FALSE(st) << text;
        return st.message();
    };
    EXPECT_NE(error(R"({"inhibition": [[0.1, 0.2]]})").find("inhibition[0] has 2 entries"),
              std::string::npos);
    EXPECT_NE(error(R"({"inhibition": [[0.1], [0.2]]})").find("inhibition has 2 rows"),
              std::string::npos);
    EXPECT_NE(error(R"({"inhibition": [[-1]]})").find("inhibition[0][0] = -1"),
              std::string::npos);
    EXPECT_NE(error(R"({"inhibition": [["a"]]})").find("must hold numbers"), std::string::npos);
    EXPECT_NE(error(R"({"inhibition": 3})").find("array of arrays"), std::string::npos);
    EXPECT_NE(error(R"({"inhibitor_diffusion_um": -2})").find("inhibitor_diffusion_um = -2"),
              std::string::npos);
}

constexpr int64_t kWidth = 384, kHeight = 192;
constexpr double kPitchUm = 6.25;

/// The paper preset with grains a third its diameter, nine times as many
/// and nine times the exposure (the same coverage and photons per grain:
/// the same curve, with a third of the noise) on a 2.4 mm wide frame, `rows` high, of
/// 6.25 um input pixels: the left half 1 stop under grey, the right half 3
/// stops over (a step edge at x = 1.2 mm); self-inhibition `strength`,
/// diffusion `sigma_um`.
TestScene edge_scene(double strength, double sigma_um, int64_t rows)
{
    TestScene s;
    EXPECT_TRUE(load_stock("paper", s.stock));
    Population& pop = s.stock.layers[0].populations[0];
    pop.diameter_um /= 3.0;
    pop.grains_per_um2 *= 9.0;
    s.stock.exposure_at_grey_lxs *= 9.0;
    if (strength > 0.0)
        s.stock.inhibition = { { strength } };
    s.stock.inhibitor_diffusion_um = sigma_um;
    s.scene.width_mm               = 2.4;
    const int64_t w = kWidth, h = rows;
    s.pixels.resize(static_cast<size_t>(w * h));
    for (int64_t y = 0; y < h; ++y)
        for (int64_t x = 0; x < w; ++x)
            s.pixels[static_cast<size_t>(y * w + x)] = static_cast<float>(0.18 * (x < w / 2 ? 0.5 : 8.0));
    s.view = ImageView { s.pixels.data(), w, h, 1 };
    return s;
}

/// Mean transmittance (10^-density: linear in the developed grains, unlike
/// the density of a pixel partly covered by 6 um grains) of the columns
/// whose centres lie in [d0, d1) um from the edge (negative: the thin side)
/// and its standard error, from blocks of 4 rows as the unit (grains of
/// 2 um couple only neighbouring 6.25 um rows; blocks of 4 rows are nearly
/// independent).
std::pair<double, double> band(const std::vector<float>& d, double d0_um, double d1_um)
{
    const int64_t w = kWidth, h = kHeight;
    const double p = kPitchUm, edge = 0.5 * kWidth * kPitchUm;
    std::vector<double> blocks;
    for (int64_t by = 0; by < h; by += 4) {
        double s = 0.0;
        int n    = 0;
        for (int64_t y = by; y < by + 4; ++y)
            for (int64_t x = 0; x < w; ++x) {
                const double dist = (x + 0.5) * p - edge;
                if (dist >= d0_um && dist < d1_um) {
                    s += std::pow(10.0, -d[static_cast<size_t>(y * w + x)]);
                    ++n;
                }
            }
        blocks.push_back(s / n);
    }
    return mean_and_standard_error(blocks);
}

double z(std::pair<double, double> a, std::pair<double, double> b)
{
    return (a.first - b.first) / std::hypot(a.second, b.second);
}

TEST(Inhibition, AStepEdgeOvershootsAndUndershoots)
{
    // Dense side: near the edge the blurred density is lower (the thin
    // side's mixes in), so less inhibition and more density (less
    // transmittance) than far from it: overshoot; thin side: the reverse,
    // undershoot. Differences in standard errors of the band means (z).
    const double sigma = 60.0;
    // Grain by grain with the early-stopped chain (what auto chose for this
    // scene when the test was written; it now builds a table and draws the
    // grains from P(develop | mean photons) at their centres' exposure):
    // the z-scores below were measured on it.
    RenderSettings grains;
    grains.scale    = ScaleMethod::grain;
    grains.kinetics = KineticsMethod::early_stop;
    const auto d    = render_scene(edge_scene(1.0, sigma, kHeight), grains);
    const auto dense_near = band(d, 0.0, sigma), dense_far = band(d, 4 * sigma, 6 * sigma);
    const auto thin_near = band(d, -sigma, 0.0), thin_far = band(d, -6 * sigma, -4 * sigma);
    EXPECT_GT(z(dense_far, dense_near), 5.0);
    EXPECT_GT(z(thin_near, thin_far), 5.0);
    // Without inhibition there is neither (the same bands agree).
    const auto plain = render_scene(edge_scene(0.0, sigma, kHeight), grains);
    EXPECT_LT(std::fabs(z(band(plain, 0.0, sigma), band(plain, 4 * sigma, 6 * sigma))), 3.5);
    EXPECT_LT(std::fabs(z(band(plain, -sigma, 0.0), band(plain, -6 * sigma, -4 * sigma))), 3.5);
}

TEST(Inhibition, TheEdgeEffectsWidthIsTheDiffusions)
{
    // The log development factor across the step edge (deterministic:
    // plan_inhibition itself), normalised to 1 far on the thin side and 0
    // far on the dense side, is the blurred step: Phi(-d / sigma) at d um
    // from the edge, for every sigma. Tolerance 0.02: the exact pixel means
    // of the blur differ from the centre value by ~(p / sigma)^2 / 24 of
    // the curvature.
    for (double sigma : { 20.0, 60.0 }) {
        const TestScene s = edge_scene(1.0, sigma, 8);
        const LayerExposure exposure(s.view, s.stock.layers[0].sensitivity, kPitchUm, 1e30,
                                     FrameEdge::gate);
        InhibitionPlan plan;
        ASSERT_TRUE(plan_inhibition(s.stock, s.scene, { &exposure }, kWidth, 8, kPitchUm, 0, plan));
        ASSERT_TRUE(plan.log_factor[0]);
        const FramePlane& f = *plan.log_factor[0];
        const double edge   = 0.5 * kWidth * kPitchUm;
        // Far values: 6 sigma from the edge, 100 um and more from the frame's.
        const double thin = f.at(edge - 6 * sigma, 20.0), dense = f.at(edge + 6 * sigma, 20.0);
        ASSERT_GT(dense, thin);
        for (double dist : { -2.0, -1.0, -0.5, 0.5, 1.0, 2.0 }) {
            // The pixel whose centre is nearest dist sigma from the edge.
            const double x = edge + std::round(dist * sigma / kPitchUm - 0.5) * kPitchUm
                             + 0.5 * kPitchUm;
            const double normalised = (f.at(x, 20.0) - thin) / (dense - thin);
            const double expected   = 0.5 * std::erfc(-(x - edge) / sigma / M_SQRT2);
            EXPECT_NEAR(normalised, expected, 0.02) << "sigma " << sigma << " at " << dist;
        }
    }
}

TEST(Inhibition, ZeroInhibitionIsNone)
{
    // An all-zero matrix (with a diffusion) is bit-identical to no keys.
    TestScene plain   = edge_scene(0.0, 0.0, 16);
    TestScene zero    = plain;
    zero.stock.inhibition             = { { 0.0 } };
    zero.stock.inhibitor_diffusion_um = 40.0;
    for (Engine engine : { Engine::exact, Engine::automatic, Engine::fast }) {
        RenderSettings settings;
        settings.engine = engine;
        EXPECT_TRUE(bit_identical(render_scene(plain, settings), render_scene(zero, settings)))
            << name_of(engine);
    }
}

TEST(Inhibition, BitIdenticalForThreadsTilesAndRois)
{
    // A ROI on the dense side next to the edge: the blur reaches the thin
    // side outside it.
    const TestScene s = edge_scene(1.0, 40.0, 32);
    for (Engine engine : { Engine::exact, Engine::automatic })
        expect_deterministic(s, engine, Roi { 194, 10, 207, 30 });
}

class InhibitedPatch : public ::testing::TestWithParam<ScaleMethod> {};

TEST_P(InhibitedPatch, HasTheInhibitedExpectedCurve)
{
    // Far from the frame's edges (where the blurred density falls off) a
    // uniform patch's mean transmittance is the expected curve with
    // inhibition (apply_inhibition), within 4 standard errors of the mean
    // (pixels in blocks of 4x4 as the unit; 100 um from the frame's edges,
    // 5 diffusion widths) plus the curve's error bound;
    // and clearly below the curve without.
    // Grain by grain, and at pixel scale (its statistics thinned by the
    // log factor at each pixel: the mean is exact there too).
    TestScene s = edge_scene(1.0, 20.0, kHeight);
    for (float& v : s.pixels)
        v = 0.18f;
    RenderSettings settings;
    settings.scale = GetParam();
    RenderStats stats;
    const auto d = render_scene(s, settings, &stats);
    EXPECT_NE(stats.layers[0].path.find(GetParam() == ScaleMethod::pixel ? "scale=pixel"
                                                                         : "kinetics="),
              std::string::npos)
        << stats.layers[0].path;
    std::vector<double> blocks;
    for (int64_t by = 16; by < kHeight - 16; by += 4)
        for (int64_t bx = 16; bx < kWidth - 16; bx += 4) {
            double t = 0.0;
            for (int64_t y = by; y < by + 4; ++y)
                for (int64_t x = bx; x < bx + 4; ++x)
                    t += std::pow(10.0, -d[static_cast<size_t>(y * kWidth + x)]);
            blocks.push_back(t / 16);
        }
    const auto [mean, se] = mean_and_standard_error(blocks);

    std::vector<ExpectedCurve> with, without;
    ASSERT_TRUE(expected_curves(s.stock, s.scene, ExpectedCurveOptions {}, with));
    Stock plain      = s.stock;
    plain.inhibition = {};
    ASSERT_TRUE(expected_curves(plain, s.scene, ExpectedCurveOptions {}, without));
    const double t_with = with[0].transmittance_at(0.18);
    // The curve's density error as a transmittance error.
    const double t_error = t_with * std::log(10.0) * with[0].density_error;
    EXPECT_LT(std::fabs(mean - t_with), 4.0 * se + t_error)
        << "measured " << mean << " expected " << t_with << " se " << se;
    EXPECT_GT(mean - without[0].transmittance_at(0.18), 10.0 * se);
}

INSTANTIATE_TEST_SUITE_P(Scales, InhibitedPatch,
                         ::testing::Values(ScaleMethod::grain, ScaleMethod::pixel),
                         [](const auto& info) { return std::string(name_of(info.param)); });

TEST(Inhibition, PixelScaleIsBitIdenticalForThreadsTilesAndRois)
{
    const TestScene s = edge_scene(1.0, 40.0, 32);
    expect_deterministic(s, Engine::automatic, Roi { 194, 10, 207, 30 }, ScaleMethod::pixel);
}

}  // namespace
}  // namespace filmgrain
