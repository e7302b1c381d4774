// Tests of the preview positive (preview.h).
#include "preview.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "filmgrain/expected_curve.h"

namespace filmgrain::cli {
namespace {

TEST(Preview, LayerChoice)
{
    EXPECT_EQ(preview_layers({ "B", "G", "R" }), (std::vector<int> { 2, 1, 0 }));
    EXPECT_EQ(preview_layers({ "Y" }), (std::vector<int> { 0 }));
    EXPECT_EQ(preview_layers({ "a", "b" }), (std::vector<int> { 0 }));
    EXPECT_EQ(preview_layers({ "a", "b", "c", "d" }), (std::vector<int> { 0, 1, 2 }));
    EXPECT_EQ(preview_layers({ "x", "R", "G", "B" }), (std::vector<int> { 1, 2, 3 }));
}

TEST(Preview, Quantile)
{
    std::vector<double> v;
    for (int i = 0; i <= 1000; ++i)
        v.push_back(static_cast<float>(1000 - i));
    EXPECT_EQ(quantile(v, 0.999), 999.0);
    EXPECT_EQ(quantile(v, 0.0), 0.0);
    EXPECT_EQ(quantile(v, 1.0), 1000.0);
    v.push_back(std::numeric_limits<float>::quiet_NaN());
    EXPECT_EQ(quantile(v, 1.0), 1000.0) << "non-finite values are ignored";
    EXPECT_EQ(quantile({}, 0.5), 0.0);
}

TEST(Preview, MappingIsOneScaleForAllChannels)
{
    // 2 pixels, layers R, G, B. Base 0.2; D_hi is the 99.9th percentile of
    // the six values = the largest below the top rank: 1.2.
    const float d[] = { 0.2f, 0.7f, 1.2f,   // pixel 0
                        1.2f, 0.1f, 1.25f };  // pixel 1
    const Preview p = make_preview(d, 2, 1, { "R", "G", "B" }, { 0.2, 0.2, 0.2 });
    ASSERT_EQ(p.channels, 3);
    ASSERT_EQ(p.pixels.size(), 6u);
    EXPECT_EQ(p.pixels[0], 0);  // at base
    EXPECT_EQ(p.pixels[1], static_cast<uint8_t>(std::lround(255 * std::pow(0.5, 1 / 2.2))));
    EXPECT_EQ(p.pixels[2], 255);
    EXPECT_EQ(p.pixels[3], 255);
    EXPECT_EQ(p.pixels[4], 0);  // below base: clamped
    EXPECT_EQ(p.pixels[5], 255);  // above D_hi: clamped
}

TEST(Preview, UnexposedFilmIsBlack)
{
    const float d[] = { 0.2f, 0.2f, 0.2f, 0.2f };
    const Preview p = make_preview(d, 2, 2, { "Y" }, { 0.2 });
    EXPECT_EQ(p.channels, 1);
    for (uint8_t v : p.pixels)
        EXPECT_EQ(v, 0);
}

TEST(Preview, ThroughOcioAdxAndTheAcesView)
{
    // The colour negative: D-min (base + fog, the model's) previews black,
    // D-min + 0.69 (ADX's mid grey: ACES 0.18) a neutral grey near the ACES
    // SDR view's 0.39 (~100 of 255), denser is brighter; R = G = B for a
    // neutral density.
    Stock stock;
    ASSERT_TRUE(load_stock("color-negative", stock));
    std::vector<ExpectedCurve> fog;
    ExpectedCurveOptions o;
    o.fog_only = true;
    ASSERT_TRUE(expected_curves(stock, SceneSettings(), o, fog));
    const float dmin = static_cast<float>(fog[0].min_density());
    const float d[]  = { dmin, dmin, dmin, dmin + 0.69f, dmin + 0.69f, dmin + 0.69f,
                         dmin + 1.2f, dmin + 1.2f, dmin + 1.2f };
    Preview p;
    std::string warning;
    const Status s = make_film_preview(d, 3, 1, stock, SceneSettings(), "", p, warning);
    ASSERT_TRUE(s) << s.message();
    EXPECT_EQ(warning, "");
    ASSERT_EQ(p.channels, 3);
    EXPECT_LE(p.pixels[0], 2);
    EXPECT_NEAR(p.pixels[3], 100, 15);
    EXPECT_EQ(p.pixels[3], p.pixels[4]);
    EXPECT_EQ(p.pixels[3], p.pixels[5]);
    EXPECT_GT(p.pixels[6], p.pixels[3]);

    // Layers that are not R, G, B: the plain inversion, with a warning.
    stock.layers[0].name = "X";
    ASSERT_TRUE(make_film_preview(d, 3, 1, stock, SceneSettings(), "", p, warning));
    EXPECT_NE(warning.find("plain inversion"), std::string::npos) << warning;
    EXPECT_EQ(p.pixels, make_preview(d, 3, 1, { "X", "G", "B" },
                                     { stock.layer_base_density(0), stock.layer_base_density(1),
                                       stock.layer_base_density(2) })
                            .pixels);
}

}  // namespace
}  // namespace filmgrain::cli
