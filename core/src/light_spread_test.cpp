// Tests of MODEL.md 9 (scatter and halation): the kernels' pixel weights,
// the spread exposure, and renders with spread (determinism, ROI, the halo's
// radius in micrometres whatever the scan, zero strength = no spread).
#include "light_spread.h"

#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "filmgrain/render.h"
#include "test_render.h"

namespace filmgrain {
namespace {

double sum(const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0); }

/// The Gaussian's weight for input pixels m apart by brute force: the mean
/// over the output pixel of the Gaussian's integral over the input pixel,
/// i.e. the Gaussian against the tent (p - |u|) / p, by the midpoint rule
/// with 20000 steps on its support [-p, p].
double gaussian_weight_numeric(int64_t m, double sigma, double p)
{
    const int n = 20000;
    double s    = 0.0;
    for (int i = 0; i < n; ++i) {
        const double u = -p + (i + 0.5) * 2.0 * p / n;
        const double x = m * p + u;
        s += std::exp(-0.5 * x * x / (sigma * sigma)) / (sigma * std::sqrt(2.0 * M_PI))
             * (p - std::fabs(u)) / p * 2.0 * p / n;
    }
    return s;
}

TEST(LightSpread, GaussianWeightsAreTheTentAveragedGaussian)
{
    for (double sigma : { 0.5, 3.0, 12.0, 40.0 }) {
        const double p      = 6.25;
        const PixelKernel k = gaussian_pixel_kernel(sigma, p);
        EXPECT_NEAR(sum(k.weights), 1.0, 1e-12);
        EXPECT_GE(k.reach * p, 6.0 * sigma);
        for (int64_t m = 0; m <= std::min<int64_t>(k.reach, 6); ++m) {
            EXPECT_EQ(k.weights[k.reach + m], k.weights[k.reach - m]);
            // The midpoint rule's error is ~1e-9 here; the truncation's
            // renormalisation ~2e-9 relative.
            EXPECT_NEAR(k.weights[k.reach + m], gaussian_weight_numeric(m, sigma, p), 1e-8)
                << "sigma " << sigma << " m " << m;
        }
    }
}

TEST(LightSpread, HalationWeightsFillTheShape)
{
    const double p = 5.0, r = 100.0;
    for (HalationKernel shape : { HalationKernel::disc, HalationKernel::ring }) {
        const PixelKernel k = halation_pixel_kernel(shape, r, p);
        const int64_t n     = 2 * k.reach + 1;
        EXPECT_NEAR(sum(k.weights), 1.0, 1e-12);
        const double inner = shape == HalationKernel::ring ? kRingInnerFraction * r : 0.0;
        const double inside = p * p / (M_PI * (r * r - inner * inner));
        for (int64_t j = -k.reach; j <= k.reach; ++j)
            for (int64_t i = -k.reach; i <= k.reach; ++i) {
                const double w = k.weights[(j + k.reach) * n + (i + k.reach)];
                const double d = std::hypot(i * p, j * p);
                // Symmetric in both axes.
                EXPECT_EQ(w, k.weights[(-j + k.reach) * n + (i + k.reach)]);
                EXPECT_EQ(w, k.weights[(j + k.reach) * n + (-i + k.reach)]);
                // Nothing beyond the radius plus the tent's reach (a pixel
                // diagonal), nothing inside the ring's hole.
                if (d > r + 1.5 * p || d < inner - 1.5 * p) {
                    EXPECT_EQ(w, 0.0) << i << "," << j;
                }
                // Uniform where the tent lies wholly inside.
                if (d < r - 1.5 * p && d > inner + 1.5 * p) {
                    EXPECT_NEAR(w, inside, 1e-12 * inside) << i << "," << j;
                }
            }
        // Edge cells against a brute-force mean over the output pixel
        // (64x64 midpoints) of the shape's exact area over the input pixel.
        for (int64_t i = 0; i <= k.reach; ++i) {
            const int64_t j = static_cast<int64_t>(std::floor(std::sqrt(std::max(0.0,
                                  (r / p) * (r / p) - double(i * i)))));
            double ref = 0.0;
            for (int a = 0; a < 64; ++a)
                for (int b = 0; b < 64; ++b) {
                    const double x = (a + 0.5) * p / 64, y = (b + 0.5) * p / 64;
                    ref += disc_rect_area_um2(x, y, r, i * p, j * p, i * p + p, j * p + p)
                           - (inner > 0.0 ? disc_rect_area_um2(x, y, inner, i * p, j * p,
                                                               i * p + p, j * p + p)
                                          : 0.0);
                }
            ref /= 64.0 * 64.0 * M_PI * (r * r - inner * inner);
            // The midpoint rule's own error at a kink ~ (1/64)^2 of a cell.
            EXPECT_NEAR(k.weights[(j + k.reach) * n + (i + k.reach)], ref, 1e-3 * inside)
                << i << "," << j;
        }
    }
}

/// A frame of `w` x `h` one-channel pixels, all `ground` but a block of
/// `value` at (bx, by) of size `b`.
std::vector<float> block_image(int64_t w, int64_t h, float ground, int64_t bx, int64_t by,
                               int64_t b, float value)
{
    std::vector<float> img(static_cast<size_t>(w * h), ground);
    for (int64_t y = by; y < by + b; ++y)
        for (int64_t x = bx; x < bx + b; ++x)
            img[static_cast<size_t>(y * w + x)] = value;
    return img;
}

std::vector<float> spread(const Layer& layer, const std::vector<float>& img, int64_t w, int64_t h,
                          double pitch_um)
{
    const ImageView view { img.data(), w, h, 1 };
    return spread_exposure(layer,
                           LayerExposure(view, { 1.0, 0.0, 0.0 }, pitch_um,
                                         std::numeric_limits<double>::infinity(), FrameEdge::gate),
                           w, h, pitch_um);
}

TEST(LightSpread, ScatterMovesLightAndHalationAddsItsFraction)
{
    // A bright block far from the frame's edges (no light leaves the
    // frame): scatter keeps the total to float rounding (relative 1e-6 over
    // 16384 pixels of round-off ~6e-8 each); halation adds `halation` of it.
    const int64_t w = 128, h = 128;
    const auto img = block_image(w, h, 0.0f, 60, 60, 8, 100.0f);
    const double total = std::accumulate(img.begin(), img.end(), 0.0);
    Layer scatter;
    scatter.scatter          = 0.4;
    scatter.scatter_sigma_um = 20.0;
    const auto s = spread(scatter, img, w, h, 5.0);
    EXPECT_NEAR(std::accumulate(s.begin(), s.end(), 0.0), total, 1e-6 * total);
    EXPECT_LT(s[64 * w + 64], 100.0f);  // light left the block's centre
    EXPECT_GT(s[64 * w + 64 + 12], 0.0f);  // and arrived beside it
    Layer halo = scatter;
    halo.halation           = 0.25;
    halo.halation_radius_um = 100.0;
    halo.halation_kernel    = HalationKernel::ring;
    const auto hs = spread(halo, img, w, h, 5.0);
    EXPECT_NEAR(std::accumulate(hs.begin(), hs.end(), 0.0), 1.25 * total, 1e-6 * total);
    for (float v : hs)
        EXPECT_GE(v, 0.0f);
}

TEST(LightSpread, PixelMeansAreExact)
{
    // The same box-reconstructed image on a grid 4 times finer: the spread
    // exposure's means over the coarse pixels must agree (the weights are
    // exact pixel means of the convolved image). Tolerance: float storage
    // (6e-8 relative per value) for the closed-form Gaussian; for halation
    // also the Gauss-Legendre rule on the edge cells (measured: 1e-6 of the
    // value here; 3e-4 with one 8x8 rule per cell instead of four).
    const int64_t w = 48, h = 40, f = 4;
    const double p = 8.0;
    std::vector<float> coarse(static_cast<size_t>(w * h));
    for (int64_t y = 0; y < h; ++y)
        for (int64_t x = 0; x < w; ++x)
            coarse[static_cast<size_t>(y * w + x)]
                = static_cast<float>(1.0 + ((x * 7 + y * 13) % 11) + (x == 20 && y == 18) * 500.0);
    std::vector<float> fine(static_cast<size_t>(w * h * f * f));
    for (int64_t y = 0; y < h * f; ++y)
        for (int64_t x = 0; x < w * f; ++x)
            fine[static_cast<size_t>(y * w * f + x)] = coarse[static_cast<size_t>((y / f) * w + x / f)];
    Layer scatter;
    scatter.scatter          = 0.5;
    scatter.scatter_sigma_um = 11.0;
    Layer halo;
    halo.halation           = 0.5;
    halo.halation_radius_um = 60.0;
    for (const Layer* spreading : { &scatter, &halo }) {
        const Layer& layer     = *spreading;
        const double tolerance = layer.halation > 0.0 ? 5e-6 : 1e-6;
        const auto a = spread(layer, coarse, w, h, p);
        const auto b = spread(layer, fine, w * f, h * f, p / f);
        double worst = 0.0;
        for (int64_t y = 0; y < h; ++y)
            for (int64_t x = 0; x < w; ++x) {
                double mean = 0.0;
                for (int64_t j = 0; j < f; ++j)
                    for (int64_t i = 0; i < f; ++i)
                        mean += b[static_cast<size_t>((y * f + j) * w * f + x * f + i)];
                mean /= f * f;
                const double ref = a[static_cast<size_t>(y * w + x)];
                worst = std::max(worst, std::fabs(mean - ref) / ref);
            }
        EXPECT_LT(worst, tolerance) << "halation " << layer.halation;
    }
}

TEST(LightSpread, AKernelFarWiderThanThePixelsIsAnError)
{
    // A 5 mm halo on 0.01 um pixels: 5e5 pixels of reach. Refused before
    // anything is allocated, with the keys to change.
    Layer halo;
    halo.halation           = 0.5;
    halo.halation_radius_um = 5000.0;
    const std::vector<float> img(16, 1.0f);
    try {
        spread(halo, img, 4, 4, 0.01);
        FAIL() << "no error";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("halation_radius_um"), std::string::npos) << e.what();
    }
}

// Renders.

/// A dark frame (0.18 * 2^-6) with one input pixel 12 stops over grey in
/// its middle, 1.2 mm wide in 12.5 um input pixels; the colour preset with
/// halation (and scatter) on its red layer.
TestScene point_light_scene()
{
    TestScene s;
    EXPECT_TRUE(load_stock("color-negative", s.stock));
    Layer& red             = s.stock.layers[0];
    red.halation           = 0.5;
    red.halation_radius_um = 200.0;
    red.scatter            = 0.2;
    red.scatter_sigma_um   = 4.0;
    s.scene.frame_width_mm = 1.2;
    const int64_t n        = 96;
    s.pixels               = block_image(n, n, static_cast<float>(0.18 / 64), n / 2, n / 2, 1,
                                         static_cast<float>(0.18 * 4096));
    s.view                 = ImageView { s.pixels.data(), n, n, 1 };
    return s;
}

TEST(LightSpread, RendersAreBitIdenticalForThreadsTilesAndRois)
{
    // A ROI beside the point: its halo (200 um = 16 pixels) reaches in
    // from outside; it reads the whole frame (the spread is computed over
    // it).
    const TestScene s = point_light_scene();
    const Roi roi { 50, 30, 70, 45 };
    for (Engine engine : { Engine::exact, Engine::automatic }) {
        expect_deterministic(s, engine, roi);
        RenderSettings part;
        part.roi = roi;
        Roi window;
        ASSERT_TRUE(required_input_window(s.stock, s.scene, 96, 96, part, window));
        EXPECT_EQ(window.x_begin, 0);
        EXPECT_EQ(window.y_begin, 0);
        EXPECT_EQ(window.x_end, 96);
        EXPECT_EQ(window.y_end, 96);
    }
}

TEST(LightSpread, ZeroStrengthIsNoSpread)
{
    // Radii without strength spread nothing: bit-identical to the stock
    // without the keys, in every engine.
    TestScene plain = point_light_scene();
    for (Layer& l : plain.stock.layers) {
        l.scatter = l.scatter_sigma_um = l.halation = l.halation_radius_um = 0.0;
        l.halation_kernel = HalationKernel::disc;
    }
    TestScene zero = plain;
    for (Layer& l : zero.stock.layers) {
        l.scatter_sigma_um   = 30.0;
        l.halation_radius_um = 300.0;
        l.halation_kernel    = HalationKernel::ring;
    }
    for (Engine engine : { Engine::exact, Engine::automatic, Engine::fast }) {
        RenderSettings settings;
        settings.engine = engine;
        EXPECT_TRUE(bit_identical(render_scene(plain, settings), render_scene(zero, settings)))
            << engine_name(engine);
    }
}

/// Mean and standard error of the red layer's density over scan pixels
/// whose centre lies between r0 and r1 micrometres from the frame's centre.
/// Standard error from the pixels' variance, with pixels in blocks of 4x4
/// as the unit (neighbouring pixels share grains: blocks of 4 pixels, wider
/// than a grain, are nearly independent).
std::pair<double, double> ring_density(const std::vector<float>& d, int64_t n, double pitch_um,
                                       double r0_um, double r1_um)
{
    const double c = 0.5 * n * pitch_um;
    std::vector<double> blocks;
    for (int64_t by = 0; by < n; by += 4)
        for (int64_t bx = 0; bx < n; bx += 4) {
            double s = 0.0;
            int k    = 0;
            for (int64_t y = by; y < by + 4; ++y)
                for (int64_t x = bx; x < bx + 4; ++x) {
                    const double r = std::hypot((x + 0.5) * pitch_um - c, (y + 0.5) * pitch_um - c);
                    if (r >= r0_um && r < r1_um) {
                        s += d[static_cast<size_t>((y * n + x) * 3)];
                        ++k;
                    }
                }
            if (k == 16)
                blocks.push_back(s / k);
        }
    return mean_and_standard_error(blocks);
}

TEST(LightSpread, TheHaloHasItsRadiusInMicrometresAtEveryScan)
{
    // Two scans of the same frame (9.4 and 6.25 um pixels): inside the
    // 200 um halo the red layer is denser than the ground (> 10 standard
    // errors); just outside it (1.15 to 1.6 radii) it is the ground (within
    // 4 standard errors of the difference), so the halo ends at its radius
    // in micrometres whatever the scan.
    const TestScene s = point_light_scene();
    for (int64_t scan : { 128, 192 }) {
        RenderSettings settings;
        settings.scan_width  = scan;
        settings.scan_height = scan;
        const auto d         = render_scene(s, settings);
        const double pitch   = 1200.0 / scan;
        const auto inside    = ring_density(d, scan, pitch, 60.0, 170.0);
        const auto outside   = ring_density(d, scan, pitch, 230.0, 320.0);
        const auto ground    = ring_density(d, scan, pitch, 420.0, 600.0);
        const auto se = [](std::pair<double, double> a, std::pair<double, double> b) {
            return std::hypot(a.second, b.second);
        };
        EXPECT_GT(inside.first - ground.first, 10.0 * se(inside, ground)) << "scan " << scan;
        EXPECT_LT(std::fabs(outside.first - ground.first), 4.0 * se(outside, ground))
            << "scan " << scan;
    }
}

}  // namespace
}  // namespace filmgrain
