// Tests of stock files (MODEL.md 6): parsing, validation, presets.
#include "filmgrain/stock.h"

#include <gtest/gtest.h>

#include "testing/test_stock_json.h"

namespace filmgrain {
namespace {

TEST(Stock, PresetsParseAndValidate)
{
    const auto names = preset_names();
    ASSERT_GE(names.size(), 2u);
    EXPECT_EQ(names.front(), default_preset_name());
    for (const auto& name : names) {
        Stock s;
        ASSERT_TRUE(load_stock(name, s)) << name;
        EXPECT_EQ(s.name, name);
        EXPECT_TRUE(s.validate());
    }
    Stock paper;
    ASSERT_TRUE(load_stock("paper", paper));
    ASSERT_EQ(paper.layers.size(), 1u);
    EXPECT_EQ(paper.layers[0].populations[0].diameter_um, 6.0);
    EXPECT_EQ(paper.layers[0].populations[0].grains_per_um2, 0.1);
    Stock color;
    ASSERT_TRUE(load_stock(default_preset_name(), color));
    ASSERT_EQ(color.layers.size(), 3u);
    EXPECT_EQ(color.layers[0].name, "R");
    EXPECT_EQ(color.layers[1].name, "G");
    EXPECT_EQ(color.layers[2].name, "B");
}

TEST(Stock, JsonRoundTrip)
{
    Stock a;
    ASSERT_TRUE(load_stock("color-negative", a));
    Stock b;
    ASSERT_TRUE(parse_stock_json(stock_to_json(a), "round trip", b));
    EXPECT_EQ(stock_to_json(a), stock_to_json(b));
}

TEST(Stock, AbsentKeysTakeDefaults)
{
    Stock s;
    ASSERT_TRUE(parse_stock_json(R"({"layers": [{"name": "Y", "populations": [{}]}]})", "t", s));
    const Stock defaults;
    EXPECT_EQ(s.development_time_s, defaults.development_time_s);
    EXPECT_EQ(s.layers[0].populations[0].k_pair_per_s, Population().k_pair_per_s);
}

TEST(Stock, ErrorsNameTheKeyValueAndRange)
{
    expect_stock_error("{", "not valid JSON");
    expect_stock_error("[]", "must be a JSON object");
    expect_stock_error(R"({"speed": 100})", "unknown key 'speed'");
    expect_stock_error(R"({"layers": [{"name": "Y", "colour": 1}]})", "unknown key 'layers[0].colour'");
    expect_stock_error(R"({"layers": [{"populations": [{"diameter": 3}]}]})",
                 "unknown key 'layers[0].populations[0].diameter'");
    expect_stock_error(R"({"fog_tau_s": "slow"})", "fog_tau_s must be a number, not string");
    expect_stock_error(R"({"layers": [{"populations": [{"diameter_um": -1}]}]})",
                 "layers[0].populations[0].diameter_um = -1: must be in [0.01, 1000]");
    expect_stock_error(R"({"max_density": 0})", "max_density = 0: must be in (0, 20]");
    expect_stock_error(R"({"layers": [{"sensitivity": [1, 2]}]})", "sensitivity must be an array of 3");
    expect_stock_error(R"({"layers": [{"sensitivity": [0, 0, 0]}]})", "all zero");
    expect_stock_error(R"({"layers": [{"name": "A"}, {"name": "A"}]})", "repeats");
    expect_stock_error(R"({"layers": []})", "layers has 0 entries");
    expect_stock_error(R"({"layers": [{"populations": []}]})", "populations has 0 entries");
    expect_stock_error(R"({"name": 5})", "name must be a string");
    expect_stock_error(R"({"layers": {}})", "layers must be an array");
    expect_stock_error(R"({"layers": [{"populations": [{"quantum_efficiency": 1.5}]}]})",
                 "quantum_efficiency = 1.5: must be in [0, 1]");
    expect_stock_error(R"({"exposure_at_grey_lxs": true})", "must be a number, not boolean");
    // Numbers in the fewest digits that read back as themselves.
    expect_stock_error(R"({"layers": [{"populations": [{"quantum_efficiency": 1.4}]}]})",
                 "quantum_efficiency = 1.4: must be in [0, 1]");
    expect_stock_error(R"({"layers": [{"populations": [{"quantum_efficiency": 1.0000000000000002}]}]})",
                 "quantum_efficiency = 1.0000000000000002: must be in [0, 1]");
    expect_stock_error(R"({"exposure_at_grey_lxs": 2e6})",
                 "exposure_at_grey_lxs = 2000000: must be in (0, 1000000]");
    expect_stock_error(R"({"exposure_at_grey_lxs": -2.5e-7})", "exposure_at_grey_lxs = -2.5e-07");
}

TEST(Stock, UnknownPresetOrMissingFile)
{
    Stock s;
    const Status st = load_stock("/no/such/stock.json", s);
    ASSERT_FALSE(st);
    EXPECT_NE(st.message().find("/no/such/stock.json"), std::string::npos);
    EXPECT_NE(st.message().find("paper"), std::string::npos);  // lists the presets
}

}  // namespace
}  // namespace filmgrain
