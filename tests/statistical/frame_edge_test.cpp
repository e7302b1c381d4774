// The frame's edge (MODEL.md 2): the scene continues beyond the input
// (clamp-to-edge), so a uniform plate gives a uniform negative up to its
// outermost pixels, in the grains' disc integrals (paper's 6 um grains on
// 6 um pixels straddle the edge), the light spread (vision3-500t's halation
// from its base, a glow reaching 2.5 mm, and 5 um scatter) and the
// inhibitors (its 20 um diffusion). With
// edge=gate (no light beyond the frame) the rim differs: these tests also
// check that they see it then, so that they can fail.
//
// Tolerance: the outermost pixels' mean and the interior's are compared in
// units of the standard error of their difference, each side's from the
// spread of independent units (blocks of pixels far larger than the grains
// and the pixel-to-pixel correlation: 4 rim pixels along the edge, 8x8
// interior blocks), |z| <= 4 for clamp.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "filmgrain/render.h"

namespace filmgrain {
namespace {

struct Side {
    double mean = 0.0, se = 0.0;
};

Side mean_and_se(const std::vector<double>& units)
{
    Side s;
    for (double u : units)
        s.mean += u;
    s.mean /= static_cast<double>(units.size());
    double var = 0.0;
    for (double u : units)
        var += (u - s.mean) * (u - s.mean);
    var /= static_cast<double>(units.size() - 1);
    s.se = std::sqrt(var / static_cast<double>(units.size()));
    return s;
}

/// A uniform grey plate of w x h pixels of `pitch_um`, rendered; per layer,
/// the z of (rim - interior) of the mean transmittance (rim: the outermost
/// ring of pixels in blocks of 4; interior: 8x8 blocks inset 16 pixels).
std::vector<double> rim_z(const Stock& stock, Engine engine, FrameEdge edge, double stops,
                          uint64_t seed, int64_t w, int64_t h, double pitch_um,
                          std::vector<double>* rim_density = nullptr,
                          std::vector<double>* interior_density = nullptr)
{
    SceneSettings scene;
    scene.exposure_stops = stops;
    scene.width_mm = static_cast<double>(w) * pitch_um / 1000.0;
    scene.seed           = seed;
    scene.edge           = edge;
    std::vector<float> input(static_cast<size_t>(w * h), 0.18f);
    const ImageView view { input.data(), w, h, 1 };
    RenderSettings settings;
    settings.engine = engine;
    const size_t nl = stock.layers.size();
    std::vector<float> d(static_cast<size_t>(w * h) * nl);
    const Status st = render_negative(stock, scene, view, settings, d.data(), nullptr);
    EXPECT_TRUE(st) << st.message();
    std::vector<double> out;
    for (size_t l = 0; l < nl; ++l) {
        const auto t = [&](int64_t x, int64_t y) {
            return std::pow(10.0, -(d[static_cast<size_t>(y * w + x) * nl + l]
                                    - stock.layer_base_density(l)));
        };
        std::vector<double> ring;  // clockwise, corners once
        for (int64_t x = 0; x < w; ++x)
            ring.push_back(t(x, 0));
        for (int64_t y = 1; y < h; ++y)
            ring.push_back(t(w - 1, y));
        for (int64_t x = w - 2; x >= 0; --x)
            ring.push_back(t(x, h - 1));
        for (int64_t y = h - 2; y >= 1; --y)
            ring.push_back(t(0, y));
        std::vector<double> rim_units, inner_units;
        for (size_t i = 0; i + 4 <= ring.size(); i += 4)
            rim_units.push_back((ring[i] + ring[i + 1] + ring[i + 2] + ring[i + 3]) / 4.0);
        for (int64_t by = 16; by + 8 <= h - 16; by += 8)
            for (int64_t bx = 16; bx + 8 <= w - 16; bx += 8) {
                double sum = 0.0;
                for (int64_t y = by; y < by + 8; ++y)
                    for (int64_t x = bx; x < bx + 8; ++x)
                        sum += t(x, y);
                inner_units.push_back(sum / 64.0);
            }
        const Side rim = mean_and_se(rim_units), inner = mean_and_se(inner_units);
        out.push_back((rim.mean - inner.mean) / std::hypot(rim.se, inner.se));
        if (rim_density)
            rim_density->push_back(-std::log10(rim.mean) + stock.layer_base_density(l));
        if (interior_density)
            interior_density->push_back(-std::log10(inner.mean) + stock.layer_base_density(l));
    }
    return out;
}

TEST(FrameEdge, PaperHasNoRimWhenTheSceneContinues)
{
    // paper: 6 um grains (log sigma 0.5) on 6 um pixels, 320x240 pixels;
    // every engine, 2 stops under and at grey, two seeds. Under gate the
    // rim's grains straddling the edge catch less light: the rim is lighter
    // (mean T 0.34 against 0.24 at -2 stops, 0.076 against 0.057 at grey,
    // measured over 8 seeds of 96x64 frames).
    Stock stock;
    ASSERT_TRUE(load_stock("paper", stock));
    for (Engine engine : { Engine::exact, Engine::automatic, Engine::fast })
        for (double stops : { -2.0, 0.0 })
            for (uint64_t seed : { 1u, 2u }) {
                const std::vector<double> z
                    = rim_z(stock, engine, FrameEdge::clamp, stops, seed, 320, 240, 6.0);
                EXPECT_LE(std::fabs(z[0]), 4.0)
                    << name_of(engine) << " " << stops << " stops, seed " << seed;
            }
    // Two seeds' z combined (independent: their sum over sqrt(2)); measured
    // 5.0 for one seed.
    const double gate_z = (rim_z(stock, Engine::exact, FrameEdge::gate, -2.0, 1, 320, 240, 6.0)[0]
                           + rim_z(stock, Engine::exact, FrameEdge::gate, -2.0, 2, 320, 240, 6.0)[0])
                          / std::sqrt(2.0);
    EXPECT_GT(gate_z, 4.0) << "gate's lighter rim no longer seen: the test cannot fail";
}

TEST(FrameEdge, Vision3HasNoRimFromLightSpreadOrInhibition)
{
    // vision3-500t on 6 um pixels, 192x128 (1.15 mm: its base kernel's
    // halation, half its light within 250 um, reaches across the whole
    // frame), at the grey step and 4.5 stops over (where
    // the issue measured the red rim 0.010 D light and the green rim
    // 0.05 D dense under gate); auto and fast (the exact engine at this
    // size takes minutes: its disc integrals are the ones the paper test
    // covers), two seeds. The stock as fitted on 2026-12-07 inhibits
    // weakly (R 0.019, G 0, B 0.032 per unit density): the same stock
    // with the earlier fit's self-inhibition (0.013, 0.105, 0.156) runs
    // too, so that the inhibitors' edge is tested where it shows.
    Stock stock;
    ASSERT_TRUE(load_stock("vision3-500t", stock));
    ASSERT_EQ(stock.inhibition.size(), 3u) << "vision3-500t inhibits (MODEL.md 10)";
    Stock inhibited = stock;
    const double earlier[] = { 0.013, 0.105, 0.156 };
    for (size_t l = 0; l < 3; ++l)
        inhibited.inhibition[l][l] = earlier[l];
    for (const Stock* s : { &stock, &inhibited })
        for (Engine engine : { Engine::automatic, Engine::fast })
            for (double stops : { 0.0, 4.5 })
                for (uint64_t seed : { 3u, 4u }) {
                    const std::vector<double> z
                        = rim_z(*s, engine, FrameEdge::clamp, stops, seed, 192, 128, 6.0);
                    for (size_t l = 0; l < z.size(); ++l)
                        EXPECT_LE(std::fabs(z[l]), 4.0)
                            << (s == &stock ? "" : "inhibited, ") << name_of(engine) << " "
                            << stops << " stops, seed " << seed << ", layer "
                            << stock.layers[l].name;
                }
    // Under gate the red rim at grey is lighter (less halation and scatter
    // light: measured z 9.7 on the 2026-12-07 stock; 11 with the 220 um
    // disc, 10.6 with the base kernel on the earlier fit) and, inhibited,
    // the green at +4.5 denser (less inhibition: -24 and -24.4 on the
    // earlier fit, whose green inhibited at 0.105).
    const std::vector<double> grey = rim_z(stock, Engine::automatic, FrameEdge::gate, 0.0, 3, 192, 128, 6.0);
    const std::vector<double> over = rim_z(inhibited, Engine::automatic, FrameEdge::gate, 4.5, 3, 192, 128, 6.0);
    EXPECT_GT(grey[0], 4.0) << "gate's red rim (less halation light) no longer seen";
    EXPECT_LT(over[1], -4.0) << "gate's green rim (less inhibition) no longer seen";
}

TEST(FrameEdge, AUniformPlateHasNoGradientTowardItsEdges)
{
    // vision3-500t at the grey step, 256x160 pixels of 6 um: the mean
    // density of each of the 8 outermost columns on both sides (averaged
    // over rows and the two sides) against the interior's, each within 4
    // standard errors (from 16-row blocks of the column).
    Stock stock;
    ASSERT_TRUE(load_stock("vision3-500t", stock));
    SceneSettings scene;
    const int64_t w = 256, h = 160;
    scene.width_mm = static_cast<double>(w) * 6.0 / 1000.0;
    scene.seed           = 9;
    std::vector<float> input(static_cast<size_t>(w * h), 0.18f);
    const ImageView view { input.data(), w, h, 1 };
    const size_t nl = stock.layers.size();
    std::vector<float> d(static_cast<size_t>(w * h) * nl);
    ASSERT_TRUE(render_negative(stock, scene, view, RenderSettings {}, d.data(), nullptr));
    for (size_t l = 0; l < nl; ++l) {
        const auto column_blocks = [&](int64_t x) {
            std::vector<double> units;
            for (int64_t by = 0; by + 16 <= h; by += 16) {
                double sum = 0.0;
                for (int64_t y = by; y < by + 16; ++y)
                    sum += d[static_cast<size_t>(y * w + x) * nl + l];
                units.push_back(sum / 16.0);
            }
            return units;
        };
        std::vector<double> inner_units;
        for (int64_t x = 64; x < w - 64; x += 8)
            for (double u : column_blocks(x))
                inner_units.push_back(u);
        const Side inner = mean_and_se(inner_units);
        for (int64_t k = 0; k < 8; ++k) {
            std::vector<double> units = column_blocks(k);
            for (double u : column_blocks(w - 1 - k))
                units.push_back(u);
            const Side col = mean_and_se(units);
            EXPECT_LE(std::fabs(col.mean - inner.mean), 4.0 * std::hypot(col.se, inner.se))
                << stock.layers[l].name << " column " << k << " from the edge: " << col.mean
                << " against " << inner.mean;
        }
    }
}

}  // namespace
}  // namespace filmgrain
