// filmgrain CLI: INPUT to scene_linear (scene_linear.h).
#include "scene_linear.h"

#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/parallel.h>
#include <OpenImageIO/strutil.h>

#include <cmath>
#include <cstdlib>
#include <memory>
#include <sstream>

#include "error_text.h"

namespace filmgrain::cli {

namespace {

/// The shortest decimal that reads back as `f` (0.64, not 0.63999998569):
/// chromaticities are stored as floats and were written as decimals.
double shortest_decimal(float f)
{
    if (!std::isfinite(f))
        return f;
    for (int digits = 1; digits < 9; ++digits) {
        std::ostringstream s;
        s.precision(digits);
        s << f;
        const double d = std::strtod(s.str().c_str(), nullptr);
        if (static_cast<float>(d) == f)
            return d;
    }
    return f;
}

/// INPUT's `chromaticities` attribute (OpenEXR's: red x, y, green x, y, blue
/// x, y, white x, y; OIIO reads it as FLOAT[8]), if it has one. One of
/// another type is ignored with a warning.
std::optional<ocio::Chromaticities> file_chromaticities(const OIIO::ImageSpec& spec,
                                                        const std::string& input_path,
                                                        const Console& con)
{
    const OIIO::TypeDesc type(OIIO::TypeDesc::FLOAT, 8);
    const OIIO::ParamValue* p = spec.find_attribute("chromaticities");
    if (!p)
        return std::nullopt;
    if (p->type() != type) {
        con.warning("input '" + input_path + "': its chromaticities attribute is "
                    + std::string(p->type().c_str()) + ", not float[8]: ignored");
        return std::nullopt;
    }
    const float* v = static_cast<const float*>(p->data());
    ocio::Chromaticities xy;
    for (size_t i = 0; i < xy.size(); ++i)
        xy[i] = shortest_decimal(v[i]);
    return xy;
}

/// "red 0.64 0.33, green 0.3 0.6, blue 0.15 0.06, white 0.3127 0.329".
std::string describe_chromaticities(const ocio::Chromaticities& xy)
{
    std::ostringstream s;
    s.precision(7);
    const char* const names[4] = { "red", "green", "blue", "white" };
    for (size_t i = 0; i < 4; ++i)
        s << (i ? ", " : "") << names[i] << ' ' << xy[2 * i] << ' ' << xy[2 * i + 1];
    return s.str();
}

std::string describe_config(const ocio::ConfigInfo& cfg)
{
    return "OCIO config: " + (cfg.path.empty() ? cfg.source : cfg.source + " " + cfg.path);
}

/// Runs `conv` over `src` in place. 1-channel images become (y, y, y) first.
Status apply_input_converter(const ocio::InputConverter& conv, OIIO::ImageBuf& src)
{
    if (conv.is_noop())
        return {};
    if (src.spec().nchannels == 1) {
        const int grey[3] = { 0, 0, 0 };
        OIIO::ImageBuf rgb = OIIO::ImageBufAlgo::channels(src, 3, grey);
        if (rgb.has_error())
            return Status::errorf("cannot expand the grey input to RGB: ", trim(rgb.geterror()));
        src = std::move(rgb);
    }
    float* pixels = static_cast<float*>(src.localpixels());
    if (!pixels || src.spec().format != OIIO::TypeFloat)
        return Status::error("internal: the input is not a local float image");
    // On OIIO's threads (--threads), in chunks: the converter is safe on
    // disjoint buffers, and a pixel's result does not depend on how the
    // image is split into calls (InputConverter's determinism).
    const int64_t npixels = static_cast<int64_t>(src.spec().image_pixels());
    const int nchannels   = src.spec().nchannels;
    constexpr int64_t kChunkPixels = int64_t(1) << 18;
    OIIO::parallel_for_chunked(0, npixels, kChunkPixels, [&](int64_t b, int64_t e) {
        conv.apply_rgb_strided(pixels + b * nchannels, static_cast<size_t>(e - b), nchannels);
    });
    return {};
}

}  // namespace

/// Chooses INPUT's colour space, converts `src` in place to the config's
/// scene_linear and says which space was used: --iscolorspace, else the
/// file's oiio:ColorSpace when the config knows it and it names primaries,
/// else the file's chromaticities (an RGB image's), else scene_linear.
/// OIIO's OpenEXR reader says "Linear" for every file (EXR stores no colour
/// space name): linear light, primaries unsaid, so the chromaticities, when
/// the file has them, say which. `chosen` receives the colour space name, or
/// "chromaticities" when converted from them; `used_xy` the chromaticities
/// when they decided (converted, or found to be scene_linear's), else
/// nothing. 1-channel images stay grey when the conversion is a no-op, else
/// become (y, y, y) first.
Status convert_to_scene_linear(const CliArgs& a, const std::string& input_path,
                               OIIO::ImageBuf& src, const Console& con, std::string& chosen,
                               std::optional<ocio::Chromaticities>& used_xy)
{
    used_xy.reset();
    const std::string declared = src.spec().get_string_attribute("oiio:ColorSpace");
    // Primaries need three channels: a grey image has none to convert.
    const std::optional<ocio::Chromaticities> xy
        = src.spec().nchannels >= 3 ? file_chromaticities(src.spec(), input_path, con)
                                    : std::nullopt;
    const bool declared_generic = OIIO::Strutil::iequals(declared, "Linear");
    std::string declared_known;  // the config's name for `declared`, "" if unknown
    if (xy && !a.iscolorspace && !declared.empty())
        if (Status s = ocio::find_colorspace(a.colorconfig, declared, declared_known); !s)
            return s;

    if (xy && !a.iscolorspace && (declared_known.empty() || declared_generic)) {
        const std::string why
            = declared.empty()   ? std::string("the file declares no colour space")
              : declared_generic ? "its oiio:ColorSpace '" + declared + "' names no primaries"
                                 : "its oiio:ColorSpace '" + declared
                                       + "' is not in the OCIO config";
        std::unique_ptr<ocio::InputConverter> conv;
        if (Status s = ocio::InputConverter::create_from_chromaticities(a.colorconfig, *xy, conv);
            !s) {
            std::unique_ptr<ocio::InputConverter> probe;  // the config, or the chromaticities?
            if (Status c = ocio::InputConverter::create(a.colorconfig, "scene_linear", probe); !c)
                return c;
            return Status::errorf("input '", input_path, "' gives its RGB by chromaticities (",
                                  describe_chromaticities(*xy), "; ", why, "), which ",
                                  "filmgrain cannot convert: ", s.message(),
                                  "; name its colour space with --iscolorspace NAME");
        }
        used_xy = xy;
        const std::string linear = "scene_linear '" + conv->scene_linear_colorspace() + "'";
        if (conv->is_noop()) {
            chosen = "scene_linear";
            con.info("input colour space: scene_linear (the file's chromaticities ("
                     + describe_chromaticities(*xy) + ") are those of " + linear
                     + ": nothing to convert; " + why + "; " + describe_config(conv->config())
                     + ")");
            return {};
        }
        chosen = "chromaticities";
        con.info("input colour space: the file's chromaticities (" + describe_chromaticities(*xy)
                 + "), converted to " + linear + " through '" + conv->via_colorspace()
                 + "' with Bradford adaptation to its white (" + why + "; "
                 + describe_config(conv->config()) + ")");
        return apply_input_converter(*conv, src);
    }

    std::string reason;
    if (a.iscolorspace) {
        chosen = *a.iscolorspace;
        reason = "--iscolorspace";
    } else if (!declared.empty()) {
        chosen = declared;
        reason = "the file's oiio:ColorSpace";
    } else {
        chosen = "scene_linear";
        reason = "the file declares none";
    }

    std::unique_ptr<ocio::InputConverter> conv;
    if (Status s = ocio::InputConverter::create(a.colorconfig, chosen, conv); !s) {
        // Is it the config or the colour space name?
        std::unique_ptr<ocio::InputConverter> probe;
        if (Status c = ocio::InputConverter::create(a.colorconfig, "scene_linear", probe); !c)
            return c;
        if (a.iscolorspace)
            return Status::errorf("--iscolorspace ", chosen, ": ", s.message());
        if (declared.empty())
            return s;
        return Status::errorf("input '", input_path, "' declares colour space '", declared,
                              "' (oiio:ColorSpace), which the OCIO config does not know; "
                              "name its colour space with --iscolorspace NAME (",
                              s.message(), ")");
    }
    if (xy) {
        // Say so when the file's chromaticities disagree with the space used
        // (or cannot be compared with it).
        bool same = false;
        const Status c = ocio::compare_chromaticities(a.colorconfig, chosen, *xy, same);
        if (!c || !same)
            reason += "; the file's chromaticities (" + describe_chromaticities(*xy) + ") "
                      + (c ? "differ from " + chosen + "'s and " : std::string())
                      + "are not used";
    }
    con.info("input colour space: " + chosen + " (" + reason + "; "
             + describe_config(conv->config()) + ")");
    return apply_input_converter(*conv, src);
}

}  // namespace filmgrain::cli
