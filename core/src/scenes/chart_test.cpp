// Tests of the built-in look chart (chart.h): exact, from its spec.
#include "filmgrain/chart.h"

#include <algorithm>

#include <gtest/gtest.h>

namespace filmgrain {
namespace {

/// Channel c of pixel (x, y) of a packed RGB chart.
float at(const std::vector<float>& px, const ChartSpec& spec, int64_t x, int64_t y, int c)
{
    return px[static_cast<size_t>((y * spec.width_px + x) * 3 + c)];
}

TEST(LookChart, SizeAndStripWidth)
{
    const ChartSpec spec;
    const std::vector<float> px = make_look_chart(spec);
    EXPECT_EQ(spec.width_px, 1536);
    EXPECT_EQ(spec.height_px, 768);
    EXPECT_EQ(px.size(), static_cast<size_t>(spec.width_px * spec.height_px * 3));
    // Pixels of 6.25 um, as the wedge's.
    EXPECT_DOUBLE_EQ(spec.strip_width_mm, spec.width_px * 6.25e-3);
    ChartSpec empty;
    empty.width_px = 0;
    EXPECT_TRUE(make_look_chart(empty).empty());
}

TEST(LookChart, GroundIsTheDocumentedValue)
{
    const ChartSpec spec;
    const std::vector<float> px = make_look_chart(spec);
    const float ground = static_cast<float>(0.18 / 64.0);  // 0.18 * 2^-6
    for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(at(px, spec, 0, 0, c), ground);
        EXPECT_EQ(at(px, spec, spec.width_px - 1, spec.height_px - 1, c), ground);
        EXPECT_EQ(at(px, spec, spec.point_x_px() + 40, spec.point_y_px(), c), ground);
    }
    // The ground is the darkest value outside the ColorChecker (whose cyan
    // has a red of 8/255 sRGB, 0.0024, below it).
    float darkest = px[0];
    for (int64_t y = 0; y < spec.height_px; ++y)
        for (int64_t x = 0; x < 2 * spec.third_px(); ++x)
            for (int c = 0; c < 3; ++c)
                darkest = std::min(darkest, at(px, spec, x, y, c));
    EXPECT_EQ(darkest, ground);
}

TEST(LookChart, PointLightsPeakWhereDocumented)
{
    const ChartSpec spec;
    const std::vector<float> px = make_look_chart(spec);
    const float peak = static_cast<float>(0.18 * 1024.0);  // 0.18 * 2^10
    EXPECT_EQ(spec.point_x_px(), 256);
    EXPECT_EQ(spec.point_y_px(), 256);
    EXPECT_EQ(spec.dim_point_y_px(), 512);
    const auto brightest = std::max_element(px.begin(), px.end());
    EXPECT_EQ(*brightest, peak);
    const int64_t i = (brightest - px.begin()) / 3;
    // The first maximum in raster order is the disc's top pixel, on the
    // centre column, radius pixels above the centre.
    EXPECT_EQ(i % spec.width_px, spec.point_x_px());
    EXPECT_EQ(i / spec.width_px, spec.point_y_px() - spec.point_radius_px);
    int64_t disc = 0, dim = 0;
    for (size_t k = 0; k < px.size(); k += 3) {
        disc += px[k] == peak;
        dim += px[k] == static_cast<float>(0.18 * 64.0);
    }
    EXPECT_EQ(disc, 29);  // dx^2 + dy^2 <= 9
    EXPECT_EQ(dim, 29);
    for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(at(px, spec, spec.point_x_px(), spec.point_y_px(), c), peak);
        EXPECT_EQ(at(px, spec, spec.point_x_px() + 3, spec.point_y_px(), c), peak);
        EXPECT_LT(at(px, spec, spec.point_x_px() + 3, spec.point_y_px() + 1, c), peak);
    }
}

TEST(LookChart, GreyRectangleHasSharpEdges)
{
    const ChartSpec spec;
    const std::vector<float> px = make_look_chart(spec);
    const int64_t y = (spec.rect_y0_px() + spec.rect_y1_px()) / 2;
    EXPECT_EQ(at(px, spec, spec.rect_x0_px(), y, 1), 0.18f);
    EXPECT_EQ(at(px, spec, spec.rect_x1_px() - 1, y, 1), 0.18f);
    EXPECT_LT(at(px, spec, spec.rect_x0_px() - 1, y, 1), 0.01f);
    EXPECT_LT(at(px, spec, spec.rect_x1_px(), y, 1), 0.01f);
}

TEST(LookChart, ColorCheckerPatches)
{
    const ChartSpec spec;
    const std::vector<float> px = make_look_chart(spec);
    EXPECT_EQ(spec.patch_x_px(0), 1044);
    EXPECT_EQ(spec.patch_y_px(0), 228);
    auto centre = [&](int patch, int c) {
        return at(px, spec, spec.patch_x_px(patch) + spec.patch_px / 2,
                  spec.patch_y_px(patch) + spec.patch_px / 2, c);
    };
    // Patch 19 (white 9.5) is brighter than patch 24 (black 2), both grey;
    // their linearised sRGB values (243 -> 0.896, 52 -> 0.0343).
    for (int c = 0; c < 3; ++c)
        EXPECT_GT(centre(18, c), centre(23, c));
    EXPECT_NEAR(centre(18, 0), 0.8963, 1e-4);
    EXPECT_NEAR(centre(23, 0), 0.03434, 1e-4);
    EXPECT_NEAR(centre(21, 0), 0.1946, 1e-4);  // neutral 5, 122
    // Patch 15 (red) is red, patch 14 (green) green, patch 13 (blue) blue.
    EXPECT_GT(centre(14, 0), 4 * centre(14, 1));
    EXPECT_GT(centre(13, 1), 2 * centre(13, 0));
    EXPECT_GT(centre(12, 2), 4 * centre(12, 0));
    // Every patch lies inside the right third, with ground between patches.
    EXPECT_GE(spec.patch_x_px(0), 2 * spec.third_px());
    EXPECT_LE(spec.patch_x_px(5) + spec.patch_px, spec.width_px);
    EXPECT_GE(spec.patch_y_px(0), 0);
    EXPECT_LE(spec.patch_y_px(23) + spec.patch_px, spec.height_px);
    const float ground = static_cast<float>(ChartSpec::level(spec.ground_stops));
    EXPECT_EQ(at(px, spec, spec.patch_x_px(1) - 1, spec.patch_y_px(1) + 10, 0), ground);
}

TEST(LookChart, IsAPureFunctionOfItsSpec)
{
    ChartSpec small;
    small.width_px  = 300;
    small.height_px = 120;
    EXPECT_EQ(make_look_chart(small), make_look_chart(small));
    EXPECT_EQ(make_look_chart(small).size(), 300u * 120u * 3u);
    EXPECT_EQ(make_look_chart(ChartSpec()), make_look_chart(ChartSpec()));
}

}  // namespace
}  // namespace filmgrain
