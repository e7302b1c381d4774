// Tests of the preview positive (preview.h): the plain inversion, and the
// timed print through ADX and OCIO (MODEL.md 11).
#include "preview.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "filmgrain/ocio.h"

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

/// The ACES SDR view's 8-bit value of ACES2065-1 (v, v, v), as the preview
/// rounds it (the embedded config's default display and view).
uint8_t sdr_of_aces(float v)
{
    std::unique_ptr<ocio::Converter> conv;
    EXPECT_TRUE(ocio::Converter::create_display_view("", "ACES2065-1", "", "", conv));
    float rgb[3] = { v, v, v };
    conv->apply_rgb(rgb, 1);
    return static_cast<uint8_t>(std::lround(255.0 * std::clamp(rgb[1], 0.0f, 1.0f)));
}

TEST(Preview, ATimedPrintThroughAdxAndTheAcesView)
{
    // vision3-500t (5219's Annex C map): its own 18% grey card (the
    // expected densities the timing is computed from) previews as ACES
    // 0.18 through the SDR view, the same in R, G and B; D-min previews
    // near black; denser is brighter.
    Stock stock;
    ASSERT_TRUE(load_stock("vision3-500t", stock));
    AdxOptions o;
    o.timing = AdxTiming::grey;
    AdxTransform t;
    ASSERT_TRUE(stock_adx_transform(stock, SceneSettings(), o, t));
    const auto f = [](double v) { return static_cast<float>(v); };
    const float d[] = { f(t.status_m_dmin[0]), f(t.status_m_dmin[1]), f(t.status_m_dmin[2]),
                        f(t.status_m_grey[0]), f(t.status_m_grey[1]), f(t.status_m_grey[2]),
                        f(t.status_m_grey[0] + 0.5), f(t.status_m_grey[1] + 0.5),
                        f(t.status_m_grey[2] + 0.5) };
    Preview p;
    std::string warning;
    auto cache     = std::make_shared<std::optional<AdxTransform>>();
    const Status s = make_film_preview(d, 3, 1, stock, SceneSettings(), "", p, warning, cache);
    ASSERT_TRUE(s) << s.message();
    EXPECT_EQ(warning, "");
    ASSERT_EQ(p.channels, 3);
    EXPECT_LE(p.pixels[0], 2);
    EXPECT_LE(p.pixels[1], 2);
    EXPECT_LE(p.pixels[2], 2);
    // The grey: CDD 0.70 (+- float rounding of the densities, 1e-7) in
    // every channel, ACES 0.18 within 1e-5: the same 8-bit value.
    const uint8_t grey = sdr_of_aces(0.18f);
    EXPECT_NEAR(grey, 100, 15) << "the ACES SDR view's mid grey";
    EXPECT_EQ(p.pixels[3], grey);
    EXPECT_EQ(p.pixels[4], grey);
    EXPECT_EQ(p.pixels[5], grey);
    EXPECT_GT(p.pixels[6], p.pixels[3]);
    ASSERT_TRUE(cache->has_value()) << "the transform is kept for the next frame";
    EXPECT_EQ((*cache)->timing_cdd, t.timing_cdd);

    // A one-layer (silver) stock stays neutral at every density, and its
    // grey card is the same mid grey.
    Stock paper;
    ASSERT_TRUE(load_stock("paper", paper));
    AdxTransform pt;
    ASSERT_TRUE(stock_adx_transform(paper, SceneSettings(), o, pt));
    std::vector<float> y;
    for (double above = -0.1; above <= 2.5; above += 0.1)
        y.push_back(f(pt.status_m_dmin[0] + above));
    y.push_back(f(pt.status_m_grey[0]));
    ASSERT_TRUE(make_film_preview(y.data(), static_cast<int64_t>(y.size()), 1, paper,
                                  SceneSettings(), "", p, warning));
    EXPECT_EQ(warning, "");
    for (size_t i = 0; i < y.size(); ++i) {
        EXPECT_EQ(p.pixels[3 * i], p.pixels[3 * i + 1]) << i;
        EXPECT_EQ(p.pixels[3 * i], p.pixels[3 * i + 2]) << i;
    }
    EXPECT_EQ(p.pixels[3 * (y.size() - 1)], grey);

    // No single expected curve (rate_area_exponent != 0): D-min still
    // exists (fog), so an untimed preview, with a warning.
    paper.layers[0].populations[0].rate_area_exponent = 1.0;
    ASSERT_TRUE(make_film_preview(y.data(), static_cast<int64_t>(y.size()), 1, paper,
                                  SceneSettings(), "", p, warning));
    EXPECT_NE(warning.find("preview: not timed"), std::string::npos) << warning;

    // Layers that are not R, G, B: the plain inversion, with a warning.
    stock.layers[0].name = "X";
    stock.status_m_to_apd.reset();
    ASSERT_TRUE(make_film_preview(d, 3, 1, stock, SceneSettings(), "", p, warning));
    EXPECT_NE(warning.find("plain inversion"), std::string::npos) << warning;
    EXPECT_EQ(p.pixels, make_preview(d, 3, 1, { "X", "G", "B" },
                                     { stock.layer_base_density(0), stock.layer_base_density(1),
                                       stock.layer_base_density(2) })
                            .pixels);
}

}  // namespace
}  // namespace filmgrain::cli
