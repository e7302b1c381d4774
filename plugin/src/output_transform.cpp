// filmgrain CLI: the output transforms (output_transform.h).
#include "output_transform.h"
#include "error_text.h"

#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/strutil.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <memory>

#include "filmgrain/ocio.h"

namespace filmgrain::cli {

// --- ADX -------------------------------------------------------------------

AdxEncoding adx_encoding(OutputKind kind)
{
    return kind == OutputKind::adx10 ? kAdx10 : kAdx16;
}

// --- The CLI's adapter -----------------------------------------------------

namespace {

/// A number in messages and metadata: printf's %g (6 significant digits).
std::string format_g(double v) { return OIIO::Strutil::sprintf("%g", v); }

/// The density image as a local packed float buffer (a copy when it is not
/// one already).
Status local_density(const OIIO::ImageBuf& density, int nlayers, OIIO::ImageBuf& local,
                     const float*& pixels)
{
    if (!density.initialized() || density.spec().nchannels != nlayers)
        return Status::errorf("internal: the density image has ",
                              density.initialized() ? density.spec().nchannels : 0,
                              " channels for a stock of ", nlayers, " layers");
    pixels = static_cast<const float*>(density.localpixels());
    if (pixels && density.spec().format == OIIO::TypeFloat)
        return {};
    if (!local.copy(density, OIIO::TypeFloat))
        return Status::errorf("cannot read the density image: ", trim(local.geterror()));
    pixels = static_cast<const float*>(local.localpixels());
    return {};
}

/// The output image: density's windows and metadata, 3 float channels R, G, B.
OIIO::ImageBuf rgb_like(const OIIO::ImageBuf& density)
{
    OIIO::ImageSpec spec = density.spec();
    spec.nchannels       = 3;
    spec.set_format(OIIO::TypeFloat);
    spec.channelnames = { "R", "G", "B" };
    spec.alpha_channel = -1;
    spec.z_channel     = -1;
    return OIIO::ImageBuf(spec);
}

/// "R a, G b, B c" with `sign` forcing a '+' on positive values.
std::string rgb_text(const Density3& v, bool sign = false)
{
    std::string out;
    const char* rgb[3] = { "R", "G", "B" };
    for (size_t c = 0; c < 3; ++c)
        out += std::string(c ? ", " : "") + rgb[c] + " " + (sign && v[c] >= 0.0 ? "+" : "")
               + format_g(v[c]);
    return out;
}

Status apply_adx(const OutputRequest& req, const FilmgrainOptions& opts,
                 const OIIO::ImageBuf& density, OIIO::ImageBuf& result, OutputReport& report)
{
    const Stock& stock = opts.stock;
    const std::string what = std::string("output=") + output_kind_name(req.kind);
    // MODEL.md 11, prepared by the core once per run (cached by the caller).
    AdxTransform transform;
    if (req.adx_cache && req.adx_cache->has_value()) {
        transform = **req.adx_cache;
    } else {
        AdxOptions o;
        o.timing = req.timing;
        if (Status s = stock_adx_transform(stock, opts.scene, o, transform); !s)
            return Status::errorf(what, req.timing == AdxTiming::grey ? ":timing=grey" : "",
                                  ": ", s.message());
        if (req.adx_cache)
            *req.adx_cache = transform;
    }
    const AdxEncoding enc = adx_encoding(req.kind);
    // The colour space as the config spells it (an ACES config's ADX10),
    // else the standard name.
    std::string resolved;
    if (Status s = ocio::find_colorspace(req.colorconfig, enc.colorspace, resolved); !s)
        return s;
    if (resolved.empty()) {
        resolved = enc.colorspace;
        report.warnings.push_back(what + ": the OCIO config has no colour space '"
                                  + enc.colorspace + "': the EXR is tagged " + enc.colorspace
                                  + " (SMPTE ST 2065-3) for a config that has one");
    }
    const int nl        = static_cast<int>(stock.layers.size());
    const float* pixels = nullptr;
    OIIO::ImageBuf local;
    if (Status s = local_density(density, nl, local, pixels); !s)
        return s;
    result                = rgb_like(density);
    const size_t npixels  = static_cast<size_t>(density.spec().image_pixels());
    report.clamped_values = encode_adx(transform, enc, pixels, npixels, nl, true,
                                       static_cast<float*>(result.localpixels()));
    report.colorspace = resolved;
    report.adx        = transform;
    if (report.clamped_values)
        report.warnings.push_back(
            std::to_string(report.clamped_values) + " of the " + std::to_string(npixels * 3)
            + " " + enc.colorspace + " code values were outside [0, "
            + format_g(enc.max_code) + "] (CDD outside ["
            + format_g(-enc.offset / enc.scale) + ", "
            + format_g((enc.max_code - enc.offset) / enc.scale) + "]) and were clamped");
    OIIO::ImageSpec& spec = result.specmod();
    spec.attribute("filmgrain:quantity",
                   std::string(enc.colorspace) + " code value / " + format_g(enc.max_code)
                       + ": " + format_g(enc.offset) + " + " + format_g(enc.scale)
                       + " x CDD, CDD = k (APD - APD D-min)"
                       + (transform.timing == AdxTiming::grey ? " + timing" : "")
                       + ", SMPTE ST 2065-3");
    spec.attribute("filmgrain:printing_density", printing_density_source(transform));
    spec.attribute("filmgrain:adx_dmin", rgb_text(transform.status_m_dmin));
    spec.attribute("filmgrain:apd_dmin", rgb_text(transform.apd_dmin));
    spec.attribute("filmgrain:adx_gains", rgb_text(transform.gains));
    spec.attribute("filmgrain:adx_timing",
                   transform.timing == AdxTiming::grey
                       ? "grey: " + rgb_text(transform.timing_cdd, true)
                       : std::string("off"));
    return {};
}

Status apply_regrain(const OutputRequest& req, const FilmgrainOptions& opts,
                     const OIIO::ImageBuf& input, const OIIO::ImageBuf& density,
                     OIIO::ImageBuf& result, OutputReport& report)
{
    const Stock& stock = opts.stock;
    // The scan must be the input frame's grid: each scan pixel's mean is
    // the input pixel under it.
    const OIIO::ImageSpec& is = input.spec();
    const OIIO::ROI frame = film_frame_window(is);
    const int64_t frame_w = frame.width(), frame_h = frame.height();
    const int64_t fx = frame.xbegin, fy = frame.ybegin;
    const OIIO::ImageSpec& ds = density.spec();
    if (ds.full_width != frame_w || ds.full_height != frame_h)
        return Status::errorf("output=regrain needs the scan at the input's size (", frame_w,
                              "x", frame_h, "): the scan is ", ds.full_width, "x",
                              ds.full_height, "; drop scan= (the positive's local mean is "
                              "the input pixel under each scan pixel)");
    if (is.nchannels != 1 && is.nchannels < 3)
        return Status::errorf("output=regrain: the input has ", is.nchannels,
                              " channels: expected 1 or at least 3");
    std::vector<ExpectedCurve> curves;
    if (req.curves_cache && !req.curves_cache->empty()) {
        curves = *req.curves_cache;
    } else {
        if (Status s = expected_curves(stock, opts.scene, ExpectedCurveOptions(), curves); !s)
            return Status::errorf("output=regrain: ", s.message());
        if (req.curves_cache)
            *req.curves_cache = curves;
    }
    RegrainModel model;
    if (Status s = make_regrain_model(stock, std::move(curves), model); !s)
        return s;
    const std::string dst = req.ocolorspace.empty() ? std::string("scene_linear") : req.ocolorspace;
    std::unique_ptr<ocio::Converter> conv;
    if (Status s = ocio::Converter::create(req.colorconfig, "scene_linear", dst, conv); !s)
        return Status::errorf("--ocolorspace ", dst, ": ", s.message());

    const float* pixels = nullptr;
    OIIO::ImageBuf local;
    const int nl = static_cast<int>(stock.layers.size());
    if (Status s = local_density(density, nl, local, pixels); !s)
        return s;
    result      = rgb_like(density);
    float* out  = static_cast<float*>(result.localpixels());
    const int w = ds.width, h = ds.height;
    std::vector<float> in_row(static_cast<size_t>(w) * 3);
    const int in_nc = is.nchannels;
    for (int y = 0; y < h; ++y) {
        // The input pixels under this row (black outside the data window).
        const int64_t iy = fy + ds.y + y;
        for (int x = 0; x < w; ++x) {
            const int64_t ix = fx + ds.x + x;
            float p[3]       = { 0.0f, 0.0f, 0.0f };
            if (ix >= is.x && ix < is.x + is.width && iy >= is.y && iy < is.y + is.height) {
                float px[4] = { 0.0f, 0.0f, 0.0f, 0.0f };
                input.getpixel(static_cast<int>(ix), static_cast<int>(iy), 0, px,
                               std::min(in_nc, 3));
                if (in_nc == 1)
                    px[1] = px[2] = px[0];
                std::copy_n(px, 3, p);
            }
            std::copy_n(p, 3, &in_row[static_cast<size_t>(x) * 3]);
        }
        for (int x = 0; x < w; ++x) {
            const size_t o = static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x);
            regrain_pixel(model, &in_row[static_cast<size_t>(x) * 3], pixels + o * static_cast<size_t>(nl),
                          out + o * 3);
        }
    }
    conv->apply_rgb(out, static_cast<size_t>(w) * static_cast<size_t>(h));
    report.colorspace = conv->destination_name();
    result.specmod().attribute("filmgrain:quantity",
                               "scene-linear positive: the input plus the film's grain "
                               "(regrain), in " + report.colorspace);
    return {};
}

}  // namespace

Status apply_output(const OutputRequest& req, const FilmgrainOptions& opts,
                    const OIIO::ImageBuf& input, const OIIO::ImageBuf& density,
                    OIIO::ImageBuf& out, OutputReport& report)
{
    report = OutputReport();
    try {
        if (req.kind != OutputKind::regrain && !req.ocolorspace.empty())
            return Status::errorf("--ocolorspace ", req.ocolorspace,
                                  " applies to output=regrain only (the output is ",
                                  output_kind_name(req.kind), ")");
        if (req.timing != AdxTiming::off && req.kind != OutputKind::adx10
            && req.kind != OutputKind::adx16)
            return Status::errorf("timing=", name_of(req.timing),
                                  " applies to output=adx10 and adx16 only (the output is ",
                                  output_kind_name(req.kind), ")");
        OIIO::ImageBuf result;
        switch (req.kind) {
        case OutputKind::density:
            if (&out != &density)
                out.copy(density, OIIO::TypeUnknown);
            out.specmod().attribute("filmgrain:output", output_kind_name(req.kind));
            return {};
        case OutputKind::adx10:
        case OutputKind::adx16:
            if (Status s = apply_adx(req, opts, density, result, report); !s)
                return s;
            break;
        case OutputKind::regrain:
            if (Status s = apply_regrain(req, opts, input, density, result, report); !s)
                return s;
            break;
        }
        OIIO::ImageSpec& spec = result.specmod();
        spec.attribute("filmgrain:output", output_kind_name(req.kind));
        spec.attribute("filmgrain:colorspace", report.colorspace);
        spec.attribute("oiio:ColorSpace", report.colorspace);
        out = std::move(result);
        return {};
    } catch (const std::exception& e) {
        return Status::errorf("output=", output_kind_name(req.kind), ": ", e.what());
    }
}

}  // namespace filmgrain::cli
