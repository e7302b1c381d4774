// Tests of geometry (MODEL.md 1): frame mapping and the grain processes.
#include "model/geometry.h"

#include <cmath>
#include <map>
#include <tuple>

#include <gtest/gtest.h>

#include "util/sampling.h"

namespace filmgrain {
namespace {

TEST(FrameGeometry, MapsInputAndScan)
{
    FrameGeometry g;
    ASSERT_TRUE(FrameGeometry::make(24.89, 2489, 1000, 0, 0, g));
    EXPECT_DOUBLE_EQ(g.input_pitch_um, 10.0);
    EXPECT_DOUBLE_EQ(g.height_um, 10000.0);
    EXPECT_EQ(g.scan_width, 2489);
    EXPECT_EQ(g.scan_height, 1000);
    // A scan width alone follows the frame's aspect.
    ASSERT_TRUE(FrameGeometry::make(24.89, 2489, 1000, 500, 0, g));
    EXPECT_EQ(g.scan_height, 201);
    EXPECT_DOUBLE_EQ(g.scan_pitch_x_um, 24890.0 / 500);
    EXPECT_DOUBLE_EQ(g.scan_pitch_y_um, 10000.0 / 201);
    EXPECT_FALSE(FrameGeometry::make(0, 10, 10, 0, 0, g));
    EXPECT_FALSE(FrameGeometry::make(24.89, 0, 10, 0, 0, g));
    EXPECT_FALSE(FrameGeometry::make(NAN, 10, 10, 0, 0, g));
}

TEST(FrameGeometry, AScanReferenceSetsTheGridThatContinuesOverTheFrame)
{
    // An 84x58 input (10 um pixels) whose display window is the 64x48
    // reference at (10, 5), scanned 50 wide: the scan's pitch is the
    // reference's, its pixel (0, 0) the reference's corner, and the frame
    // around the reference is covered by the same grid, rounded outward.
    FrameGeometry g;
    ASSERT_TRUE(FrameGeometry::make(0.84, 84, 58, 50, 0, g, Roi { 10, 5, 74, 53 }));
    EXPECT_EQ(g.scan_height, 38);  // 50 x 48 / 64 = 37.5, rounded
    EXPECT_DOUBLE_EQ(g.scan_pitch_x_um, 640.0 / 50);
    EXPECT_DOUBLE_EQ(g.scan_pitch_y_um, 480.0 / 38);
    EXPECT_DOUBLE_EQ(g.scan_origin_x_um, 100.0);
    EXPECT_DOUBLE_EQ(g.scan_origin_y_um, 50.0);
    const RectUm r = g.scan_rect(-1, 0, 50, 38);
    EXPECT_DOUBLE_EQ(r.x0_um, 100.0 - 12.8);
    EXPECT_DOUBLE_EQ(r.x1_um, 740.0);
    EXPECT_DOUBLE_EQ(r.y1_um, 530.0);
    // The frame: 10 input pixels left = 7.8125 scan pixels, 10 right =
    // 7.8125; 5 above = 3.958, 5 below = 3.958: rounded outward.
    const Roi all = g.frame_scan_pixels();
    EXPECT_EQ(all.x_begin, -8);
    EXPECT_EQ(all.x_end, 58);
    EXPECT_EQ(all.y_begin, -4);
    EXPECT_EQ(all.y_end, 42);
    // Whole scan pixels stay whole: the reference itself, and 32 input
    // pixels = 25 scan pixels.
    const Roi ref = scan_pixels_over(g.scan_reference, g.scan_width, g.scan_height,
                                     Roi { 10, 5, 74, 53 });
    EXPECT_EQ(ref.x_begin, 0);
    EXPECT_EQ(ref.x_end, 50);
    EXPECT_EQ(ref.y_end, 38);
    EXPECT_EQ(scan_pixels_over(g.scan_reference, 50, 38, Roi { 42, 5, 74, 53 }).x_begin, 25);
    // Without a reference the scan is the frame's, as it always was.
    FrameGeometry plain;
    ASSERT_TRUE(FrameGeometry::make(0.84, 84, 58, 50, 0, plain));
    EXPECT_EQ(plain.scan_origin_x_um, 0.0);
    const Roi whole = plain.frame_scan_pixels();
    EXPECT_EQ(whole.x_begin, 0);
    EXPECT_EQ(whole.x_end, 50);
    EXPECT_EQ(whole.y_end, plain.scan_height);
    // A reference beyond the input is an error.
    EXPECT_FALSE(FrameGeometry::make(0.84, 84, 58, 50, 0, g, Roi { 10, 5, 90, 53 }));
}

TEST(PopulationGrains, BinsPartitionTheDistribution)
{
    Population pop;
    pop.diameter_log_sigma = 0.3;
    const PopulationGrains grains(pop, 1, 0, 0);
    double total = 0;
    double prev_hi = -INFINITY;
    for (const auto& b : grains.bins()) {
        EXPECT_EQ(b.z_lo, prev_hi);
        prev_hi = b.z_hi;
        total += b.grains_per_um2;
    }
    EXPECT_EQ(prev_hi, 9.0);
    EXPECT_NEAR(total / pop.grains_per_um2, 1.0 - normal_upper_tail(9.0), 1e-15);
    EXPECT_GT(grains.bins().size(), 1u);
    EXPECT_NEAR(grains.mean_area_um2(), M_PI / 4 * 36 * std::exp(0.09), 1e-12);
    // A narrow distribution needs one bin.
    pop.diameter_log_sigma = 0.0;
    EXPECT_EQ(PopulationGrains(pop, 1, 0, 0).bins().size(), 1u);
}

struct Sample {
    double count = 0, area_sum = 0, area2_sum = 0;
};

Sample sample_region(const PopulationGrains& grains, const RectUm& r)
{
    Sample s;
    grains.for_each_grain_near(r, [&](const Grain& g) {
        if (g.x_um < r.x0_um || g.x_um >= r.x1_um || g.y_um < r.y0_um || g.y_um >= r.y1_um)
            return;
        const double a = M_PI * g.radius_um * g.radius_um;
        s.count += 1;
        s.area_sum += a;
        s.area2_sum += a * a;
    });
    return s;
}

TEST(PopulationGrains, IntensityAndMeanArea)
{
    // Grain count in a region is Poisson(lambda A): 5 sigma = 5 sqrt(lambda A).
    // Mean area: standard error sqrt(var(a) / count), 5 sigma.
    for (double sigma : { 0.0, 0.3, 0.8 }) {
        Population pop;
        pop.grains_per_um2     = 0.5;
        pop.diameter_um        = 2.0;
        pop.diameter_log_sigma = sigma;
        const PopulationGrains grains(pop, 77, 1, 2);
        const RectUm r { -300, 100, 700, 1100 };
        const Sample s      = sample_region(grains, r);
        const double expect = pop.grains_per_um2 * 1e6;
        EXPECT_NEAR(s.count, expect, 5 * std::sqrt(expect)) << "sigma " << sigma;
        const double mean = s.area_sum / s.count;
        // (var is 0 up to rounding when sigma = 0: allow summation rounding.)
        const double var  = std::max(0.0, s.area2_sum / s.count - mean * mean);
        EXPECT_NEAR(mean, grains.mean_area_um2(), 5 * std::sqrt(var / s.count) + 1e-9 * mean)
            << "sigma " << sigma;
    }
}

TEST(PopulationGrains, GrainsDoNotDependOnTheRegionAsked)
{
    // Every grain found for a small region is found, identically and in the
    // same relative order, for a larger region containing it.
    Population pop;
    pop.diameter_log_sigma = 0.6;
    const PopulationGrains grains(pop, 3, 0, 0);
    const RectUm small { 100, 100, 180, 150 }, large { -50, 20, 400, 333 };
    std::vector<std::tuple<uint64_t, double, double, double>> a, b;
    const auto touches = [&](const Grain& g, const RectUm& r) {
        const double dx = std::max({ r.x0_um - g.x_um, 0.0, g.x_um - r.x1_um });
        const double dy = std::max({ r.y0_um - g.y_um, 0.0, g.y_um - r.y1_um });
        return dx * dx + dy * dy < g.radius_um * g.radius_um;
    };
    grains.for_each_grain_near(small, [&](const Grain& g) {
        if (touches(g, small))
            a.emplace_back(g.id, g.x_um, g.y_um, g.radius_um);
    });
    grains.for_each_grain_near(large, [&](const Grain& g) {
        if (touches(g, small))
            b.emplace_back(g.id, g.x_um, g.y_um, g.radius_um);
    });
    ASSERT_FALSE(a.empty());
    EXPECT_EQ(a, b);
    // Another seed gives other grains.
    const PopulationGrains other(pop, 4, 0, 0);
    std::vector<std::tuple<uint64_t, double, double, double>> c;
    other.for_each_grain_near(small, [&](const Grain& g) {
        if (touches(g, small))
            c.emplace_back(g.id, g.x_um, g.y_um, g.radius_um);
    });
    EXPECT_NE(a, c);
}

}  // namespace
}  // namespace filmgrain
