// filmgrain: unit tests of the OpenColorIO input conversion (filmgrain/ocio.h).
#include <filmgrain/ocio.h>

#include <Imath/ImathMatrix.h>
#include <Imath/ImathVec.h>
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

// --- Chromaticities -----------------------------------------------------------

namespace {

using filmgrain::ocio::Chromaticities;

/// ITU-R BT.709-6 primaries, D65 white.
const Chromaticities k_rec709_xy = { 0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.3290 };
/// CIE XYZ as RGB, equal-energy white E.
const Chromaticities k_xyz_xy = { 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0 / 3.0, 1.0 / 3.0 };
/// ACES AP0 primaries, ACES white (SMPTE ST 2065-1).
const Chromaticities k_ap0_xy = { 0.7347, 0.2653, 0.0, 1.0, 0.0001, -0.0770, 0.32168, 0.33767 };
/// Made up: wider than Rec.709, white near D55.
const Chromaticities k_made_up_xy = { 0.70, 0.29, 0.17, 0.78, 0.13, 0.03, 0.3324, 0.3474 };

/// Linear Rec.709 RGB -> CIE XYZ (D65), as published for sRGB / BT.709
/// (IEC 61966-2-1 gives it to 4 digits; these 10 are its exact derivation
/// from the primaries and D65 = 0.3127, 0.3290). Rows are X, Y, Z.
const Imath::M33d k_rec709_to_xyz(0.4123907993, 0.3575843394, 0.1804807884,
                                  0.2126390059, 0.7151686788, 0.0721923154,
                                  0.0193308187, 0.1191947798, 0.9505321522);
/// ACES AP0 -> XYZ, the NPM published in SMPTE ST 2065-1.
const Imath::M33d k_ap0_to_xyz(0.9525523959, 0.0, 0.0000936786,
                               0.3439664498, 0.7281660966, -0.0721325464,
                               0.0, 0.0, 1.0088251844);
/// Bradford's cone response matrix (Lam 1985).
const Imath::M33d k_bradford_cones(0.8951, 0.2664, -0.1614, -0.7502, 1.7135, 0.0367,
                                   0.0389, -0.0685, 1.0296);

/// m v, v a column (Imath's `v * m` takes v as a row).
Imath::V3d mul(const Imath::M33d& m, const Imath::V3d& v)
{
    return v * m.transposed();
}

/// Bradford adaptation taking white XYZ `from` to white XYZ `to`.
Imath::M33d bradford(const Imath::V3d& from, const Imath::V3d& to)
{
    const Imath::V3d a = mul(k_bradford_cones, from), b = mul(k_bradford_cones, to);
    Imath::M33d gain;
    gain[0][0] = b.x / a.x;
    gain[1][1] = b.y / a.y;
    gain[2][2] = b.z / a.z;
    return k_bradford_cones.inverse() * gain * k_bradford_cones;
}

Imath::V3d white_of(const Imath::M33d& rgb_to_xyz)
{
    return mul(rgb_to_xyz, Imath::V3d(1.0, 1.0, 1.0));
}

/// Linear Rec.709 test colours: white, the primaries, a skin tone, a sky
/// blue, a dark green, a bright orange.
const std::vector<Imath::V3d> k_rec709_colours = {
    { 1.0, 1.0, 1.0 }, { 1.0, 0.0, 0.0 }, { 0.0, 1.0, 0.0 }, { 0.0, 0.0, 1.0 },
    { 0.45, 0.30, 0.22 }, { 0.20, 0.35, 0.70 }, { 0.03, 0.12, 0.04 }, { 2.5, 0.9, 0.1 },
};

std::unique_ptr<InputConverter> make_xy(const std::string& config, const Chromaticities& xy,
                                        double tolerance_xy
                                        = filmgrain::ocio::k_chromaticities_tolerance_xy)
{
    std::unique_ptr<InputConverter> conv;
    Status s = InputConverter::create_from_chromaticities(config, xy, conv, tolerance_xy);
    EXPECT_TRUE(s.ok()) << s.message();
    EXPECT_EQ(conv != nullptr, s.ok());
    return conv;
}

/// Converts `in` (pixels of the file) and checks each against `expected`.
void expect_converts(const InputConverter& conv, const std::vector<Imath::V3d>& in,
                     const std::vector<Imath::V3d>& expected, double tolerance,
                     const std::string& what)
{
    std::vector<float> rgb;
    for (const Imath::V3d& v : in)
        rgb.insert(rgb.end(), { float(v.x), float(v.y), float(v.z) });
    conv.apply_rgb(rgb.data(), in.size());
    for (size_t i = 0; i < in.size(); ++i)
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(rgb[3 * i + size_t(c)], expected[i][c], tolerance)
                << what << ": colour " << i << " channel " << c;
}

/// The converter of a file whose primaries are `xy`, checked on the Rec.709
/// test colours written into such a file by `to_file` (Rec.709 RGB -> the
/// file's): it converts them back within 1e-5, and is not a no-op.
std::unique_ptr<InputConverter> expect_xy_gives_rec709(const Chromaticities& xy,
                                                       const Imath::M33d& to_file,
                                                       const std::string& what)
{
    std::vector<Imath::V3d> file;
    for (const Imath::V3d& c : k_rec709_colours)
        file.push_back(mul(to_file, c));
    auto conv = make_xy("", xy);
    if (!conv)
        return conv;  // make_xy failed the test
    EXPECT_FALSE(conv->is_noop()) << what;
    expect_converts(*conv, file, k_rec709_colours, 1e-5, what);
    return conv;
}

}  // namespace

TEST_F(OcioTest, Rec709ChromaticitiesAreTheEmbeddedSceneLinear)
{
    // Within the default tolerance: no conversion at all.
    auto conv = make_xy("", k_rec709_xy);
    ASSERT_TRUE(conv);
    EXPECT_TRUE(conv->is_noop());
    EXPECT_EQ(conv->source_colorspace(), "");
    EXPECT_EQ(conv->via_colorspace(), "ACES2065-1");
    EXPECT_EQ(conv->scene_linear_colorspace(), "lin_rec709");
    float px[3] = { 0.3f, 0.2f, 0.1f };
    conv->apply_rgb(px, 1);
    EXPECT_EQ(px[0], 0.3f);

    // With tolerance 0 the conversion is built: Rec.709 -> XYZ -> Bradford
    // D65 -> ACES white -> AP0 by our matrices, then AP0 -> Rec.709 by
    // OCIO's, which compose to the identity. OCIO itself then drops the
    // product as an identity matrix (it does so for a diagonal within ~1e-6
    // of 1, measured with OCIO 2.1.2), so is_noop() may be true or false
    // here; either way every colour comes back within 1e-6 (relative above
    // 1).
    auto exact = make_xy("", k_rec709_xy, 0.0);
    ASSERT_TRUE(exact);
    std::vector<float> rgb;
    for (const Imath::V3d& c : k_rec709_colours)
        rgb.insert(rgb.end(), { float(c.x), float(c.y), float(c.z) });
    exact->apply_rgb(rgb.data(), k_rec709_colours.size());
    for (size_t i = 0; i < k_rec709_colours.size(); ++i)
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(rgb[3 * i + size_t(c)], k_rec709_colours[i][c],
                        1e-6 * std::max(1.0, k_rec709_colours[i][c]))
                << "colour " << i << " channel " << c;
}

TEST_F(OcioTest, XyzChromaticitiesGiveRec709)
{
    // A Rec.709 colour in XYZ with white E: Rec.709 -> XYZ (published),
    // Bradford D65 -> E. Converting back must give the Rec.709 value.
    const Imath::M33d to_file
        = bradford(white_of(k_rec709_to_xyz), Imath::V3d(1.0, 1.0, 1.0)) * k_rec709_to_xyz;
    EXPECT_TRUE(expect_xy_gives_rec709(k_xyz_xy, to_file, "XYZ (E)"));
}

TEST_F(OcioTest, Ap0ChromaticitiesGiveRec709)
{
    // Through the published ST 2065-1 NPM: Rec.709 -> XYZ -> Bradford D65 ->
    // ACES white -> AP0.
    const Imath::M33d to_file = k_ap0_to_xyz.inverse()
                                * bradford(white_of(k_rec709_to_xyz), white_of(k_ap0_to_xyz))
                                * k_rec709_to_xyz;
    const auto conv = expect_xy_gives_rec709(k_ap0_xy, to_file, "AP0");
    ASSERT_TRUE(conv);
    // AP0 red is colour-science's ACES2065-1 -> sRGB first column (as in
    // Aces2065ToRec709 above).
    expect_converts(*conv, { { 1.0, 0.0, 0.0 } },
                    { { 2.5216861867, -0.2764799048, -0.0153780649 } }, 1e-5, "AP0 red");

    // The same as the config's own ACES2065-1 colour space.
    auto named = make("", "ACES2065-1");
    ASSERT_TRUE(named);
    std::vector<float> a, b;
    for (const Imath::V3d& c : k_rec709_colours)
        for (int i = 0; i < 3; ++i)
            a.push_back(float(c[i]));
    b = a;
    conv->apply_rgb(a.data(), k_rec709_colours.size());
    named->apply_rgb(b.data(), k_rec709_colours.size());
    for (size_t i = 0; i < a.size(); ++i)
        EXPECT_NEAR(a[i], b[i], 1e-6) << "value " << i;
}

TEST_F(OcioTest, InputConverterNamesItsRoute)
{
    // A named source: as given, resolved, and scene_linear's colour space
    // as the Converter's destination.
    auto named = make("", "acescg");  // OCIO matches names case-insensitively
    ASSERT_TRUE(named);
    EXPECT_EQ(named->source_colorspace(), "acescg");
    EXPECT_EQ(named->source_name(), "ACEScg");
    EXPECT_EQ(named->scene_linear_colorspace(), "lin_rec709");
    EXPECT_EQ(named->destination_name(), "lin_rec709");
    EXPECT_EQ(named->via_colorspace(), "");
    // From chromaticities: no source name, the ACES space it went through.
    std::unique_ptr<InputConverter> xy;
    ASSERT_TRUE(InputConverter::create_from_chromaticities("", k_ap0_xy, xy));
    EXPECT_EQ(xy->source_colorspace(), "");
    EXPECT_EQ(xy->source_name(), "");
    EXPECT_EQ(xy->destination_name(), "lin_rec709");
    EXPECT_EQ(xy->via_colorspace(), "ACES2065-1");
}

TEST_F(OcioTest, MadeUpChromaticitiesKeepWhiteAndTheirPrimaries)
{
    auto conv = make_xy("", k_made_up_xy);
    ASSERT_TRUE(conv);
    EXPECT_FALSE(conv->is_noop());
    // White stays white.
    expect_converts(*conv, { { 1.0, 1.0, 1.0 }, { 0.18, 0.18, 0.18 } },
                    { { 1.0, 1.0, 1.0 }, { 0.18, 0.18, 0.18 } }, 1e-6, "white");
    // Each primary, converted, then taken back to XYZ (published Rec.709
    // matrix) and adapted from D65 to the made-up white, has the made-up
    // primary's chromaticity.
    const Imath::V3d made_up_white(k_made_up_xy[6] / k_made_up_xy[7], 1.0,
                                   (1.0 - k_made_up_xy[6] - k_made_up_xy[7]) / k_made_up_xy[7]);
    const Imath::M33d back = bradford(white_of(k_rec709_to_xyz), made_up_white) * k_rec709_to_xyz;
    for (int p = 0; p < 3; ++p) {
        float px[3] = { 0.0f, 0.0f, 0.0f };
        px[p]       = 1.0f;
        conv->apply_rgb(px, 1);
        const Imath::V3d xyz = mul(back, Imath::V3d(px[0], px[1], px[2]));
        const double sum     = xyz.x + xyz.y + xyz.z;
        EXPECT_NEAR(xyz.x / sum, k_made_up_xy[size_t(2 * p)], 1e-6) << "primary " << p;
        EXPECT_NEAR(xyz.y / sum, k_made_up_xy[size_t(2 * p + 1)], 1e-6) << "primary " << p;
    }
}

TEST_F(OcioTest, CompareChromaticities)
{
    const auto same = [](const std::string& cs, const Chromaticities& xy) {
        bool result = false;
        Status s    = filmgrain::ocio::compare_chromaticities("", cs, xy, result);
        EXPECT_TRUE(s.ok()) << cs << ": " << s.message();
        return result;
    };
    EXPECT_TRUE(same("scene_linear", k_rec709_xy));
    EXPECT_TRUE(same("lin_rec709", k_rec709_xy));
    EXPECT_TRUE(same("sRGB", k_rec709_xy));  // a curve through 0 and 1
    EXPECT_FALSE(same("ACEScg", k_rec709_xy));
    EXPECT_TRUE(same("ACES2065-1", k_ap0_xy));
    EXPECT_FALSE(same("scene_linear", k_ap0_xy));
    EXPECT_TRUE(same("ACEScg", { 0.713, 0.293, 0.165, 0.830, 0.128, 0.044, 0.32168, 0.33767 }));
    // D65 written as 0.31271, 0.32902, and Rec.709 as floats: the same.
    EXPECT_TRUE(same("scene_linear", { 0.64f, 0.33f, 0.3f, 0.6f, 0.15f, 0.06f, 0.31271, 0.32902 }));
    // Rec.709 primaries with a D50 white are another colour space.
    EXPECT_FALSE(same("scene_linear", { 0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3457, 0.3585 }));
    // 2e-3 off in one primary's x is beyond the tolerance; 2e-4 is within.
    EXPECT_FALSE(same("scene_linear", { 0.642, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.3290 }));
    EXPECT_TRUE(same("scene_linear", { 0.6402, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.3290 }));

    bool result = true;
    Status s = filmgrain::ocio::compare_chromaticities("", "raw", k_rec709_xy, result);
    EXPECT_FALSE(s.ok());
    EXPECT_FALSE(result);
    EXPECT_NE(s.message().find("'raw'"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("data"), std::string::npos) << s.message();
    s = filmgrain::ocio::compare_chromaticities("", "ADX10", k_rec709_xy, result);
    EXPECT_FALSE(s.ok());
    EXPECT_NE(s.message().find("not to black"), std::string::npos) << s.message();
    s = filmgrain::ocio::compare_chromaticities("", "nope", k_rec709_xy, result);
    EXPECT_FALSE(s.ok());
    EXPECT_NE(s.message().find("unknown colour space 'nope'"), std::string::npos) << s.message();
}

TEST_F(OcioTest, InvalidChromaticities)
{
    struct Case {
        Chromaticities xy;
        std::vector<std::string> words;
    };
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const std::vector<Case> cases = {
        { { 0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.0 }, { "white y = 0", "> 0" } },
        { { 0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, -0.3 }, { "white y = -0.3" } },
        { { 0.64, 0.33, nan, 0.60, 0.15, 0.06, 0.3127, 0.3290 }, { "green x = nan", "finite" } },
        // Collinear primaries.
        { { 0.6, 0.3, 0.4, 0.4, 0.2, 0.5, 0.3127, 0.3290 }, { "on one line" } },
        // The white on the line from red to green.
        { { 0.6, 0.4, 0.2, 0.8, 0.15, 0.06, 0.4, 0.6 }, { "white lies on the line" } },
    };
    for (const Case& c : cases) {
        std::unique_ptr<InputConverter> conv = make("", "sRGB");
        Status s = InputConverter::create_from_chromaticities("", c.xy, conv);
        ASSERT_FALSE(s.ok());
        EXPECT_FALSE(conv);
        for (const std::string& w : c.words)
            EXPECT_NE(s.message().find(w), std::string::npos) << s.message();
    }
    std::unique_ptr<InputConverter> conv;
    Status s = InputConverter::create_from_chromaticities("", k_rec709_xy, conv, -1.0);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find("tolerance_xy = -1"), std::string::npos) << s.message();
}

TEST_F(OcioTest, ChromaticitiesNeedAces2065InTheConfig)
{
    TempDir dir("noaces");
    const std::string path = write_file(dir.path() / "user.ocio", k_user_config);
    std::unique_ptr<InputConverter> conv;
    Status s = InputConverter::create_from_chromaticities(path, k_rec709_xy, conv);
    ASSERT_FALSE(s.ok());
    EXPECT_FALSE(conv);
    EXPECT_NE(s.message().find(path), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("aces_interchange"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("ACES2065-1"), std::string::npos) << s.message();

    // A colour space named ACES2065-1 is enough (no role): here my_lin is
    // taken to be AP0 itself, so AP0 chromaticities need no conversion.
    std::string text = k_user_config;
    text += "  - !<ColorSpace>\n    name: ACES2065-1\n";
    const std::string named = write_file(dir.path() / "named.ocio", text);
    auto ap0 = make_xy(named, k_ap0_xy);
    ASSERT_TRUE(ap0);
    EXPECT_TRUE(ap0->is_noop());
    EXPECT_EQ(ap0->via_colorspace(), "ACES2065-1");
    auto rec709 = make_xy(named, k_rec709_xy);
    ASSERT_TRUE(rec709);
    EXPECT_FALSE(rec709->is_noop());
}
