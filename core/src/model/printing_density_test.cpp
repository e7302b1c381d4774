// Tests of printing density and ADX (MODEL.md 11; printing_density.h):
// exact values computed by hand, the stock key, and the timing of the
// built-in stocks from their expected curves.
#include "filmgrain/printing_density.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "filmgrain/expected_curve.h"
#include "testing/test_stock_json.h"

namespace filmgrain {
namespace {

/// 5219's Annex C map (S-2008-002 v1.1; stocks/datasheets/
/// kodak-vision3-500t-5219.json).
StatusMToApd map_5219()
{
    StatusMToApd m;
    m.matrix = { { { 1.100481, -0.017433, -0.000160 },
                   { -0.005245, 1.021893, 0.009767 },
                   { -0.008288, 0.028113, 0.957600 } } };
    m.offset = { -0.046520, -0.025677, 0.010549 };
    return m;
}

TEST(PrintingDensity, StatusMToApdIsTheAnnexCMultiplication)
{
    // StM (0.8, 1.2, 1.5), by hand:
    //   R = 1.100481*0.8 - 0.017433*1.2 - 0.000160*1.5 - 0.046520
    //     = 0.8803848 - 0.0209196 - 0.00024 - 0.04652 = 0.8127052
    //   G = -0.004196 + 1.2262716 + 0.0146505 - 0.025677 = 1.2110491
    //   B = -0.0066304 + 0.0337356 + 1.4364 + 0.010549 = 1.4740542
    const Density3 apd = status_m_to_apd(map_5219(), { 0.8, 1.2, 1.5 });
    EXPECT_NEAR(apd[0], 0.8127052, 1e-12);
    EXPECT_NEAR(apd[1], 1.2110491, 1e-12);
    EXPECT_NEAR(apd[2], 1.4740542, 1e-12);
}

TEST(PrintingDensity, AdxIsEquationOneOfS2008002)
{
    // No map (APD = Status M), D-min (0.2, 0.6, 0.85), each channel 0.5
    // above it: CDD = k (APD - APD_Dmin) = (0.5, 0.46, 0.475), ADX16 =
    // 1520 + 8000 CDD = (5520, 5200, 5320), ADX10 = 95 + 500 CDD = (345,
    // 325, 332.5).
    const Density3 dmin = { 0.2, 0.6, 0.85 };
    const AdxTransform t = make_adx_transform(nullptr, { 0, 1, 2 }, dmin, kAdxGains, nullptr);
    EXPECT_FALSE(t.has_map);
    EXPECT_EQ(printing_density_source(t), "status_m (no map)");
    const Density3 cdd = t.cdd({ 0.7, 1.1, 1.35 });
    EXPECT_NEAR(cdd[0], 0.5, 1e-12);
    EXPECT_NEAR(cdd[1], 0.46, 1e-12);
    EXPECT_NEAR(cdd[2], 0.475, 1e-12);
    EXPECT_NEAR(adx_code_value(kAdx16, cdd[0]), 5520.0, 1e-9);
    EXPECT_NEAR(adx_code_value(kAdx16, cdd[1]), 5200.0, 1e-9);
    EXPECT_NEAR(adx_code_value(kAdx16, cdd[2]), 5320.0, 1e-9);
    EXPECT_NEAR(adx_code_value(kAdx10, cdd[2]), 332.5, 1e-9);
    EXPECT_EQ(adx_code_value(kAdx16, kAdxGreyCdd), 7120.0) << "ADX16's 18% grey";
    EXPECT_EQ(adx_code_value(kAdx10, kAdxGreyCdd), 445.0);

    // The buffer encoder, layers stored B, G, R: rounded code values / max.
    AdxTransform bgr = make_adx_transform(nullptr, { 2, 1, 0 }, dmin, kAdxGains, nullptr);
    const float nan  = std::numeric_limits<float>::quiet_NaN();
    const float d[]  = { 1.35f, 1.1f, 0.7f,            // the pixel above
                         0.85f, 0.6f, 0.2f,            // D-min: CDD 0
                         0.85f + 9.0f, 0.6f - 1.0f, nan };  // too dense, too thin, NaN
    float rgb[9];
    EXPECT_EQ(encode_adx(bgr, kAdx16, d, 3, 3, true, rgb), 3u);
    // Float densities: the CDD is within 1e-7 of the above, 8e-4 code values.
    EXPECT_EQ(rgb[0], static_cast<float>(5520.0 / 65535.0));
    EXPECT_EQ(rgb[1], static_cast<float>(5200.0 / 65535.0));
    EXPECT_EQ(rgb[2], static_cast<float>(5320.0 / 65535.0));
    EXPECT_EQ(rgb[3], static_cast<float>(1520.0 / 65535.0));
    EXPECT_EQ(rgb[4], static_cast<float>(1520.0 / 65535.0));
    EXPECT_EQ(rgb[5], static_cast<float>(1520.0 / 65535.0));
    EXPECT_EQ(rgb[6], 0.0f) << "NaN: 0, counted";
    EXPECT_EQ(rgb[7], 0.0f) << "1520 - 7360 < 0: clamped";
    EXPECT_EQ(rgb[8], 1.0f) << "1520 + 8000 * 9 * 0.95 > 65535: clamped";
    // Unrounded (the preview): the code value as it is, nothing clamped.
    EXPECT_EQ(encode_adx(bgr, kAdx10, d, 2, 3, false, rgb), 0u);
    EXPECT_NEAR(rgb[2] * 1023.0, 332.5, 332.5 * 1e-6);
}

TEST(PrintingDensity, TheMapsOffsetCancelsAndItsMatrixMixes)
{
    // With 5219's map, D-min (0.19, 0.58, 0.84) and StM 0.5 above it in
    // every channel: APD - APD_Dmin = M (0.5, 0.5, 0.5) (the offset
    // cancels) = 0.5 * row sums = (0.541444, 0.5132075, 0.4887125); CDD = k
    // times that = (0.541444, 0.4721509, 0.46427688).
    const StatusMToApd m = map_5219();
    const Density3 dmin  = { 0.19, 0.58, 0.84 };
    const AdxTransform t = make_adx_transform(&m, { 0, 1, 2 }, dmin, kAdxGains, nullptr);
    EXPECT_TRUE(t.has_map);
    EXPECT_EQ(printing_density_source(t), "annex_c");
    const Density3 apd_dmin = status_m_to_apd(m, dmin);
    for (size_t c = 0; c < 3; ++c)
        EXPECT_EQ(t.apd_dmin[c], apd_dmin[c]);
    const Density3 cdd = t.cdd({ 0.69, 1.08, 1.34 });
    EXPECT_NEAR(cdd[0], 0.541444, 1e-12);
    EXPECT_NEAR(cdd[1], 0.92 * 0.5132075, 1e-12);
    EXPECT_NEAR(cdd[2], 0.95 * 0.4887125, 1e-12);
    // The same from absolute APD: k (APD(d) - APD(D-min)).
    const Density3 apd = status_m_to_apd(m, { 0.69, 1.08, 1.34 });
    for (size_t c = 0; c < 3; ++c)
        EXPECT_NEAR(cdd[c], kAdxGains[c] * (apd[c] - apd_dmin[c]), 1e-12);
}

TEST(PrintingDensity, GreyTimingPutsTheGreyOnCdd070)
{
    // Grey card at StM (0.95, 1.45, 1.75), D-min (0.19, 0.58, 0.84), 5219's
    // map: untimed CDD = k M (0.76, 0.87, 0.91); timing t = 0.70 - that, so
    // the grey encodes as ADX16 7120 in every channel and D-min as 1520 + 8000 t.
    const StatusMToApd m  = map_5219();
    const Density3 dmin   = { 0.19, 0.58, 0.84 };
    const Density3 grey   = { 0.95, 1.45, 1.75 };
    const AdxTransform un = make_adx_transform(&m, { 0, 1, 2 }, dmin, kAdxGains, nullptr);
    const AdxTransform t  = make_adx_transform(&m, { 0, 1, 2 }, dmin, kAdxGains, &grey);
    EXPECT_EQ(un.timing, AdxTiming::off);
    EXPECT_EQ(t.timing, AdxTiming::grey);
    const Density3 at_grey = t.cdd(grey);
    const Density3 before  = un.cdd(grey);
    // By hand: M (0.76, 0.87, 0.91):
    //   R = 0.83636556 - 0.01516671 - 0.0001456  = 0.82105325
    //   G = -0.0039862 + 0.88904691 + 0.00888797 = 0.89394868
    //   B = -0.00629888 + 0.02445831 + 0.871416  = 0.88957543
    // times k = (0.82105325, 0.822432786, 0.845096659).
    EXPECT_NEAR(before[0], 0.82105325, 1e-12);
    EXPECT_NEAR(before[1], 0.92 * 0.89394868, 1e-12);
    EXPECT_NEAR(before[2], 0.95 * 0.88957543, 1e-12);
    for (size_t c = 0; c < 3; ++c) {
        EXPECT_NEAR(at_grey[c], kAdxGreyCdd, 1e-12);
        EXPECT_NEAR(t.timing_cdd[c], kAdxGreyCdd - before[c], 1e-15);
        EXPECT_NEAR(adx_code_value(kAdx16, at_grey[c]), 7120.0, 1e-8);
        EXPECT_NEAR(t.cdd(dmin)[c], t.timing_cdd[c], 1e-15);
    }
}

TEST(PrintingDensity, TimingWordsAndLayers)
{
    AdxTiming t = AdxTiming::grey;
    EXPECT_TRUE(parse_name("off", t));
    EXPECT_EQ(t, AdxTiming::off);
    EXPECT_TRUE(parse_name("grey", t));
    EXPECT_EQ(t, AdxTiming::grey);
    for (const char* bad : { "", "Grey", "gray", "on", "grey " })
        EXPECT_FALSE(parse_name(bad, t)) << bad;
    EXPECT_STREQ(name_of(AdxTiming::off), "off");

    std::array<int, 3> l {};
    ASSERT_TRUE(printing_density_layers({ "B", "x", "G", "R" }, l));
    EXPECT_EQ(l, (std::array<int, 3> { 3, 2, 0 }));
    ASSERT_TRUE(printing_density_layers({ "Y" }, l));
    EXPECT_EQ(l, (std::array<int, 3> { 0, 0, 0 }));
    const Status s = printing_density_layers({ "R", "G" }, l);
    ASSERT_FALSE(s);
    EXPECT_NE(s.message().find("the stock's layers are R, G (no layer B)"), std::string::npos)
        << s.message();
}

// --- The stock key ----------------------------------------------------------

const char* kRgbLayers = R"("layers": [{"name": "R"}, {"name": "G"}, {"name": "B"}])";

std::string stock_with(const std::string& printing_density, const char* layers = kRgbLayers)
{
    return std::string("{") + layers + R"(, "printing_density": )" + printing_density + "}";
}

const char* kMap = R"({"status_m_to_apd": {"matrix": [[1.1, -0.02, 0], [0, 1.02, 0.01],
                       [-0.01, 0.03, 0.96]], "offset": [-0.05, -0.03, 0.01]}})";

TEST(PrintingDensity, StockKeyParsesAndRoundTrips)
{
    Stock s;
    ASSERT_TRUE(parse_stock_json(stock_with(kMap), "t", s));
    ASSERT_TRUE(s.status_m_to_apd);
    EXPECT_EQ(s.status_m_to_apd->matrix[0][1], -0.02);
    EXPECT_EQ(s.status_m_to_apd->matrix[2][2], 0.96);
    EXPECT_EQ(s.status_m_to_apd->offset[2], 0.01);
    Stock back;
    ASSERT_TRUE(parse_stock_json(stock_to_json(s), "round trip", back));
    ASSERT_TRUE(back.status_m_to_apd);
    EXPECT_EQ(back.status_m_to_apd->matrix, s.status_m_to_apd->matrix);
    EXPECT_EQ(back.status_m_to_apd->offset, s.status_m_to_apd->offset);
    // Absent: no map, and none written.
    Stock plain;
    ASSERT_TRUE(parse_stock_json(std::string("{") + kRgbLayers + "}", "t", plain));
    EXPECT_FALSE(plain.status_m_to_apd);
    EXPECT_EQ(stock_to_json(plain).find("printing_density"), std::string::npos);
}

TEST(PrintingDensity, StockKeyErrorsNameTheKey)
{
    expect_stock_error(stock_with(R"({"status_m_to_apd": {"matrix": [[1,0,0],[0,1,0],[0,0,1]],
                                      "offset": [0,0,0]}, "spectral": 1})"),
                       "unknown key 'printing_density.spectral'");
    expect_stock_error(stock_with(R"({"status_m_to_apd": {"matrix": [[1,0,0],[0,1,0],[0,0,1]]}})"),
                       "printing_density.status_m_to_apd needs offset");
    expect_stock_error(stock_with(R"({"status_m_to_apd": {"matrix": [[1,0,0],[0,1,0]],
                                      "offset": [0,0,0]}})"),
                       "printing_density.status_m_to_apd.matrix must be 3 rows of 3 numbers");
    expect_stock_error(stock_with(R"({"status_m_to_apd": {"matrix": [[1,0,0],[0,1,"x"],[0,0,1]],
                                      "offset": [0,0,0]}})"),
                       "printing_density.status_m_to_apd.matrix[1][2] must be a number");
    expect_stock_error(stock_with(R"({"status_m_to_apd": {"matrix": [[1,0,0],[0,1,0],[0,0,1]],
                                      "offset": [0,0,11.5]}})"),
                       "printing_density.status_m_to_apd.offset[2] = 11.5: must be in [-10, 10]");
    expect_stock_error(stock_with(R"({"status_m_to_apd": {"matrix": [[1,0,0],[0,-20,0],[0,0,1]],
                                      "offset": [0,0,0]}})"),
                       "printing_density.status_m_to_apd.matrix[1][1] = -20: must be in [-10, 10]");
    expect_stock_error(stock_with(kMap, R"("layers": [{"name": "Y"}])"),
                       "printing_density maps the densities of the layers named R, G and B; "
                       "the stock has no layer R");
}

// --- From the stock's expected curves ---------------------------------------

TEST(PrintingDensity, StockTransformTakesDminAndGreyFromTheExpectedCurves)
{
    Stock stock;
    ASSERT_TRUE(load_stock("vision3-500t", stock));
    SceneSettings scene;
    scene.exposure_stops = 1.5;  // timing is the stock's: offset 0 regardless
    AdxOptions o;
    AdxTransform off;
    ASSERT_TRUE(stock_adx_transform(stock, scene, o, off));
    EXPECT_TRUE(off.has_map);
    EXPECT_EQ(off.gains, kAdxGains);
    EXPECT_EQ(off.timing_cdd, (Density3 { 0.0, 0.0, 0.0 }));
    o.timing = AdxTiming::grey;
    AdxTransform grey;
    ASSERT_TRUE(stock_adx_transform(stock, scene, o, grey));
    std::vector<ExpectedCurve> curves;
    SceneSettings rated = scene;
    rated.exposure_stops = 0.0;
    ASSERT_TRUE(expected_curves(stock, rated, ExpectedCurveOptions(), curves));
    for (size_t c = 0; c < 3; ++c) {
        EXPECT_EQ(off.status_m_dmin[c], curves[c].min_density());
        EXPECT_EQ(grey.status_m_dmin[c], curves[c].min_density());
        EXPECT_EQ(grey.status_m_grey[c],
                  curves[c].density_at(0.18 * stock.layers[c].neutral_weight()));
        EXPECT_NEAR(grey.cdd(grey.status_m_grey)[c], kAdxGreyCdd, 1e-12);
    }
    // 500T's grey sits about 0.5-0.7 above D-min in every channel (gamma
    // ~0.5 over ~1.2 decades of exposure above its toe): the lights are a
    // few hundredths to a few tenths of density, not more.
    for (size_t c = 0; c < 3; ++c)
        EXPECT_LT(std::fabs(grey.timing_cdd[c]), 0.3) << c;

    // A one-layer stock: R = G = B from its layer; ADX's gains (output=adx),
    // or (1, 1, 1) for the preview, which then stays neutral.
    Stock paper;
    ASSERT_TRUE(load_stock("paper", paper));
    AdxTransform adx, neutral;
    ASSERT_TRUE(stock_adx_transform(paper, scene, AdxOptions(), adx));
    EXPECT_EQ(adx.layers, (std::array<int, 3> { 0, 0, 0 }));
    EXPECT_EQ(adx.gains, kAdxGains);
    EXPECT_FALSE(adx.has_map);
    AdxOptions preview;
    preview.timing            = AdxTiming::grey;
    preview.neutral_one_layer = true;
    ASSERT_TRUE(stock_adx_transform(paper, scene, preview, neutral));
    EXPECT_EQ(neutral.gains, (Density3 { 1.0, 1.0, 1.0 }));
    for (double above : { 0.0, 0.3, 1.2 }) {
        const double d     = neutral.status_m_dmin[0] + above;
        const Density3 cdd = neutral.cdd({ d, d, d });
        EXPECT_EQ(cdd[0], cdd[1]);
        EXPECT_EQ(cdd[0], cdd[2]);
    }
    // A stock with three layers not named R, G, B: refused, naming them.
    Stock odd = stock;
    odd.layers[0].name = "X";
    odd.status_m_to_apd.reset();
    AdxTransform none;
    const Status s = stock_adx_transform(odd, scene, AdxOptions(), none);
    ASSERT_FALSE(s);
    EXPECT_NE(s.message().find("no layer R"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace filmgrain
