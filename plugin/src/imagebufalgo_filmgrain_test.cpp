// Tests of the ImageBufAlgo-style operator (imagebufalgo_filmgrain.h): the
// adapter's own duties (packing src, windows, channel names, metadata, ROI,
// errors on dst); the physics is tested in core/.
#include "filmgrain/imagebufalgo_filmgrain.h"

#include <gtest/gtest.h>

#include <OpenImageIO/imagebufalgo.h>

#include <cmath>
#include <limits>

#include "filmgrain/version.h"

namespace filmgrain {
namespace {

/// A small, fast render: 0.3 mm frame.
FilmgrainOptions small_options()
{
    FilmgrainOptions o;
    o.scene.width_mm = 0.3;
    o.scene.seed           = 7;
    return o;
}

OIIO::ImageBuf grey_ramp(int w, int h, int nchannels)
{
    OIIO::ImageBuf buf(OIIO::ImageSpec(w, h, nchannels, OIIO::TypeFloat));
    for (OIIO::ImageBuf::Iterator<float> it(buf); !it.done(); ++it)
        for (int c = 0; c < nchannels; ++c)
            it[c] = 0.02f * static_cast<float>(it.x() + 1) * (c == 0 ? 1.0f : 0.8f);
    return buf;
}

TEST(Operator, DefaultOptionsAreTheDefaultPreset)
{
    const FilmgrainOptions o;
    Stock preset;
    ASSERT_TRUE(load_stock(default_preset_name(), preset).ok());
    EXPECT_EQ(o.stock.name, preset.name);
    EXPECT_EQ(stock_to_json(o.stock), stock_to_json(preset));
    EXPECT_EQ(o.tile_size_px, RenderSettings().tile_size_px);
    EXPECT_EQ(o.scene.seed, SceneSettings().seed);
}

TEST(Operator, ChannelsWindowsAndMetadata)
{
    const OIIO::ImageBuf src = grey_ramp(16, 12, 3);
    FilmgrainOptions opts    = small_options();
    OIIO::ImageBuf dst;
    RenderStats stats;
    opts.stats = &stats;
    ASSERT_TRUE(IBA::filmgrain(dst, src, opts)) << dst.geterror();
    const OIIO::ImageSpec& spec = dst.spec();
    ASSERT_EQ(spec.nchannels, static_cast<int>(opts.stock.layers.size()));
    for (int c = 0; c < spec.nchannels; ++c)
        EXPECT_EQ(spec.channelnames[c], opts.stock.layers[c].name);
    EXPECT_EQ(spec.format, OIIO::TypeFloat);
    EXPECT_EQ(dst.roi(), OIIO::ROI(0, 16, 0, 12, 0, 1, 0, spec.nchannels));
    EXPECT_EQ(dst.roi_full(), dst.roi());
    EXPECT_EQ(spec.get_string_attribute("filmgrain:quantity"), kFilmgrainQuantity);
    EXPECT_EQ(spec.get_string_attribute("filmgrain:stock"), stock_to_json(opts.stock));
    EXPECT_EQ(spec.get_string_attribute("filmgrain:stock_name"), opts.stock.name);
    EXPECT_EQ(spec.get_string_attribute("filmgrain:seed"), "7");
    EXPECT_EQ(spec.get_float_attribute("filmgrain:width_mm"), 0.3f);
    EXPECT_EQ(spec.get_float_attribute("filmgrain:exposure_stops", -1.f), 0.f);
    EXPECT_EQ(spec.get_float_attribute("filmgrain:shutter_s"),
              static_cast<float>(opts.scene.shutter_s));
    EXPECT_EQ(spec.get_string_attribute("filmgrain:engine"), name_of(opts.engine_options.engine));
    EXPECT_EQ(spec.get_string_attribute("filmgrain:version"), version_string());
    ASSERT_EQ(stats.layers.size(), opts.stock.layers.size());
    EXPECT_EQ(stats.input.pixels_read, 16u * 12u);
}

TEST(Operator, SeedIsA64BitDecimalString)
{
    FilmgrainOptions opts = small_options();
    opts.scene.seed       = 18446744073709551615ull;
    OIIO::ImageBuf dst    = IBA::filmgrain(grey_ramp(4, 3, 1), opts);
    ASSERT_FALSE(dst.has_error()) << dst.geterror();
    EXPECT_EQ(dst.spec().get_string_attribute("filmgrain:seed"), "18446744073709551615");
}

TEST(Operator, RoiIsTheDataWindowAndMatchesTheFullRender)
{
    const OIIO::ImageBuf src  = grey_ramp(16, 12, 1);
    const FilmgrainOptions o  = small_options();
    const OIIO::ImageBuf full = IBA::filmgrain(src, o);
    ASSERT_FALSE(full.has_error()) << full.geterror();
    const OIIO::ROI roi(3, 11, 2, 9);
    OIIO::ImageBuf part;
    ASSERT_TRUE(IBA::filmgrain(part, src, o, roi, 1)) << part.geterror();
    EXPECT_EQ(part.spec().x, 3);
    EXPECT_EQ(part.spec().y, 2);
    EXPECT_EQ(part.spec().width, 8);
    EXPECT_EQ(part.spec().height, 7);
    EXPECT_EQ(part.spec().full_width, 16);
    EXPECT_EQ(part.spec().full_height, 12);
    // Determinism across ROI and thread count: bit-identical pixels.
    for (OIIO::ImageBuf::ConstIterator<float> it(part); !it.done(); ++it)
        for (int c = 0; c < part.nchannels(); ++c)
            ASSERT_EQ(it[c], full.getchannel(it.x(), it.y(), 0, c)) << it.x() << "," << it.y();
}

TEST(Operator, ScanSizeDiffersFromInput)
{
    FilmgrainOptions o = small_options();
    o.scan_width       = 8;  // height from the frame's aspect: 6
    const OIIO::ImageBuf dst = IBA::filmgrain(grey_ramp(16, 12, 3), o);
    ASSERT_FALSE(dst.has_error()) << dst.geterror();
    EXPECT_EQ(dst.spec().width, 8);
    EXPECT_EQ(dst.spec().height, 6);
}

TEST(Operator, GreyEqualsRgbWithEqualChannels)
{
    OIIO::ImageBuf grey = grey_ramp(8, 6, 1);
    const int order[3]  = { 0, 0, 0 };
    OIIO::ImageBuf rgb  = OIIO::ImageBufAlgo::channels(grey, 3, order);
    const FilmgrainOptions o = small_options();
    const OIIO::ImageBuf a = IBA::filmgrain(grey, o);
    const OIIO::ImageBuf b = IBA::filmgrain(rgb, o);
    ASSERT_FALSE(a.has_error() || b.has_error());
    const auto cmp = OIIO::ImageBufAlgo::compare(a, b, 0.0f, 0.0f);
    EXPECT_EQ(cmp.maxerror, 0.0);
}

TEST(Operator, DstMayAliasSrc)
{
    OIIO::ImageBuf buf       = grey_ramp(8, 6, 3);
    const FilmgrainOptions o = small_options();
    const OIIO::ImageBuf expected = IBA::filmgrain(buf, o);
    ASSERT_TRUE(IBA::filmgrain(buf, buf, o)) << buf.geterror();
    EXPECT_EQ(OIIO::ImageBufAlgo::compare(buf, expected, 0.0f, 0.0f).maxerror, 0.0);
}

TEST(Operator, NonFinitePixelsAreCountedAndOutputIsFinite)
{
    OIIO::ImageBuf src = grey_ramp(8, 6, 3);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    const float bad1[3] = { nan, 0.1f, 0.1f }, bad2[3] = { inf, inf, -inf };
    src.setpixel(1, 1, bad1);
    src.setpixel(5, 4, bad2);
    RenderStats stats;
    OIIO::ImageBuf dst;
    FilmgrainOptions with_stats = small_options();
    with_stats.stats            = &stats;
    ASSERT_TRUE(IBA::filmgrain(dst, src, with_stats)) << dst.geterror();
    EXPECT_EQ(stats.input.nonfinite_pixels, 2u);
    for (OIIO::ImageBuf::ConstIterator<float> it(dst); !it.done(); ++it)
        for (int c = 0; c < dst.nchannels(); ++c)
            ASSERT_TRUE(std::isfinite(it[c]));
}

TEST(Operator, ErrorsGoOnDst)
{
    const FilmgrainOptions o = small_options();
    OIIO::ImageBuf dst;

    EXPECT_FALSE(IBA::filmgrain(dst, grey_ramp(4, 4, 2), o));
    EXPECT_NE(dst.geterror().find("2 channels"), std::string::npos);

    EXPECT_FALSE(IBA::filmgrain(dst, OIIO::ImageBuf(), o));
    EXPECT_NE(dst.geterror().find("empty"), std::string::npos);

    EXPECT_FALSE(IBA::filmgrain(dst, grey_ramp(4, 4, 1), o, OIIO::ROI(2, 6, 0, 4)));
    EXPECT_NE(dst.geterror().find("inside the 4x4 scan"), std::string::npos);

    FilmgrainOptions bad = o;
    bad.stock.layers[0].populations[0].diameter_um = -1.0;
    EXPECT_FALSE(IBA::filmgrain(dst, grey_ramp(4, 4, 1), bad));
    EXPECT_NE(dst.geterror().find("diameter_um"), std::string::npos);

    bad = o;
    bad.scene.exposure_stops = std::numeric_limits<double>::quiet_NaN();
    const OIIO::ImageBuf r = IBA::filmgrain(grey_ramp(4, 4, 1), bad);
    EXPECT_TRUE(r.has_error());
    EXPECT_NE(r.geterror().find("exposure"), std::string::npos);

    bad = o;
    bad.scan_width = int64_t(1) << 33;
    EXPECT_FALSE(IBA::filmgrain(dst, grey_ramp(4, 4, 1), bad));
    EXPECT_NE(dst.geterror().find("at most"), std::string::npos);
}

TEST(Operator, CancelViaProgress)
{
    FilmgrainOptions o     = small_options();
    o.scene.width_mm = 3.0;  // slow enough to be cancelled
    o.tile_size_px         = 4;
    o.progress             = [](double) { return false; };
    for (const char* stock : { "color-negative", "vision3-500t" }) {
        // Cancelled at the first poll, wherever the render is: vision3-500t
        // spends seconds building its tables (inhibition, P(develop | N))
        // and then draws its 47 um pixels in milliseconds, so only a
        // planning phase that polls can cancel it.
        ASSERT_TRUE(load_stock(stock, o.stock));
        OIIO::ImageBuf dst;
        EXPECT_FALSE(IBA::filmgrain(dst, grey_ramp(64, 48, 3), o, {}, 1)) << stock;
        EXPECT_NE(dst.geterror().find("cancelled"), std::string::npos) << stock;
    }
}

}  // namespace
}  // namespace filmgrain
