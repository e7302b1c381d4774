// filmgrain CLI: one image rendered (frame_render.h).
#include "frame_render.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/hash.h>
#include <OpenImageIO/imageio.h>

#include <nlohmann/json.hpp>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "error_text.h"
#include "filmgrain/chart.h"
#include "filmgrain/version.h"
#include "filmgrain/wedge.h"
#include "input_image.h"
#include "output_files.h"
#include "preview.h"
#include "scene_linear.h"
#include "stats_json.h"

namespace filmgrain::cli {

namespace fs = std::filesystem;

namespace {

/// Output limits (docs/reference.md, "Limits and guarantees"): the rendered region
/// (the ROI, else the whole scan) is allocated as floats, one per layer.
constexpr int64_t kMaxOutputPixels = int64_t(1) << 28;
constexpr int64_t kMaxOutputValues = int64_t(1) << 31;

OIIO::ImageBuf make_wedge()
{
    const WedgeSpec spec;
    const std::vector<float> pixels = make_step_wedge(spec);
    OIIO::ImageBuf buf(OIIO::ImageSpec(static_cast<int>(spec.width_px()),
                                       static_cast<int>(spec.height_px), 1, OIIO::TypeFloat));
    buf.set_pixels(buf.roi(), OIIO::TypeFloat, pixels.data());
    return buf;
}

OIIO::ImageBuf make_chart()
{
    const ChartSpec spec;
    const std::vector<float> pixels = make_look_chart(spec);
    OIIO::ImageBuf buf(OIIO::ImageSpec(static_cast<int>(spec.width_px),
                                       static_cast<int>(spec.height_px), 3, OIIO::TypeFloat));
    buf.set_pixels(buf.roi(), OIIO::TypeFloat, pixels.data());
    return buf;
}

/// Writes `buf` as `format` into the reserved output `final_path` (created
/// only now, unnamed until commit: see OutputFiles).
Status write_image(OutputFiles& files, const std::string& final_path, OIIO::ImageBuf& buf,
                   OIIO::TypeDesc type, const char* format)
{
    std::FILE* f = nullptr;
    if (Status s = files.open(final_path, f); !s)
        return s;
    bool ok = false;
    {
        OIIO::Filesystem::IOFile proxy(f, OIIO::Filesystem::IOProxy::Write);
        buf.set_write_ioproxy(&proxy);
        ok = buf.write(final_path, type, format);
        buf.set_write_ioproxy(nullptr);
    }
    errno = 0;
    if (std::fclose(f) != 0 && ok)
        return Status::errorf("cannot write '", final_path, "': ", std::strerror(errno));
    if (!ok)
        return Status::errorf("cannot write '", final_path, "': ", trim(buf.geterror()));
    return {};
}

/// The positive preview of the negative `density`: a timed print through
/// ADX and the OCIO config's display view (make_film_preview), or the plain
/// inversion with a warning where the config cannot. `cache`: the run's
/// printing density transform (built by the first frame).
Status write_preview(OutputFiles& files, const OIIO::ImageBuf& density,
                     const FilmgrainOptions& opts, const std::string& colorconfig,
                     const Console& con, const std::string& final_path,
                     const std::shared_ptr<std::optional<AdxTransform>>& cache)
{
    const OIIO::ImageSpec& ds = density.spec();
    Preview p;
    std::string warning;
    if (Status s = make_film_preview(static_cast<const float*>(density.localpixels()), ds.width,
                                     ds.height, opts.stock, opts.scene, colorconfig, p, warning,
                                     cache);
        !s)
        return Status::errorf("preview: ", s.message());
    if (!warning.empty())
        con.warning(warning);
    OIIO::ImageSpec spec(ds.width, ds.height, p.channels, OIIO::TypeUInt8);
    if (p.channels == 1)
        spec.channelnames = { "Y" };
    spec.attribute("oiio:ColorSpace", "sRGB");
    OIIO::ImageBuf buf(spec);
    buf.set_pixels(buf.roi(), OIIO::TypeUInt8, p.pixels.data());
    if (Status s = write_image(files, final_path, buf, OIIO::TypeUnknown, "png"); !s)
        return Status::errorf("preview: ", s.message());
    return {};
}

}  // namespace

/// Refuses, before any work, an output region larger than the limits.
Status check_output_size(const FilmgrainOptions& opts, const OIIO::ImageSpec& input,
                         const FilmgrainCommand& cmd)
{
    // The scan covers the display window (else the data window); the
    // output is the data window's scan (rounded outward), or the ROI.
    ScanGeometry scan;
    if (Status s = frame_scan(input, opts, scan); !s)
        return s;
    Roi data;
    if (Status s = IBA::data_window_scan(input, opts, data); !s)
        return s;
    const int64_t w = cmd.has_roi ? cmd.roi_width : data.width();
    const int64_t h = cmd.has_roi ? cmd.roi_height : data.height();
    const int64_t layers = static_cast<int64_t>(opts.stock.layers.size());
    if (w > kMaxOutputPixels || h > kMaxOutputPixels || w * h > kMaxOutputPixels
        || w * h * layers > kMaxOutputValues)
        return Status::errorf("scan = ", scan.width, "x", scan.height, cmd.has_roi ? " (roi " : "",
                              cmd.has_roi ? std::to_string(w) + "x" + std::to_string(h) + ")" : "",
                              ": an output of ", w, "x", h, " pixels of ", layers,
                              " layers is larger than filmgrain writes (at most ",
                              kMaxOutputPixels, " pixels and ", kMaxOutputValues,
                              " values); render a part of it with roi=X,Y,W,H");
    return {};
}

/// The files the render reads besides INPUT (a stock JSON, an OCIO config)
/// must not be any of its outputs: --stats can have any name.
Status check_outputs_spare_inputs(const CliArgs& a, const FrameJob& job)
{
    const char* ocio_env = std::getenv("OCIO");
    const std::pair<const char*, std::string> inputs[] = {
        { "the stock file", preset_json(a.filmgrain.stock).empty() ? a.filmgrain.stock : "" },
        { "the --colorconfig file", a.colorconfig },
        { "the $OCIO config", a.colorconfig.empty() && ocio_env ? ocio_env : "" },
    };
    const std::pair<const char*, const std::string*> outputs[] = {
        { "-o", &job.output }, { "--stats", &job.stats }, { "--preview", &job.preview }
    };
    for (const auto& [what_in, in] : inputs)
        for (const auto& [what_out, out] : outputs) {
            std::error_code ec;
            if (!in.empty() && !out->empty() && fs::equivalent(in, *out, ec) && !ec)
                return Status::errorf(what_out, " and ", what_in, " name the same file '",
                                      *out, "': refusing to overwrite it");
        }
    return {};
}

std::string format_seconds(double s)
{
    std::ostringstream out;
    out << std::setprecision(3) << s;
    return out.str();
}

/// Identifies what an output was made from, for --skip-existing: a SHA-1
/// (OpenImageIO's) of the settings that decide the pixels, as canonical
/// JSON: version, stock (complete), scene (frame included), engine options,
/// scan, roi, pixel type, compression, colour conversion, and the input
/// file's path, size and modification time. Not the tile size or thread
/// count (they never change the output).
std::string settings_hash(const RenderContext& ctx, const FilmgrainOptions& opts,
                          const FrameJob& job)
{
    using Json            = nlohmann::ordered_json;
    const CliArgs& a      = ctx.args;
    const EngineOptions& e = opts.engine_options;
    const SceneSettings& sc = opts.scene;
    Json j;
    j["version"]  = version_string();
    j["stock"]    = stock_to_json(opts.stock);
    // The keys are frozen as they were when the hash was introduced (e.g.
    // frame_width_mm, now width_mm; static, now static_grain): a renamed key
    // would change every hash and re-render every --skip-existing frame.
    j["scene"]    = { { "exposure_stops", sc.exposure_stops },
                      { "shutter_s", sc.shutter_s },
                      { "frame_width_mm", sc.width_mm },
                      { "seed", sc.seed },
                      { "frame", frame_json<Json>(sc.frame) },
                      { "static", sc.static_grain },
                      { "edge", name_of(sc.edge) } };
    j["engine"]   = { { "engine", name_of(e.engine) },
                      { "tolerance", e.tolerance },
                      { "kinetics", e.kinetics ? name_of(*e.kinetics) : "" },
                      { "photons", e.photons ? name_of(*e.photons) : "" },
                      { "coverage", e.coverage ? name_of(*e.coverage) : "" },
                      { "grains", e.grains ? name_of(*e.grains) : "" },
                      { "scale", e.scale ? name_of(*e.scale) : "" },
                      { "samples", e.samples } };
    const FilmgrainCommand& cmd = a.filmgrain;
    j["scan"]     = { opts.scan_width, opts.scan_height };
    j["roi"]      = cmd.has_roi ? Json { cmd.roi_x, cmd.roi_y, cmd.roi_width, cmd.roi_height }
                                : Json(nullptr);
    j["output"]   = { { "kind", output_kind_name(cmd.output) },
                      { "ocolorspace", a.ocolorspace.value_or("") } };
    // ADX and the preview are printing densities with ADX's gains since
    // MODEL.md 11 (issue 40): files written before (Status M, no gains,
    // untimed previews) are not up to date. Density and regrain outputs
    // without a preview keep their hashes.
    if (cmd.output == OutputKind::adx10 || cmd.output == OutputKind::adx16)
        j["output"]["adx"] = { { "encoding", "apd, k (1, 0.92, 0.95)" },
                               { "timing", name_of(cmd.timing) } };
    if (!job.preview.empty())
        j["preview"] = "adx16 timed on grey";
    j["type"]     = a.output_type == OutputType::half16 ? "half" : "float";
    j["compression"] = a.output_modifiers.compression;
    const char* ocio_env = std::getenv("OCIO");
    j["color"]    = { { "config", !a.colorconfig.empty() ? a.colorconfig
                                  : ocio_env            ? std::string("$OCIO=") + ocio_env
                                                        : std::string("embedded") },
                      { "iscolorspace", a.iscolorspace.value_or("") } };
    Json input = { { "wedge", a.wedge } };
    if (a.chart)  // only then: the hashes of earlier renders stay valid
        input["chart"] = true;
    if (!job.input.empty()) {
        std::error_code ec;
        input["path"]  = job.input;
        input["size"]  = static_cast<uint64_t>(fs::file_size(job.input, ec));
        input["mtime"] = static_cast<int64_t>(
            fs::last_write_time(job.input, ec).time_since_epoch().count());
    }
    j["input"] = std::move(input);
    return OIIO::SHA1::digest(j.dump().data(), j.dump().size());
}

/// --skip-existing: the job's EXR exists and says it was made with `hash`,
/// and its --stats and --preview files exist when asked for.
bool up_to_date(const FrameJob& job, const std::string& hash)
{
    std::error_code ec;
    for (const std::string* p : { &job.stats, &job.preview })
        if (!p->empty() && !fs::exists(*p, ec))
            return false;
    if (!fs::exists(job.output, ec))
        return false;
    auto in = OIIO::ImageInput::open(job.output);
    if (!in) {
        OIIO::geterror();  // a damaged output: render it again
        return false;
    }
    const bool same = in->spec().get_string_attribute("filmgrain:settings_hash") == hash;
    in->close();
    return same;
}

/// Renders one image (a single image, or one frame of a sequence) and
/// writes its outputs all-or-nothing. Errors are returned; an interruption
/// is reported as Status "interrupted" (the caller checks interrupted()).
Status render_one(const RenderContext& ctx, const FrameJob& job, FrameOutcome& outcome)
{
    const auto t_start = Clock::now();
    const CliArgs& a   = ctx.args;
    const Console& con = ctx.con;
    const FilmgrainCommand& cmd = a.filmgrain;
    FilmgrainOptions opts = ctx.opts;
    if (job.frame)
        opts.scene.frame = *job.frame;
    outcome = FrameOutcome::rendered;

    std::error_code ec;
    if (!job.input.empty() && job.frame && !fs::exists(job.input, ec) && a.skip_missing) {
        outcome = FrameOutcome::missing;
        con.warning("frame " + std::to_string(*job.frame) + ": input '" + job.input
                    + "' does not exist: skipped (--skip-missing)");
        return {};
    }
    const std::string hash = settings_hash(ctx, opts, job);
    if (a.skip_existing && up_to_date(job, hash)) {
        outcome = FrameOutcome::up_to_date;
        con.info("'" + job.output + "' is up to date (same settings): skipped");
        return {};
    }

    OIIO::ROI roi;  // undefined: the whole scan
    if (cmd.has_roi)
        roi = OIIO::ROI(static_cast<int>(cmd.roi_x), static_cast<int>(cmd.roi_x + cmd.roi_width),
                        static_cast<int>(cmd.roi_y),
                        static_cast<int>(cmd.roi_y + cmd.roi_height));

    // Check every output's directory first: an unwritable one fails now, not
    // after the render. Files are created only when written (OutputFiles).
    OutputFiles files;
    for (const std::string* p : { &job.output, &job.preview, &job.stats })
        if (!p->empty())
            if (Status s = files.reserve(*p); !s)
                return s;

    RunReport report;
    report.stock_name = opts.stock.name;
    report.scene      = opts.scene;

    // Read.
    auto t = Clock::now();
    OIIO::ImageBuf src;
    OIIO::ImageSpec header;  // the input's own spec (src may hold only a window of it)
    if (a.wedge || a.chart) {  // a built-in scene, already scene-linear
        src                     = a.wedge ? make_wedge() : make_chart();
        header                  = src.spec();
        report.input_file       = a.wedge ? "wedge" : "chart";
        report.input_colorspace = "scene_linear";
        con.info(std::string("input: the built-in ")
                 + (a.wedge ? "step wedge, " : "look chart, ") + std::to_string(src.spec().width)
                 + "x" + std::to_string(src.spec().height)
                 + (a.wedge ? " scene-linear grey" : " scene-linear RGB"));
    } else {
        // Everything the header says is checked before any pixel is read.
        InputHeader input;
        if (Status s = read_input_header(job.input, a.input_selection, input); !s)
            return s;
        if (Status s = check_output_size(opts, input.spec, cmd); !s)
            return Status::errorf("input '", job.input, "': ", s.message());
        con.info("input: " + input.description);
        if (Status s = read_input_pixels(job.input, input, opts, cmd, src); !s)
            return s;
        header            = input.spec;
        report.input_file = job.input;
    }
    if (a.wedge || a.chart)
        if (Status s = check_output_size(opts, header, cmd); !s)
            return s;
    report.seconds.read = seconds_since(t);
    if (interrupted())
        return Status::error("interrupted");

    // Colour.
    t = Clock::now();
    if (!a.wedge && !a.chart)
        if (Status s = convert_to_scene_linear(a, job.input, src, con, report.input_colorspace,
                                               report.input_chromaticities);
            !s)
            return s;
    report.seconds.color = seconds_since(t);
    if (interrupted())
        return Status::error("interrupted");

    // Simulate.
    t = Clock::now();
    opts.progress = [&con](double f) {
        if (interrupted())
            return false;
        con.progress(f);
        return true;
    };
    OIIO::ImageBuf dst;
    opts.stats    = &report.render;
    const bool ok = IBA::filmgrain(dst, src, opts, roi, a.threads);
    con.end_progress();
    report.seconds.simulate = seconds_since(t);
    if (interrupted())
        return Status::error("interrupted");
    if (!ok) {
        // The operator's messages start with its name, as OIIO's do.
        std::string msg = trim(dst.geterror());
        if (msg.rfind("filmgrain: ", 0) == 0)
            msg.erase(0, std::strlen("filmgrain: "));
        return Status::error(msg);
    }

    if (Status s = report_scan(header, opts, report); !s)
        return s;
    const OIIO::ROI data = dst.roi();
    report.roi           = Roi { data.xbegin, data.ybegin, data.xend, data.yend };

    const InputStats& in = report.render.input;
    if (in.nan_pixels)
        con.warning(std::to_string(in.nan_pixels) + " of the " + std::to_string(in.pixels_read)
                    + " input pixels read have NaN values: they expose nothing");
    if (in.saturated_pixels)
        con.warning(std::to_string(in.saturated_pixels) + " of the "
                    + std::to_string(in.pixels_read)
                    + " input pixels read (+Inf, or past the largest exposure the kinetics "
                      "represent) saturate: clamped to that exposure, where every grain "
                      "develops");
    if (in.negative_pixels)
        con.warning(std::to_string(in.negative_pixels) + " of the "
                    + std::to_string(in.pixels_read)
                    + " input pixels read have a negative channel: it enters each layer's "
                      "weighted sum as is, and a negative layer exposure counts as none");

    // What the EXR holds: the density, or ADX code values or the regrain
    // positive made from it (--filmgrain:output=).
    // The density itself is written in place (no copy of the frame).
    report.output = output_kind_name(cmd.output);
    OIIO::ImageBuf transformed;
    OIIO::ImageBuf& result = cmd.output == OutputKind::density ? dst : transformed;
    OutputReport output_report;
    if (Status s = apply_output(
            OutputRequest { cmd.output, a.colorconfig, a.ocolorspace.value_or(""),
                            ctx.regrain_curves, cmd.timing, ctx.adx_transform },
            opts,
            src, dst, result, output_report);
        !s)
        return s;
    for (const std::string& w : output_report.warnings)
        con.warning(w);

    // Write, all or nothing.
    t = Clock::now();
    result.specmod().attribute("compression", a.output_modifiers.compression);
    result.specmod().attribute("filmgrain:settings_hash", hash);
    const OIIO::TypeDesc type
        = a.output_type == OutputType::half16 ? OIIO::TypeHalf : OIIO::TypeFloat;
    if (Status s = write_image(files, job.output, result, type, "openexr"); !s)
        return s;
    if (!job.preview.empty())
        if (Status s = write_preview(files, dst, opts, a.colorconfig, con, job.preview,
                                     ctx.preview_transform);
            !s)
            return s;
    report.seconds.write = seconds_since(t);
    report.seconds.total = seconds_since(t_start);
    if (!job.stats.empty())
        if (Status s = files.write(job.stats, stats_json(report)); !s)
            return Status::errorf("--stats: ", s.message());
    if (interrupted())
        return Status::error("interrupted");
    if (Status s = files.commit(); !s)
        return s;

    std::string layers;
    for (const Layer& l : opts.stock.layers)
        layers += (layers.empty() ? "" : ",") + l.name;
    std::ostringstream summary;
    summary << "wrote " << job.output << " (" << data.width() << "x" << data.height();
    if (data.width() != report.scan.width || data.height() != report.scan.height)
        summary << " of the " << report.scan.width << "x" << report.scan.height << " scan";
    summary << ", " << opts.stock.layers.size()
            << (opts.stock.layers.size() == 1 ? " layer " : " layers ") << layers << ") in "
            << format_seconds(seconds_since(t_start)) << " s";
    con.info(summary.str());
    return {};
}

}  // namespace filmgrain::cli
