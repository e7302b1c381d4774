// Tests of the preview positive (preview.h).
#include "preview.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

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
    std::vector<float> v;
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
    const Preview p = make_preview(d, 2, 1, { "R", "G", "B" }, 0.2);
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
    const Preview p = make_preview(d, 2, 2, { "Y" }, 0.2);
    EXPECT_EQ(p.channels, 1);
    for (uint8_t v : p.pixels)
        EXPECT_EQ(v, 0);
}

}  // namespace
}  // namespace filmgrain::cli
