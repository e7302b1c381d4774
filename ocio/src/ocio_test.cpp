// filmgrain: unit tests of the OpenColorIO input conversion (filmgrain/ocio.h).
#include <filmgrain/ocio.h>

#include <OpenColorIO/OpenColorIO.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

namespace OCIO = OCIO_NAMESPACE;
namespace fs   = std::filesystem;
using filmgrain::Status;
using filmgrain::ocio::ConfigInfo;
using filmgrain::ocio::InputConverter;

namespace {

/// Sets or unsets $OCIO for the lifetime of the guard, then restores it.
class OcioEnvGuard {
public:
    explicit OcioEnvGuard(const std::optional<std::string>& value)
    {
        if (const char* old = std::getenv("OCIO"))
            m_saved = old;
        set(value);
    }
    ~OcioEnvGuard() { set(m_saved); }
    OcioEnvGuard(const OcioEnvGuard&)            = delete;
    OcioEnvGuard& operator=(const OcioEnvGuard&) = delete;

private:
    static void set(const std::optional<std::string>& value)
    {
        if (value)
            setenv("OCIO", value->c_str(), 1);
        else
            unsetenv("OCIO");
    }
    std::optional<std::string> m_saved;
};

/// Every test starts without $OCIO, whatever the caller's environment, so the
/// embedded config is used unless the test says otherwise.
class OcioTest : public ::testing::Test {
protected:
    OcioEnvGuard m_no_ocio { std::nullopt };
};

/// A temporary directory removed at the end of the test.
class TempDir {
public:
    explicit TempDir(const std::string& tag)
    {
        m_path = fs::temp_directory_path()
                 / ("filmgrain_ocio_test_" + tag + "_"
                    + std::to_string(::getpid()));
        fs::remove_all(m_path);
        fs::create_directories(m_path);
    }
    ~TempDir()
    {
        std::error_code ec;
        fs::remove_all(m_path, ec);
    }
    const fs::path& path() const { return m_path; }

private:
    fs::path m_path;
};

/// A small user config: scene_linear is "my_lin"; "my_log" is log10 encoded
/// (my_log value v decodes to 10^v).
const char* const k_user_config = R"(ocio_profile_version: 2

roles:
  default: my_lin
  scene_linear: my_lin

file_rules:
  - !<Rule> {name: Default, colorspace: default}

displays:
  None:
    - !<View> {name: Raw, colorspace: my_lin}

colorspaces:
  - !<ColorSpace>
    name: my_lin
  - !<ColorSpace>
    name: my_log
    to_scene_reference: !<LogTransform> {base: 10, direction: inverse}
)";

std::string write_file(const fs::path& path, const std::string& text)
{
    std::ofstream out(path);
    out << text;
    return path.string();
}

std::unique_ptr<InputConverter> make(const std::string& config,
                                     const std::string& src)
{
    std::unique_ptr<InputConverter> conv;
    Status s = InputConverter::create(config, src, conv);
    EXPECT_TRUE(s.ok()) << s.message();
    EXPECT_EQ(conv != nullptr, s.ok());
    return conv;
}

/// IEC 61966-2-1 sRGB decode, exact, in double.
double srgb_decode_iec(double v)
{
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

}  // namespace

// --- The embedded config ----------------------------------------------------

TEST_F(OcioTest, EmbeddedConfigLoadsAndValidates)
{
    std::istringstream in(filmgrain::ocio::embedded_config_text());
    OCIO::ConstConfigRcPtr config;
    ASSERT_NO_THROW(config = OCIO::Config::CreateFromStream(in));
    ASSERT_TRUE(config);
    EXPECT_NO_THROW(config->validate());
    for (const char* cs : { "lin_rec709", "ACEScg", "ACES2065-1", "sRGB", "raw" })
        EXPECT_TRUE(config->getColorSpace(cs)) << cs;
    EXPECT_STREQ(config->getColorSpace("scene_linear")->getName(), "lin_rec709");
    EXPECT_STREQ(config->getColorSpace("aces_interchange")->getName(), "ACES2065-1");
    EXPECT_STREQ(config->getColorSpace("data")->getName(), "raw");
    EXPECT_TRUE(config->getColorSpace("raw")->isData());
}

TEST_F(OcioTest, EmbeddedTextMatchesTheSourceFile)
{
    // Catches a stale embed (the generated .cpp not regenerated).
    std::ifstream in(FILMGRAIN_OCIO_MINIMAL_CONFIG_PATH);
    ASSERT_TRUE(in) << FILMGRAIN_OCIO_MINIMAL_CONFIG_PATH;
    const std::string file((std::istreambuf_iterator<char>(in)),
                           std::istreambuf_iterator<char>());
    EXPECT_EQ(filmgrain::ocio::embedded_config_text(), file);
}

TEST_F(OcioTest, SceneLinearSourcesAreNoops)
{
    for (const char* src : { "scene_linear", "lin_rec709", "linear",
                             "Linear Rec.709 (sRGB)", "lin_srgb", "reference" }) {
        auto conv = make("", src);
        ASSERT_TRUE(conv) << src;
        EXPECT_TRUE(conv->is_noop()) << src;
        EXPECT_EQ(conv->config().source, "embedded");
        EXPECT_EQ(conv->config().path, "");
        EXPECT_EQ(conv->source_colorspace(), src);
        EXPECT_EQ(conv->scene_linear_colorspace(), "lin_rec709");
        float rgb[3] = { 0.25f, -1.0f, 7.0f };
        conv->apply_rgb(rgb, 1);
        EXPECT_EQ(rgb[0], 0.25f);
        EXPECT_EQ(rgb[1], -1.0f);
        EXPECT_EQ(rgb[2], 7.0f);
    }
    auto srgb = make("", "sRGB");
    ASSERT_TRUE(srgb);
    EXPECT_FALSE(srgb->is_noop());
}

TEST_F(OcioTest, RawIsNeverConverted)
{
    for (const char* src : { "raw", "Raw", "data" }) {
        auto conv = make("", src);
        ASSERT_TRUE(conv) << src;
        EXPECT_TRUE(conv->is_noop()) << src;
    }
}

TEST_F(OcioTest, SrgbDecodeMatchesIecFormula)
{
    // OCIO derives the linear segment of ExponentWithLinearTransform from
    // gamma 2.4 / offset 0.055 (slope ~12.923, continuous derivative) instead
    // of IEC's rounded 12.92 and break point 0.04045: its result differs from
    // the exact formula by up to ~7.5e-7 absolute on [0, 1] (largest just
    // below the break point). Hence the 1e-6 tolerance.
    const std::vector<float> values = { 0.0f, 0.001f, 0.02f, 0.04045f, 0.0405f,
                                        0.1f, 0.18f, 0.5f, 0.75f, 1.0f };
    for (const char* src : { "sRGB", "srgb", "sRGB - Texture", "srgb_tx" }) {
        auto conv = make("", src);
        ASSERT_TRUE(conv) << src;
        std::vector<float> rgb;
        for (float v : values)
            rgb.insert(rgb.end(), { v, v, v });
        conv->apply_rgb(rgb.data(), values.size());
        for (size_t i = 0; i < values.size(); ++i) {
            const double expected = srgb_decode_iec(values[i]);
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(rgb[3 * i + c], expected, 1e-6)
                    << src << " at " << values[i] << " channel " << c;
        }
    }
}

TEST_F(OcioTest, AcescgToRec709)
{
    // Expected: the published ACES AP1 -> linear Rec.709 matrix with Bradford
    // adaptation from the ACES white (x 0.32168, y 0.33767) to D65, i.e.
    // XYZ->Rec709 (ITU-R BT.709-6) * Bradford(D60->D65) * AP1->XYZ (Academy
    // S-2014-004), as tabulated in colour-science
    // (colour.matrix_RGB_to_RGB(ACEScg, sRGB, "Bradford")) and as
    // AP1_2_sRGB in Unreal Engine's ACES.ush (rounded there to 5 digits).
    // Rows are output channels; column c is the image of primary c.
    const double ap1_to_rec709[3][3] = {
        { 1.7050509927, -0.6217921207, -0.0832588720 },
        { -0.1302564175, 1.1408047366, -0.0105483191 },
        { -0.0240033568, -0.1289689761, 1.1529723329 },
    };
    auto conv = make("", "ACEScg");
    ASSERT_TRUE(conv);
    EXPECT_FALSE(conv->is_noop());

    float white[3] = { 1.0f, 1.0f, 1.0f };
    conv->apply_rgb(white, 1);
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(white[c], 1.0, 1e-4) << "channel " << c;

    for (int primary = 0; primary < 3; ++primary) {
        float rgb[3]    = { 0.0f, 0.0f, 0.0f };
        rgb[primary]    = 1.0f;
        conv->apply_rgb(rgb, 1);
        for (int row = 0; row < 3; ++row)
            EXPECT_NEAR(rgb[row], ap1_to_rec709[row][primary], 1e-4)
                << "primary " << primary << " row " << row;
    }
}

TEST_F(OcioTest, Aces2065ToRec709)
{
    // AP0 -> linear Rec.709, Bradford D60 -> D65; same sources as above
    // (SMPTE ST 2065-1 primaries; colour-science ACES2065-1 -> sRGB).
    const double ap0_to_rec709_col0[3] = { 2.5216861867, -0.2764799048,
                                           -0.0153780649 };
    for (const char* src : { "ACES2065-1", "aces_interchange" }) {
        auto conv = make("", src);
        ASSERT_TRUE(conv) << src;
        float rgb[6] = { 1.0f, 1.0f, 1.0f, 1.0f, 0.0f, 0.0f };
        conv->apply_rgb(rgb, 2);
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(rgb[c], 1.0, 1e-4) << src << " white channel " << c;
            EXPECT_NEAR(rgb[3 + c], ap0_to_rec709_col0[c], 1e-4)
                << src << " red row " << c;
        }
    }
}

TEST_F(OcioTest, StridedLeavesAlphaAndExtraChannelsUntouched)
{
    auto conv = make("", "sRGB");
    ASSERT_TRUE(conv);
    const double expected = srgb_decode_iec(0.5);
    for (int nchannels : { 3, 4, 5, 7 }) {
        const size_t npixels = 37;
        std::vector<float> px(npixels * size_t(nchannels));
        for (size_t i = 0; i < npixels; ++i)
            for (int c = 0; c < nchannels; ++c)
                px[i * size_t(nchannels) + size_t(c)]
                    = c < 3 ? 0.5f : 0.125f * float(c) + float(i);
        conv->apply_rgb_strided(px.data(), npixels, nchannels);
        for (size_t i = 0; i < npixels; ++i) {
            for (int c = 0; c < nchannels; ++c) {
                const float v = px[i * size_t(nchannels) + size_t(c)];
                if (c < 3)
                    EXPECT_NEAR(v, expected, 1e-6) << nchannels << " ch, pixel " << i;
                else
                    EXPECT_EQ(v, 0.125f * float(c) + float(i))
                        << nchannels << " ch, pixel " << i << " channel " << c;
            }
        }
    }
}

TEST_F(OcioTest, StridedMatchesPackedAcrossChunks)
{
    // More pixels than one internal chunk, so chunk boundaries are crossed.
    auto conv = make("", "ACEScg");
    ASSERT_TRUE(conv);
    const size_t npixels = 40000;
    std::vector<float> rgb(npixels * 3), rgba(npixels * 4);
    for (size_t i = 0; i < npixels; ++i) {
        for (int c = 0; c < 3; ++c) {
            const float v = float((i * 7 + size_t(c) * 13) % 1000) / 250.0f;
            rgb[3 * i + size_t(c)]  = v;
            rgba[4 * i + size_t(c)] = v;
        }
        rgba[4 * i + 3] = -2.0f;
    }
    // Reference: every pixel converted on its own (no chunking involved).
    std::vector<float> single = rgb;
    for (size_t i = 0; i < npixels; ++i)
        conv->apply_rgb(single.data() + 3 * i, 1);
    conv->apply_rgb(rgb.data(), npixels);
    conv->apply_rgb_strided(rgba.data(), npixels, 4);
    for (size_t i = 0; i < npixels; ++i) {
        for (int c = 0; c < 3; ++c) {
            ASSERT_EQ(rgb[3 * i + size_t(c)], single[3 * i + size_t(c)]) << "pixel " << i;
            ASSERT_EQ(rgba[4 * i + size_t(c)], single[3 * i + size_t(c)]) << "pixel " << i;
        }
        ASSERT_EQ(rgba[4 * i + 3], -2.0f) << "pixel " << i;
    }
}

TEST_F(OcioTest, BadArgumentsDoNothing)
{
    auto conv = make("", "sRGB");
    ASSERT_TRUE(conv);
    conv->apply_rgb(nullptr, 10);
    conv->apply_rgb_strided(nullptr, 10, 4);
    float px[6] = { 0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f };
    conv->apply_rgb(px, 0);
    conv->apply_rgb_strided(px, 2, 2);  // fewer than 3 channels: rejected
    for (float v : px)
        EXPECT_EQ(v, 0.5f);
}

TEST_F(OcioTest, ConcurrentApplyMatchesSerial)
{
    auto conv = make("", "sRGB");
    ASSERT_TRUE(conv);
    const size_t npixels = 20000;
    std::vector<float> input(npixels * 3);
    for (size_t i = 0; i < input.size(); ++i)
        input[i] = float(i % 1001) / 1000.0f;
    std::vector<float> serial = input;
    conv->apply_rgb(serial.data(), npixels);

    const int nthreads = 8;
    std::vector<std::vector<float>> out(nthreads, input);
    std::vector<std::thread> threads;
    for (int t = 0; t < nthreads; ++t)
        threads.emplace_back([&, t] {
            // Each thread converts its copy in tiles of a different size.
            const size_t tile = 100 + size_t(t) * 997;
            for (size_t p = 0; p < npixels; p += tile)
                conv->apply_rgb(out[size_t(t)].data() + 3 * p,
                                std::min(tile, npixels - p));
        });
    for (std::thread& th : threads)
        th.join();
    for (int t = 0; t < nthreads; ++t)
        EXPECT_EQ(out[size_t(t)], serial) << "thread " << t;
}

// --- NaN and Inf ------------------------------------------------------------

TEST_F(OcioTest, NonFiniteValuesPassThroughWithoutCrash)
{
    // Observed with OCIO 2.1.2 (documented, not asserted):
    //  - sRGB (a per-channel curve): NaN -> NaN, +Inf -> +Inf, -Inf -> -Inf.
    //  - ACEScg (a 3x3 matrix): a pixel holding NaN or +/-Inf comes out NaN
    //    (or +/-Inf) in all three channels, since the matrix mixes channels.
    // Asserted: no crash, and pixels that were finite stay finite (each pixel
    // is converted independently).
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    for (const char* src : { "sRGB", "ACEScg", "ACES2065-1" }) {
        auto conv = make("", src);
        ASSERT_TRUE(conv) << src;
        std::vector<float> rgba = {
            0.5f, 0.25f, 0.125f, 1.0f,  // finite
            nan,  0.5f,  0.5f,   1.0f,  //
            0.2f, 0.3f,  0.4f,   1.0f,  // finite
            inf,  -inf,  0.5f,   nan,   // alpha NaN must stay NaN
            1.0f, 1.0f,  1.0f,   0.0f,  // finite
            nan,  inf,   -inf,   1.0f,  //
            0.0f, 0.0f,  0.0f,   inf,   // finite RGB
        };
        std::vector<float> rgb;
        for (size_t i = 0; i < rgba.size(); i += 4)
            rgb.insert(rgb.end(), rgba.begin() + long(i), rgba.begin() + long(i) + 3);
        const std::vector<float> before = rgb;
        const size_t npixels = rgb.size() / 3;

        conv->apply_rgb(rgb.data(), npixels);
        conv->apply_rgb_strided(rgba.data(), npixels, 4);
        for (size_t i = 0; i < npixels; ++i) {
            const bool finite_in = std::isfinite(before[3 * i])
                                   && std::isfinite(before[3 * i + 1])
                                   && std::isfinite(before[3 * i + 2]);
            for (int c = 0; c < 3; ++c) {
                if (finite_in) {
                    EXPECT_TRUE(std::isfinite(rgb[3 * i + size_t(c)]))
                        << src << " pixel " << i << " channel " << c;
                    EXPECT_TRUE(std::isfinite(rgba[4 * i + size_t(c)]))
                        << src << " pixel " << i << " channel " << c;
                }
            }
        }
        EXPECT_TRUE(std::isnan(rgba[4 * 3 + 3])) << src;
        EXPECT_EQ(rgba[4 * 6 + 3], inf) << src;
    }
}

// --- Errors -----------------------------------------------------------------

TEST_F(OcioTest, UnknownColourSpace)
{
    std::unique_ptr<InputConverter> conv;
    Status s = InputConverter::create("", "no_such_space", conv);
    ASSERT_FALSE(s.ok());
    EXPECT_FALSE(conv);
    EXPECT_NE(s.message().find("no_such_space"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("unknown"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("embedded"), std::string::npos) << s.message();
    // The message lists what is known.
    EXPECT_NE(s.message().find("ACEScg"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("scene_linear"), std::string::npos) << s.message();

    s = InputConverter::create("", "", conv);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find("unknown colour space ''"), std::string::npos)
        << s.message();
}

TEST_F(OcioTest, FailedCreateResetsOutput)
{
    auto conv = make("", "sRGB");
    ASSERT_TRUE(conv);
    Status s = InputConverter::create("", "no_such_space", conv);
    EXPECT_FALSE(s.ok());
    EXPECT_FALSE(conv);
}

TEST_F(OcioTest, BadConfigPath)
{
    const std::string path = "/nonexistent/filmgrain/missing_config.ocio";
    std::unique_ptr<InputConverter> conv;
    Status s = InputConverter::create(path, "sRGB", conv);
    ASSERT_FALSE(s.ok());
    EXPECT_FALSE(conv);
    EXPECT_NE(s.message().find(path), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("cannot load OCIO config"), std::string::npos)
        << s.message();
    EXPECT_EQ(s.message().find("$OCIO"), std::string::npos) << s.message();

    std::vector<std::string> names { "stale" };
    s = filmgrain::ocio::list_colorspaces(path, names);
    ASSERT_FALSE(s.ok());
    EXPECT_TRUE(names.empty());
    EXPECT_NE(s.message().find(path), std::string::npos) << s.message();
}

TEST_F(OcioTest, MalformedConfigFile)
{
    TempDir dir("malformed");
    const std::string path = write_file(dir.path() / "bad.ocio",
                                        "ocio_profile_version: 2\ncolorspaces: [[[\n");
    std::unique_ptr<InputConverter> conv;
    Status s = InputConverter::create(path, "sRGB", conv);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find(path), std::string::npos) << s.message();
}

TEST_F(OcioTest, MissingOcioEnvFile)
{
    const std::string path = "/nonexistent/filmgrain/from_env.ocio";
    OcioEnvGuard env(path);
    std::unique_ptr<InputConverter> conv;
    Status s = InputConverter::create("", "sRGB", conv);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find("$OCIO"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find(path), std::string::npos) << s.message();

    std::vector<std::string> names;
    s = filmgrain::ocio::list_colorspaces("", names);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find("$OCIO"), std::string::npos) << s.message();
}

TEST_F(OcioTest, ConfigWithoutSceneLinearRole)
{
    TempDir dir("norole");
    std::string text = k_user_config;
    const std::string role_line = "  scene_linear: my_lin\n";
    text.erase(text.find(role_line), role_line.size());
    const std::string path = write_file(dir.path() / "norole.ocio", text);
    std::unique_ptr<InputConverter> conv;
    Status s = InputConverter::create(path, "my_log", conv);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find("scene_linear"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find(path), std::string::npos) << s.message();
}

// --- User configs -------------------------------------------------------------

TEST_F(OcioTest, ExplicitConfigFile)
{
    TempDir dir("explicit");
    const std::string path = write_file(dir.path() / "user.ocio", k_user_config);
    auto conv = make(path, "my_log");
    ASSERT_TRUE(conv);
    EXPECT_EQ(conv->config().source, "file");
    EXPECT_EQ(conv->config().path, path);
    EXPECT_EQ(conv->scene_linear_colorspace(), "my_lin");
    EXPECT_FALSE(conv->is_noop());
    float rgb[6] = { 0.0f, -1.0f, 1.0f, 0.5f, -2.0f, 2.0f };
    conv->apply_rgb(rgb, 2);
    const double expected[6] = { 1.0, 0.1, 10.0, std::sqrt(10.0), 0.01, 100.0 };
    for (int i = 0; i < 6; ++i)
        EXPECT_NEAR(rgb[i], expected[i], 1e-5 * expected[i]) << "value " << i;

    auto lin = make(path, "scene_linear");
    ASSERT_TRUE(lin);
    EXPECT_TRUE(lin->is_noop());

    // Names of the embedded config are unknown here, and the message names
    // this file.
    std::unique_ptr<InputConverter> bad;
    Status s = InputConverter::create(path, "ACEScg", bad);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find(path), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("my_log"), std::string::npos) << s.message();
}

TEST_F(OcioTest, ConfigFromOcioEnv)
{
    TempDir dir("env");
    const std::string path = write_file(dir.path() / "user.ocio", k_user_config);
    OcioEnvGuard env(path);
    auto conv = make("", "my_log");
    ASSERT_TRUE(conv);
    EXPECT_EQ(conv->config().source, "$OCIO");
    EXPECT_EQ(conv->config().path, path);
    EXPECT_EQ(conv->scene_linear_colorspace(), "my_lin");
    float rgb[3] = { 1.0f, 0.0f, -1.0f };
    conv->apply_rgb(rgb, 1);
    EXPECT_NEAR(rgb[0], 10.0, 1e-4);
    EXPECT_NEAR(rgb[1], 1.0, 1e-5);
    EXPECT_NEAR(rgb[2], 0.1, 1e-6);

    std::unique_ptr<InputConverter> bad;
    Status s = InputConverter::create("", "no_such_space", bad);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find("$OCIO"), std::string::npos) << s.message();
}

TEST_F(OcioTest, ExplicitConfigWinsOverOcioEnv)
{
    TempDir dir("precedence");
    const std::string path = write_file(dir.path() / "user.ocio", k_user_config);
    OcioEnvGuard env("/nonexistent/filmgrain/from_env.ocio");
    auto conv = make(path, "my_log");
    ASSERT_TRUE(conv);
    EXPECT_EQ(conv->config().source, "file");
}

TEST_F(OcioTest, EmptyOcioEnvMeansEmbedded)
{
    OcioEnvGuard env { std::string() };
    auto conv = make("", "ACEScg");
    ASSERT_TRUE(conv);
    EXPECT_EQ(conv->config().source, "embedded");
}

// --- list_colorspaces -----------------------------------------------------

TEST_F(OcioTest, ListColourSpaces)
{
    std::vector<std::string> names;
    Status s = filmgrain::ocio::list_colorspaces("", names);
    ASSERT_TRUE(s.ok()) << s.message();
    auto has = [&names](const std::string& n) {
        return std::find(names.begin(), names.end(), n) != names.end();
    };
    for (const char* n : { "lin_rec709", "ACEScg", "ACES2065-1", "ADX10", "ADX16", "sRGB",
                           "raw", "sRGB - Display", "scene_linear", "data", "aces_interchange" })
        EXPECT_TRUE(has(n)) << n;
    // Colour spaces first (OCIO lists the display colour spaces before the
    // scene ones), in config order, then the roles.
    const auto at = [&names](const std::string& n) {
        return std::find(names.begin(), names.end(), n) - names.begin();
    };
    EXPECT_LT(at("lin_rec709"), at("ACEScg"));
    EXPECT_LT(at("ADX16"), at("raw"));
    EXPECT_LT(at("raw"), at("scene_linear"));

    TempDir dir("list");
    const std::string path = write_file(dir.path() / "user.ocio", k_user_config);
    s = filmgrain::ocio::list_colorspaces(path, names);
    ASSERT_TRUE(s.ok()) << s.message();
    EXPECT_EQ(names, (std::vector<std::string> { "my_lin", "my_log", "default",
                                                 "scene_linear" }));
}

// --- Converter: ADX and the display ------------------------------------------

using filmgrain::ocio::Converter;

TEST_F(OcioTest, EmbeddedAdxSpacesAreOciosBuiltinAdxToAces)
{
    // The config's ADX16 -> ACES2065-1 goes through its reference
    // (lin_rec709) and back: it must equal OCIO's BuiltinTransform
    // ADX16_to_ACES2065-1 applied directly, up to float rounding of the two
    // matrices (relative 1e-5).
    for (const char* adx : { "ADX10", "ADX16" }) {
        std::unique_ptr<Converter> conv;
        Status s = Converter::create("", adx, "ACES2065-1", conv);
        ASSERT_TRUE(s.ok()) << s.message();
        EXPECT_EQ(conv->source_name(), adx);
        EXPECT_EQ(conv->destination_name(), "ACES2065-1");
        auto bt = OCIO::BuiltinTransform::Create();
        bt->setStyle((std::string(adx) + "_to_ACES2065-1").c_str());
        auto direct = OCIO::Config::CreateRaw()->getProcessor(bt)->getDefaultCPUProcessor();
        const bool ten = std::string(adx) == "ADX10";
        for (double d : { 0.0, 0.3, 0.7, 1.2, 1.8 }) {
            const float cv = static_cast<float>(ten ? (95.0 + 500.0 * d) / 1023.0
                                                    : (1520.0 + 8000.0 * d) / 65535.0);
            float a[3] = { cv, cv, cv }, b[3] = { cv, cv, cv };
            conv->apply_rgb(a, 1);
            direct->applyRGB(b);
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(a[c], b[c], 1e-5 * std::fabs(b[c]) + 1e-7) << adx << " D " << d;
        }
    }
    std::string resolved;
    ASSERT_TRUE(filmgrain::ocio::find_colorspace("", "adx16", resolved).ok());
    EXPECT_EQ(resolved, "ADX16");
    ASSERT_TRUE(filmgrain::ocio::find_colorspace("", "no such space", resolved).ok());
    EXPECT_EQ(resolved, "");
}

TEST_F(OcioTest, DisplayViewDefaultsToSrgbAces)
{
    std::unique_ptr<Converter> conv;
    Status s = Converter::create_display_view("", "ACES2065-1", "", "", conv);
    ASSERT_TRUE(s.ok()) << s.message();
    EXPECT_EQ(conv->destination_name(), "sRGB / ACES 1.0 - SDR Video");
    // ACES mid grey (0.18) through the ACES 1.0 SDR video output transform
    // is about 0.39 on an sRGB display (the RRT's mid grey ~10 nits of 100);
    // black stays black, brighter is brighter.
    float px[9] = { 0.18f, 0.18f, 0.18f, 0.0f, 0.0f, 0.0f, 1.0f, 1.0f, 1.0f };
    conv->apply_rgb(px, 3);
    EXPECT_NEAR(px[0], 0.39, 0.05);
    EXPECT_NEAR(px[0], px[1], 1e-3);
    EXPECT_NEAR(px[3], 0.0, 1e-3);
    EXPECT_GT(px[6], px[0]);
    s = Converter::create_display_view("", "ACES2065-1", "sRGB", "Nope", conv);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find("unknown view 'Nope'"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("ACES 1.0 - SDR Video"), std::string::npos) << s.message();
    EXPECT_FALSE(conv);
    s = Converter::create("", "scene_linear", "nowhere", conv);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find("unknown colour space 'nowhere'"), std::string::npos);
}
