// Tests of the --filmgrain / -o modifier parser (modifiers.h): every
// modifier, every documented error, and a random-input smoke test that
// stands in for the future libFuzzer target (no crash, no exception).
#include "modifiers.h"

#include <gtest/gtest.h>

#include <random>
#include <string>

namespace filmgrain::cli {
namespace {

FilmgrainCommand parse_ok(const std::string& arg)
{
    FilmgrainCommand cmd;
    const Status s = parse_filmgrain_modifiers(arg, cmd);
    EXPECT_TRUE(s.ok()) << arg << ": " << s.message();
    return cmd;
}

/// Parses `arg`, expects failure, and returns the message.
std::string parse_error(const std::string& arg)
{
    FilmgrainCommand cmd;
    cmd.scene.seed = 12345;  // must survive a failed parse
    const Status s = parse_filmgrain_modifiers(arg, cmd);
    EXPECT_FALSE(s.ok()) << arg << " parsed";
    EXPECT_EQ(cmd.scene.seed, 12345u) << "out changed on failure: " << arg;
    return s.message();
}

TEST(Modifiers, NoModifiersMeansDefaults)
{
    const FilmgrainCommand d;
    FilmgrainCommand cmd;
    cmd.scene.seed = 99;
    ASSERT_TRUE(parse_filmgrain_modifiers("--filmgrain", cmd).ok());
    EXPECT_EQ(cmd.stock, default_preset_name());
    EXPECT_EQ(cmd.scene.seed, d.scene.seed);
    EXPECT_EQ(cmd.scene.exposure_stops, SceneSettings().exposure_stops);
    EXPECT_EQ(cmd.scene.shutter_s, SceneSettings().shutter_s);
    EXPECT_EQ(cmd.scene.width_mm, SceneSettings().width_mm);
    EXPECT_EQ(cmd.tile_size_px, RenderSettings().tile_size_px);
    EXPECT_EQ(cmd.scan_width, 0);
    EXPECT_FALSE(cmd.has_roi);
}

TEST(Modifiers, EveryModifier)
{
    const FilmgrainCommand c = parse_ok(
        "--filmgrain:stock=paper:exposure_stops=-1.5:shutter_s=0.01:seed=18446744073709551615"
        ":width_mm=0.5:scan=640x480:roi=1,2,3,4:engine=exact:tile=16");
    EXPECT_EQ(c.stock, "paper");
    EXPECT_EQ(c.scene.exposure_stops, -1.5);
    EXPECT_EQ(c.scene.shutter_s, 0.01);
    EXPECT_EQ(c.scene.seed, 18446744073709551615ull);
    EXPECT_EQ(c.scene.width_mm, 0.5);
    EXPECT_EQ(c.scan_width, 640);
    EXPECT_EQ(c.scan_height, 480);
    EXPECT_TRUE(c.has_roi);
    EXPECT_EQ(c.roi_x, 1);
    EXPECT_EQ(c.roi_y, 2);
    EXPECT_EQ(c.roi_width, 3);
    EXPECT_EQ(c.roi_height, 4);
    EXPECT_EQ(c.engine_options.engine, Engine::exact);
    EXPECT_EQ(c.tile_size_px, 16);
}

TEST(Modifiers, Forms)
{
    EXPECT_EQ(parse_ok("--filmgrain:scan=320").scan_width, 320);
    EXPECT_EQ(parse_ok("--filmgrain:scan=320").scan_height, 0);
    EXPECT_DOUBLE_EQ(parse_ok("--filmgrain:shutter_s=1/48").scene.shutter_s, 1.0 / 48.0);
    EXPECT_EQ(parse_ok("--filmgrain:exposure_stops=+2").scene.exposure_stops, 2.0);
    EXPECT_EQ(parse_ok("--filmgrain:exposure_stops=1e-1").scene.exposure_stops, 0.1);
    EXPECT_EQ(parse_ok("--filmgrain:stock=dir/my=stock.json").stock, "dir/my=stock.json");
    EXPECT_EQ(parse_ok("--filmgrain:roi=0,0,1,1").roi_width, 1);
    EXPECT_EQ(parse_ok("--filmgrain:roi=-16,-8,1,1").roi_x, -16);
    EXPECT_EQ(parse_ok("--filmgrain:roi=-16,-8,1,1").roi_y, -8);
    EXPECT_FALSE(parse_ok("--filmgrain").scene.frame.has_value());
    EXPECT_EQ(parse_ok("--filmgrain:frame=1001").scene.frame, 1001);
    EXPECT_EQ(parse_ok("--filmgrain:frame=-5").scene.frame, -5);
    EXPECT_EQ(parse_ok("--filmgrain:frame=1000000000").scene.frame, 1000000000);
    EXPECT_TRUE(parse_ok("--filmgrain:frame=1:static_grain=1").scene.static_grain);
    EXPECT_FALSE(parse_ok("--filmgrain:static_grain=0").scene.static_grain);
    EXPECT_EQ(parse_ok("--filmgrain:edge=gate").scene.edge, FrameEdge::gate);
    EXPECT_EQ(parse_ok("--filmgrain").scene.edge, FrameEdge::clamp);
}

TEST(Modifiers, UnknownModifierNamesItAndListsTheValidOnes)
{
    const std::string m = parse_error("--filmgrain:exposur=1");
    EXPECT_NE(m.find("unknown modifier 'exposur'"), std::string::npos) << m;
    for (const auto& doc : filmgrain_modifier_docs())
        EXPECT_NE(m.find(doc.key), std::string::npos) << m;
}

TEST(Modifiers, BadValuesNameKeyValueAndForm)
{
    struct Case {
        const char* arg;
        const char* expect[3];
    };
    const Case cases[] = {
        { "--filmgrain:exposure_stops=abc", { "exposure_stops=abc", "not a decimal number", "STOPS" } },
        { "--filmgrain:exposure_stops=nan", { "exposure_stops=nan", "finite", "STOPS" } },
        { "--filmgrain:exposure_stops=inf", { "exposure_stops=inf", "finite", "STOPS" } },
        { "--filmgrain:exposure_stops=-infinity", { "exposure_stops=-infinity", "finite", "STOPS" } },
        { "--filmgrain:exposure_stops=1e999", { "exposure_stops=1e999", "range", "STOPS" } },
        { "--filmgrain:exposure_stops= 1", { "exposure_stops= 1", "not a decimal", "STOPS" } },
        { "--filmgrain:exposure_stops=1x", { "exposure_stops=1x", "not a decimal", "STOPS" } },
        { "--filmgrain:exposure_stops=+-1", { "exposure_stops=+-1", "not a decimal", "STOPS" } },
        { "--filmgrain:exposure_stops=100", { "exposure_stops = 100", "[-64, 64]", "" } },
        { "--filmgrain:seed=-1", { "seed=-1", "whole number", "N" } },
        { "--filmgrain:seed=1.5", { "seed=1.5", "whole number", "N" } },
        { "--filmgrain:seed=18446744073709551616", { "seed=18446744073709551616", "too large", "" } },
        { "--filmgrain:seed=+1", { "seed=+1", "whole number", "" } },
        { "--filmgrain:frame=1000000001", { "frame=1000000001", "too large", "[-1000000000" } },
        { "--filmgrain:frame=1.5", { "frame=1.5", "whole number", "N" } },
        { "--filmgrain:frame=--1", { "frame=--1", "whole number", "N" } },
        { "--filmgrain:static_grain=2", { "static_grain=2", "0 or 1", "0|1" } },
        { "--filmgrain:edge=wrap", { "edge=wrap", "clamp or gate", "clamp|gate" } },
        { "--filmgrain:scan=0x0", { "scan=0x0", "at least 1", "WxH" } },
        { "--filmgrain:scan=10x", { "scan=10x", "height", "WxH" } },
        { "--filmgrain:scan=x10", { "scan=x10", "width", "WxH" } },
        { "--filmgrain:scan=10x10x10", { "scan=10x10x10", "height", "WxH" } },
        { "--filmgrain:scan=3000000000", { "scan=3000000000", "too large", "WxH" } },
        { "--filmgrain:roi=0,0,0,10", { "roi=0,0,0,10", "width", "at least 1" } },
        { "--filmgrain:roi=--1,0,5,5", { "roi=--1,0,5,5", "x:", "X,Y,W,H" } },
        { "--filmgrain:roi=0,0,-5,5", { "roi=0,0,-5,5", "width:", "X,Y,W,H" } },
        { "--filmgrain:roi=0,0,5", { "roi=0,0,5", "four numbers", "X,Y,W,H" } },
        { "--filmgrain:roi=0,0,5,5,5", { "roi=0,0,5,5,5", "four numbers", "X,Y,W,H" } },
        { "--filmgrain:roi=2147483647,0,1,1", { "roi=", "x + width", "" } },
        { "--filmgrain:shutter_s=0", { "shutter_s = 0", "(0, 1e7]", "" } },
        { "--filmgrain:shutter_s=1/0", { "shutter_s=1/0", "division by zero", "SECONDS" } },
        { "--filmgrain:shutter_s=1/x", { "shutter_s=1/x", "fraction", "SECONDS" } },
        { "--filmgrain:width_mm=-3", { "width_mm = -3", "(0, 1e9]", "" } },
        { "--filmgrain:engine=quick", { "engine=quick", "unknown engine", "exact" } },
        { "--filmgrain:tolerance=0", { "tolerance=0", "(0, 1]", "" } },
        { "--filmgrain:tolerance=abc", { "tolerance=abc", "not a decimal", "" } },
        { "--filmgrain:kinetics=magic", { "kinetics=magic", "unknown kinetics", "table" } },
        { "--filmgrain:photons=edge", { "photons=edge", "unknown exposure sampling", "centre" } },
        { "--filmgrain:coverage=fuzzy", { "coverage=fuzzy", "unknown coverage", "scanline" } },
        { "--filmgrain:samples=0", { "samples=0", "at least 1", "" } },
        { "--filmgrain:samples=300", { "samples=300", "at most 256", "" } },
        { "--filmgrain:tile=0", { "tile=0", "at least 1", "" } },
        { "--filmgrain:tile=5000", { "tile=5000", "at most 4096", "" } },
        { "--filmgrain:exposure_stops=", { "exposure_stops=", "empty value", "STOPS" } },
        { "--filmgrain:stock=", { "stock=", "empty value", "NAME|FILE" } },
        { "--filmgrain:seed=1:seed=2", { "'seed' given twice", "seed=1", "seed=2" } },
        { "--filmgrain:seed", { "'seed'", "no value", "key=value" } },
        { "--filmgrain:", { "empty modifier", "", "" } },
        { "--filmgrain::seed=1", { "empty modifier", "", "" } },
        { "--filmgrain:seed=1:", { "empty modifier", "", "" } },
        { "--filmgrain:=1", { "no key", "", "" } },
    };
    for (const Case& c : cases) {
        const std::string m = parse_error(c.arg);
        for (const char* e : c.expect)
            EXPECT_NE(m.find(e), std::string::npos) << c.arg << " -> " << m << " (want: " << e
                                                    << ")";
        EXPECT_EQ(m.rfind("--filmgrain: ", 0), 0u) << m;
    }
}

TEST(Modifiers, DocsCoverEveryModifierWithItsDefault)
{
    const auto docs = filmgrain_modifier_docs();
    const char* keys[] = { "stock",    "exposure_stops", "shutter_s", "seed",     "frame",
                           "static_grain",   "edge",     "width_mm",
                           "scan",     "roi",      "engine",  "tolerance", "kinetics",
                           "photons",  "coverage", "grains",  "scale",    "samples",
                           "tile",     "output",   "timing" };
    ASSERT_EQ(docs.size(), std::size(keys));
    for (size_t i = 0; i < docs.size(); ++i) {
        EXPECT_EQ(docs[i].key, keys[i]);
        EXPECT_FALSE(docs[i].default_text.empty()) << docs[i].key;
        EXPECT_FALSE(docs[i].help.empty()) << docs[i].key;
        // Every documented modifier parses.
        FilmgrainCommand cmd;
        EXPECT_FALSE(parse_filmgrain_modifiers("--filmgrain:" + docs[i].key + "=", cmd).ok());
    }
    const auto default_of = [&docs](const std::string& key) {
        for (const ModifierDoc& d : docs)
            if (d.key == key)
                return d.default_text;
        return std::string("(no such modifier)");
    };
    EXPECT_EQ(default_of("stock"), default_preset_name());
    EXPECT_EQ(default_of("shutter_s"), "0.0208333 (1/48)");
    EXPECT_EQ(default_of("engine"), name_of(RenderSettings().engine));
    EXPECT_EQ(default_of("tile"), std::to_string(RenderSettings().tile_size_px));
    EXPECT_EQ(default_of("static_grain"), "0");
    EXPECT_EQ(default_of("edge"), "clamp");
}

TEST(Modifiers, RenamedModifiersAreReadUnderTheirOldNamesWithANotice)
{
    FilmgrainCommand now, old;
    ASSERT_TRUE(parse_filmgrain_modifiers(
        "--filmgrain:exposure_stops=1.5:shutter_s=1/24:frame=3:static_grain=1", now));
    EXPECT_TRUE(now.notices.empty());
    ASSERT_TRUE(parse_filmgrain_modifiers("--filmgrain:exposure=1.5:shutter=1/24:frame=3:static=1",
                                          old));
    EXPECT_EQ(old.scene.exposure_stops, now.scene.exposure_stops);
    EXPECT_EQ(old.scene.shutter_s, now.scene.shutter_s);
    EXPECT_EQ(old.scene.static_grain, now.scene.static_grain);
    ASSERT_EQ(old.notices.size(), 3u);
    EXPECT_EQ(old.notices[0], "exposure= is now exposure_stops= (the old name is still read)");
    EXPECT_EQ(renamed_modifiers().size(), 3u);
    for (const RenamedModifier& r : renamed_modifiers()) {
        // The old name and the new one together: one modifier given twice.
        FilmgrainCommand both;
        const Status s = parse_filmgrain_modifiers(
            std::string("--filmgrain:") + r.old_key + "=1:" + r.key + "=1", both);
        ASSERT_FALSE(s.ok()) << r.old_key;
        EXPECT_NE(s.message().find("given twice"), std::string::npos) << s.message();
        // An error quotes the name the user wrote.
        FilmgrainCommand bad;
        const Status e = parse_filmgrain_modifiers(
            std::string("--filmgrain:") + r.old_key + "=x", bad);
        EXPECT_NE(e.message().find(std::string(r.old_key) + "=x"), std::string::npos)
            << e.message();
    }
}

TEST(Modifiers, OutputModifiers)
{
    OutputModifiers o;
    ASSERT_TRUE(parse_output_modifiers("-o", o).ok());
    EXPECT_EQ(o.compression, "piz");
    ASSERT_TRUE(parse_output_modifiers("-o:compression=zip", o).ok());
    EXPECT_EQ(o.compression, "zip");
    Status s = parse_output_modifiers("-o:compression=jpeg", o);
    EXPECT_FALSE(s.ok());
    EXPECT_NE(s.message().find("compression=jpeg"), std::string::npos) << s.message();
    EXPECT_EQ(o.compression, "zip");
    s = parse_output_modifiers("-o:bits=8", o);
    EXPECT_NE(s.message().find("unknown modifier 'bits'"), std::string::npos) << s.message();
}

TEST(Modifiers, MessagesQuoteInputSafely)
{
    std::string arg = "--filmgrain:exposure_stops=";
    arg += std::string("\x01\xff\n", 3);
    arg += std::string(1000, 'z');
    const std::string m = parse_error(arg);
    EXPECT_NE(m.find("\\x01\\xff\\x0a"), std::string::npos) << m;
    EXPECT_LT(m.size(), 600u) << "long input is truncated in messages";
}

/// Random and mutated inputs: the parser must return (ok or not) without
/// crashing or throwing. Run under ASan/UBSan for the full value.
TEST(Modifiers, RandomInputsNeverCrash)
{
    std::mt19937_64 rng(1);
    const std::string alphabet = "0123456789:=,x/.-+eE abcdefghijklmnopqrstuvwxyz_\x00\xff";
    const std::string seeds[] = {
        "--filmgrain:stock=paper:exposure_stops=1:shutter_s=1/48:seed=7:width_mm=0.5",
        "--filmgrain:scan=64x48:roi=1,2,3,4:engine=exact:tile=8",
    };
    for (int i = 0; i < 20000; ++i) {
        std::string s;
        if (i % 2) {
            const size_t n = rng() % 64;
            for (size_t k = 0; k < n; ++k)
                s += alphabet[rng() % alphabet.size()];
        } else {
            s = seeds[rng() % 2];
            for (int m = 0; m < 3; ++m)
                s[rng() % s.size()] = alphabet[rng() % alphabet.size()];
        }
        FilmgrainCommand cmd;
        OutputModifiers out;
        EXPECT_NO_THROW({
            (void)parse_filmgrain_modifiers(s, cmd);
            (void)parse_output_modifiers(s, out);
        });
    }
}

}  // namespace
}  // namespace filmgrain::cli

namespace filmgrain::cli {
namespace {

TEST(Modifiers, OutputKind)
{
    EXPECT_EQ(FilmgrainCommand().output, OutputKind::density);
    EXPECT_EQ(parse_ok("--filmgrain:output=density").output, OutputKind::density);
    EXPECT_EQ(parse_ok("--filmgrain:output=adx10").output, OutputKind::adx10);
    EXPECT_EQ(parse_ok("--filmgrain:output=adx16").output, OutputKind::adx16);
    EXPECT_EQ(parse_ok("--filmgrain:output=regrain:seed=3").output, OutputKind::regrain);
    const std::string e = parse_error("--filmgrain:output=ADX16");
    EXPECT_NE(e.find("output=ADX16: unknown output (known: density, adx10, adx16, regrain)"),
              std::string::npos)
        << e;
    bool documented = false;
    for (const ModifierDoc& d : filmgrain_modifier_docs())
        documented |= d.key == "output" && d.default_text == "density"
                      && d.form == "density|adx10|adx16|regrain";
    EXPECT_TRUE(documented);
}

TEST(Modifiers, AdxTiming)
{
    EXPECT_EQ(FilmgrainCommand().timing, AdxTiming::off);
    EXPECT_EQ(parse_ok("--filmgrain:output=adx16:timing=grey").timing, AdxTiming::grey);
    EXPECT_EQ(parse_ok("--filmgrain:output=adx10:timing=off").timing, AdxTiming::off);
    for (const char* bad : { "gray", "Grey", "on", "1" }) {
        const std::string e = parse_error(std::string("--filmgrain:timing=") + bad);
        EXPECT_NE(e.find(std::string("timing=") + bad + ": unknown timing (known: off, grey)"),
                  std::string::npos)
            << e;
    }
    bool documented = false;
    for (const ModifierDoc& d : filmgrain_modifier_docs())
        documented |= d.key == "timing" && d.default_text == "off" && d.form == "off|grey";
    EXPECT_TRUE(documented);
}

}  // namespace
}  // namespace filmgrain::cli
