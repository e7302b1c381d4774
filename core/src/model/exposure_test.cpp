// Tests of exposure (MODEL.md 2): the disc-rectangle area and the disc
// integral against the box-reconstructed image.
#include "model/exposure.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "model/image_formation.h"
#include "util/rng.h"

namespace filmgrain {
namespace {

TEST(Exposure, UnitConversion)
{
    // v = 0.18 gets exposure_at_grey; each stop doubles it.
    EXPECT_DOUBLE_EQ(0.18 * exposure_lxs_per_unit_value(0.02, 0.0), 0.02);
    EXPECT_DOUBLE_EQ(0.18 * exposure_lxs_per_unit_value(0.02, 2.0), 0.08);
}

TEST(DiscRectArea, SimpleCases)
{
    const double r = 2.0, disc = M_PI * r * r;
    EXPECT_NEAR(disc_rect_area_um2(0, 0, r, -5, -5, 5, 5), disc, 1e-12);
    EXPECT_NEAR(disc_rect_area_um2(0, 0, r, 0, -5, 5, 5), disc / 2, 1e-12);
    EXPECT_NEAR(disc_rect_area_um2(0, 0, r, 0, 0, 5, 5), disc / 4, 1e-12);
    EXPECT_NEAR(disc_rect_area_um2(0, 0, r, -1, -1, 1, 1), 4.0, 1e-12);
    EXPECT_EQ(disc_rect_area_um2(0, 0, r, 3, 3, 5, 5), 0.0);
    // A segment: area of the cap beyond x = 1 is r^2 acos(1/r) - sqrt(r^2 - 1).
    const double cap = r * r * std::acos(1.0 / r) - std::sqrt(r * r - 1.0);
    EXPECT_NEAR(disc_rect_area_um2(0, 0, r, 1, -5, 5, 5), cap, 1e-12);
}

TEST(DiscRectArea, AgreesWithUnionCoverageOfOneDisc)
{
    // Two independent closed forms (corner quadrant function; Green's
    // theorem over arcs) must agree to rounding.
    Rng rng(99, Stage::cell);
    for (int i = 0; i < 2000; ++i) {
        const Disc d { rng.uniform() * 4 - 1, rng.uniform() * 4 - 1, 0.05 + rng.uniform() * 3 };
        const double a = disc_rect_area_um2(d.x_um, d.y_um, d.r_um, 0, 0, 2, 1.5);
        const double b = union_coverage_um2(&d, 1, 0, 0, 2, 1.5);
        EXPECT_NEAR(a, b, 1e-12) << d.x_um << " " << d.y_um << " " << d.r_um;
    }
}

TEST(LayerExposure, IntegratesAgainstTheBoxImage)
{
    // 4x3 image, pitch 10 um; columns have values 1, 2, 3, 4.
    std::vector<float> px(12);
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 4; ++x)
            px[y * 4 + x] = static_cast<float>(x + 1);
    const ImageView view { px.data(), 4, 3, 1 };
    const LayerExposure ex(view, { 1.0, 0.0, 0.0 }, 10.0, 1e30, FrameEdge::gate);
    // Inside one pixel: value * pi r^2.
    EXPECT_NEAR(ex.integrate_over_disc(15, 15, 2), 2 * M_PI * 4, 1e-12);
    // Straddling columns 1 and 2 at x = 20: half the disc each.
    EXPECT_NEAR(ex.integrate_over_disc(20, 15, 3), (2 + 3) * M_PI * 9 / 2, 1e-9);
    // Half outside the frame on the left: only the inside half counts.
    EXPECT_NEAR(ex.integrate_over_disc(0, 15, 3), 1 * M_PI * 9 / 2, 1e-9);
    // Entirely outside: nothing.
    EXPECT_EQ(ex.integrate_over_disc(-10, 15, 3), 0.0);
    // A disc over the whole image: the sum of value * pixel area.
    EXPECT_NEAR(ex.integrate_over_disc(20, 15, 1000), (1 + 2 + 3 + 4) * 3 * 100.0, 1e-6);
}

TEST(LayerExposure, GridMeansAreTheBoxImagesMeanOverEachCell)
{
    // 4x3 image, pitch 10 um, value 1 + x + 10 y at pixel (x, y). Cells of
    // 7 um from x = -4 um and of 13 um from y = -6 um straddle pixels and
    // reach past the image on every side.
    std::vector<float> px(12);
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 4; ++x)
            px[y * 4 + x] = static_cast<float>(1 + x + 10 * y);
    const ImageView view { px.data(), 4, 3, 1 };
    std::vector<double> xs, ys;
    for (int i = 0; i <= 8; ++i)
        xs.push_back(-4.0 + 7.0 * i);
    for (int j = 0; j <= 3; ++j)
        ys.push_back(-6.0 + 13.0 * j);
    // The mean over [x0, x1] x [y0, y1] as the sum over whole micrometre
    // squares (every edge here is a whole micrometre) of the pixel each
    // falls in: beyond the image the nearest pixel (clamp) or 0 (gate).
    const auto expected = [&](FrameEdge edge, double x0, double y0, double x1, double y1) {
        double sum = 0.0;
        for (double y = y0; y < y1; ++y)
            for (double x = x0; x < x1; ++x) {
                const int ix = static_cast<int>(std::floor(x / 10.0));
                const int iy = static_cast<int>(std::floor(y / 10.0));
                if (edge == FrameEdge::gate && (ix < 0 || ix > 3 || iy < 0 || iy > 2))
                    continue;
                sum += 1 + std::clamp(ix, 0, 3) + 10 * std::clamp(iy, 0, 2);
            }
        return sum / ((x1 - x0) * (y1 - y0));
    };
    for (FrameEdge edge : { FrameEdge::clamp, FrameEdge::gate }) {
        const LayerExposure ex(view, { 1.0, 0.0, 0.0 }, 10.0, 1e30, edge);
        std::vector<double> means(8 * 3, -1.0);
        ex.means_over_grid(xs, ys, means.data());
        for (size_t j = 0; j < 3; ++j)
            for (size_t i = 0; i < 8; ++i) {
                const double e = expected(edge, xs[i], ys[j], xs[i + 1], ys[j + 1]);
                EXPECT_NEAR(means[j * 8 + i], e, 1e-12 * e + 1e-15) << i << ", " << j;
                // One cell alone: the same value, to the bit.
                EXPECT_EQ(ex.mean_over_rect(xs[i], ys[j], xs[i + 1], ys[j + 1]),
                          means[j * 8 + i]);
            }
    }
}

TEST(LayerExposure, SpecialValuesExposeNothingOrSaturate)
{
    // MODEL.md 2, extremes: NaN and negative light expose nothing; +Inf and
    // values past the layer's saturation value are clamped to it; a
    // channel the layer does not read (weight 0) does not count, +-Inf
    // included.
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    std::vector<float> rgb = { nan, 1,   1, inf, 1, 1, -2,   1, 1, 0.5f, 0.25f, 1,
                               -inf, 1, 1, 0,   0, inf, 3e6f, 0, 0, inf, -inf, 0 };
    const ImageView view { rgb.data(), 8, 1, 3 };
    const LayerExposure ex(view, { 1.0, 1.0, 0.0 }, 1.0, 1e6, FrameEdge::gate);
    EXPECT_EQ(ex.value(0, 0), 0.0);   // NaN channel
    EXPECT_EQ(ex.value(1, 0), 1e6);   // +Inf: saturates
    EXPECT_TRUE(ex.saturates(1, 0));
    EXPECT_EQ(ex.value(2, 0), 0.0);   // v = -1: no negative light
    EXPECT_EQ(ex.value(3, 0), 0.75);  // dot(sensitivity, rgb)
    EXPECT_FALSE(ex.saturates(3, 0));
    EXPECT_EQ(ex.value(4, 0), 0.0);   // -Inf: no light
    EXPECT_EQ(ex.value(5, 0), 0.0);   // +Inf in blue, which the layer does not read
    EXPECT_FALSE(ex.saturates(5, 0));
    EXPECT_EQ(ex.value(6, 0), 1e6);   // past the saturation value
    EXPECT_EQ(ex.value(7, 0), 0.0);   // +Inf - Inf: no defined light
    // Grey input is read as (y, y, y).
    std::vector<float> grey = { 0.5f, inf };
    const LayerExposure eg(ImageView { grey.data(), 2, 1, 1 }, { 0.2, 0.3, 0.4 }, 1.0, 1e6,
                           FrameEdge::gate);
    EXPECT_NEAR(eg.value(0, 0), 0.45, 1e-7);
    EXPECT_EQ(eg.value(1, 0), 1e6);
}

TEST(LayerExposure, SaturationIsTheLargestMeanPhotonCountTheKineticsRepresent)
{
    // A layer saturates where a mean-sized grain of its most sensitive
    // population absorbs kMaxMeanPhotonsPerGrain on average (MODEL.md 2).
    Layer layer;
    Population a, b;
    a.diameter_um = 1.0;
    a.diameter_log_sigma = 0.0;
    a.quantum_efficiency = 0.1;
    b = a;
    b.diameter_um = 2.0;  // four times the area: the most sensitive
    layer.populations = { a, b };
    const double lxs_per_value = 0.5;
    const double per_value = 0.1 * kPhotonsPerUm2PerLxs * lxs_per_value * M_PI;  // b: area pi
    EXPECT_NEAR(saturation_value(layer, lxs_per_value) * per_value, kMaxMeanPhotonsPerGrain,
                1e-6 * kMaxMeanPhotonsPerGrain);
}

}  // namespace
}  // namespace filmgrain
