// filmgrain: the command-line tool. oiiotool-shaped; see `filmgrain --help`.
//
// main() only orders the stages: parse the command line, read the input (or
// make the wedge or the chart), convert it to scene-linear (OCIO), run the
// operator, write the outputs all-or-nothing. It does no maths of its own.
#include <OpenImageIO/half.h>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/hash.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/parallel.h>
#include <OpenImageIO/strutil.h>

#include <nlohmann/json.hpp>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "cli_args.h"
#include "input_image.h"
#include "filmgrain/chart.h"
#include "filmgrain/imagebufalgo_filmgrain.h"
#include "filmgrain/ocio.h"
#include "filmgrain/version.h"
#include "filmgrain/wedge.h"
#include "output_files.h"
#include "output_transform.h"
#include "preview.h"
#include "sequence.h"
#include "stats_json.h"

namespace filmgrain::cli {

namespace {

namespace fs = std::filesystem;
using Clock  = std::chrono::steady_clock;

// ---------------------------------------------------------------------------
// Interruption: SIGINT/SIGTERM/SIGHUP only set a flag. The render polls it
// through the progress callback (and cancels), the other stages check it
// between steps; the outputs' temporary files are then removed and nothing
// is renamed into place.

volatile std::sig_atomic_t g_signal = 0;

extern "C" void on_signal(int sig) { g_signal = sig; }

void install_signal_handlers()
{
    struct sigaction sa;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    for (int sig : { SIGINT, SIGTERM, SIGHUP })
        sigaction(sig, &sa, nullptr);
}

bool interrupted() { return g_signal != 0; }

double seconds_since(Clock::time_point t)
{
    return std::chrono::duration<double>(Clock::now() - t).count();
}

std::string trim(std::string s)
{
    while (!s.empty() && (s.back() == '\n' || s.back() == ' '))
        s.pop_back();
    return s;
}

// ---------------------------------------------------------------------------
// Messages: everything goes to stderr; -q keeps only errors.

class Console {
public:
    /// Progress is shown on a terminal once a run has taken a second, and
    /// from the start with --progress (`forced`); never with -q.
    Console(bool quiet, bool terminal, bool forced = false)
        : m_quiet(quiet)
        , m_show_progress((terminal || forced) && !quiet)
        , m_delay_s(forced ? 0.0 : 1.0)
        , m_start(Clock::now())
    {
    }

    void info(const std::string& msg) const
    {
        if (m_quiet)
            return;
        end_progress();
        std::cerr << "filmgrain: " << msg << std::endl;
    }
    void warning(const std::string& msg) const
    {
        if (m_quiet)
            return;
        end_progress();
        std::cerr << "filmgrain: warning: " << msg << std::endl;
    }
    int fail(const std::string& msg) const
    {
        end_progress();
        std::cerr << "filmgrain: error: " << msg << std::endl;
        return kExitError;
    }
    int fail(const Status& s) const { return fail(s.message()); }
    int fail_interrupted(const std::string& what) const
    {
        const int sig = static_cast<int>(g_signal);
        const char* name = sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM"
                                                    : sig == SIGHUP  ? "SIGHUP"
                                                                     : "a signal";
        fail(std::string("interrupted by ") + name + ": " + what);
        return kExitSignalBase + sig;
    }

    /// The sequence position shown by progress(): frame `index` (0-based)
    /// of `count`, numbered `number`; count 0: a single image.
    void set_frame(size_t index, size_t count, std::optional<int> number) const
    {
        m_index  = index;
        m_count  = count;
        m_number = number;
    }

    /// A single updating line:
    /// "filmgrain: frame 3/100 (1003)  42%  elapsed 0:12  left ~4:10".
    /// The fraction is the current image's; elapsed and left are the run's.
    void progress(double fraction) const
    {
        const double elapsed = seconds_since(m_start);
        if (!m_show_progress || elapsed < m_delay_s)
            return;
        const int percent = static_cast<int>(fraction * 100.0);
        if (percent == m_percent && elapsed - m_shown_at < 1.0)
            return;
        m_percent  = percent;
        m_shown_at = elapsed;
        std::ostringstream line;
        line << "\rfilmgrain: ";
        if (m_count > 0)
            line << "frame " << m_index + 1 << "/" << m_count << " (" << *m_number << ") ";
        else
            line << "simulating ";
        line << std::setw(3) << percent << "%  elapsed " << clock_text(elapsed);
        const double done = m_count > 0 ? (static_cast<double>(m_index) + fraction)
                                              / static_cast<double>(m_count)
                                        : fraction;
        if (done > 0.01)
            line << "  left ~" << clock_text(elapsed * (1.0 - done) / done);
        line << "   ";
        std::cerr << line.str() << std::flush;
        m_line_open = true;
    }
    void end_progress() const
    {
        if (m_line_open)
            std::cerr << std::endl;
        m_line_open = false;
        m_percent   = -1;
    }

private:
    static std::string clock_text(double seconds)
    {
        const long s = static_cast<long>(seconds + 0.5);
        std::ostringstream out;
        if (s >= 3600)
            out << s / 3600 << ":" << std::setw(2) << std::setfill('0') << s / 60 % 60;
        else
            out << s / 60;
        out << ":" << std::setw(2) << std::setfill('0') << s % 60;
        return out.str();
    }

    bool m_quiet;
    bool m_show_progress;
    double m_delay_s;
    Clock::time_point m_start;
    mutable size_t m_index = 0, m_count = 0;
    mutable std::optional<int> m_number;
    mutable int m_percent    = -1;
    mutable double m_shown_at = 0.0;
    mutable bool m_line_open = false;
};

// ---------------------------------------------------------------------------
// Informational commands.

int list_stocks()
{
    for (const std::string& name : preset_names()) {
        Stock stock;
        const Status s = load_stock(name, stock);
        std::cout << name << (name == default_preset_name() ? " (default)" : "") << "\n    "
                  << (s ? stock.description : "cannot load: " + s.message()) << "\n";
    }
    return 0;
}

int print_stock(const std::string& name_or_path, const Console& con)
{
    Stock stock;
    if (Status s = load_stock(name_or_path, stock); !s)
        return con.fail(s);
    std::cout << stock_to_json(stock, 2) << "\n";
    return 0;
}

// ---------------------------------------------------------------------------
// Rendering stages.

/// Output limits (docs/reference.md, "Limits and guarantees"): the rendered region
/// (the ROI, else the whole scan) is allocated as floats, one per layer.
constexpr int64_t kMaxOutputPixels = int64_t(1) << 28;
constexpr int64_t kMaxOutputValues = int64_t(1) << 31;

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
    if (xy && !a.has_iscolorspace && !declared.empty())
        if (Status s = ocio::find_colorspace(a.colorconfig, declared, declared_known); !s)
            return s;

    if (xy && !a.has_iscolorspace && (declared_known.empty() || declared_generic)) {
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
    if (a.has_iscolorspace) {
        chosen = a.iscolorspace;
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
        if (a.has_iscolorspace)
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

std::string format_seconds(double s)
{
    std::ostringstream out;
    out << std::setprecision(3) << s;
    return out.str();
}

/// What one image's render needs besides its files: the options shared by
/// every frame (stock loaded once).
struct RenderContext {
    const CliArgs& args;
    const Console& con;
    FilmgrainOptions opts;  ///< scene.frame is set per frame
    /// output=regrain's expected curves, built by the first frame.
    std::shared_ptr<std::vector<ExpectedCurve>> regrain_curves
        = std::make_shared<std::vector<ExpectedCurve>>();
    /// output=adx10|adx16's and the preview's printing density transforms
    /// (MODEL.md 11), built by the first frame.
    std::shared_ptr<std::optional<AdxTransform>> adx_transform
        = std::make_shared<std::optional<AdxTransform>>();
    std::shared_ptr<std::optional<AdxTransform>> preview_transform
        = std::make_shared<std::optional<AdxTransform>>();
};

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
    j["scene"]    = { { "exposure_stops", sc.exposure_stops },
                      { "shutter_s", sc.shutter_s },
                      { "frame_width_mm", sc.frame_width_mm },
                      { "seed", sc.seed },
                      { "frame", sc.frame ? Json(*sc.frame) : Json(nullptr) },
                      { "static", sc.static_grain },
                      { "edge", frame_edge_name(sc.edge) } };
    j["engine"]   = { { "engine", engine_name(e.engine) },
                      { "tolerance", e.tolerance },
                      { "kinetics", e.kinetics ? kinetics_method_name(*e.kinetics) : "" },
                      { "photons", e.exposure_method ? exposure_method_name(*e.exposure_method) : "" },
                      { "coverage", e.coverage ? coverage_method_name(*e.coverage) : "" },
                      { "grains", e.grains ? grain_method_name(*e.grains) : "" },
                      { "scale", e.scale ? scale_method_name(*e.scale) : "" },
                      { "samples", e.coverage_samples } };
    const FilmgrainCommand& cmd = a.filmgrain;
    j["scan"]     = { opts.scan_width, opts.scan_height };
    j["roi"]      = cmd.has_roi ? Json { cmd.roi_x, cmd.roi_y, cmd.roi_width, cmd.roi_height }
                                : Json(nullptr);
    j["output"]   = { { "kind", output_kind_name(cmd.output) },
                      { "ocolorspace", a.has_ocolorspace ? a.ocolorspace : "" } };
    // ADX and the preview are printing densities with ADX's gains since
    // MODEL.md 11 (issue 40): files written before (Status M, no gains,
    // untimed previews) are not up to date. Density and regrain outputs
    // without a preview keep their hashes.
    if (cmd.output == OutputKind::adx10 || cmd.output == OutputKind::adx16)
        j["output"]["adx"] = { { "encoding", "apd, k (1, 0.92, 0.95)" },
                               { "timing", adx_timing_name(cmd.timing) } };
    if (!job.preview.empty())
        j["preview"] = "adx16 timed on grey";
    j["type"]     = a.output_type == OutputType::half16 ? "half" : "float";
    j["compression"] = a.output_modifiers.compression;
    const char* ocio_env = std::getenv("OCIO");
    j["color"]    = { { "config", !a.colorconfig.empty() ? a.colorconfig
                                  : ocio_env            ? std::string("$OCIO=") + ocio_env
                                                        : std::string("embedded") },
                      { "iscolorspace", a.has_iscolorspace ? a.iscolorspace : "" } };
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

enum class FrameOutcome { rendered, up_to_date, missing };

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
    const bool ok = IBA::filmgrain(dst, src, opts, roi, a.threads, &report.render);
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
            OutputRequest { cmd.output, a.colorconfig, a.ocolorspace, ctx.regrain_curves,
                            cmd.timing, ctx.adx_transform },
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

int render(const CliArgs& a, const Console& con)
{
    const auto t_start = Clock::now();
    if (Status s = validate_render_args(a); !s)
        return con.fail(s);
    std::vector<FrameJob> jobs;
    if (Status s = plan_frames(a, jobs); !s)
        return con.fail(s);

    RenderContext ctx { a, con, {}, std::make_shared<std::vector<ExpectedCurve>>() };
    const FilmgrainCommand& cmd = a.filmgrain;
    if (Status s = load_stock(cmd.stock, ctx.opts.stock); !s)
        return con.fail(s);
    ctx.opts.scene = cmd.scene;
    if (a.wedge && !cmd.has_width_mm)
        ctx.opts.scene.frame_width_mm = WedgeSpec().strip_width_mm;
    if (a.chart && !cmd.has_width_mm)
        ctx.opts.scene.frame_width_mm = ChartSpec().strip_width_mm;
    ctx.opts.engine_options = cmd.engine_options;
    ctx.opts.scan_width     = cmd.scan_width;
    ctx.opts.scan_height    = cmd.scan_height;
    ctx.opts.tile_size_px   = cmd.tile_size_px;

    if (a.dry_run) {
        for (const FrameJob& job : jobs) {
            FilmgrainOptions opts = ctx.opts;
            if (job.frame)
                opts.scene.frame = *job.frame;
            const std::string hash = settings_hash(ctx, opts, job);
            std::error_code ec;
            const bool exists = a.wedge || a.chart || fs::exists(job.input, ec);
            // What the render would refuse from the input's header (its
            // pixels are not read): null when nothing.
            std::string refusal;
            if (exists && !a.wedge && !a.chart) {
                InputHeader input;
                Status st = read_input_header(job.input, a.input_selection, input);
                if (st)
                    if (Status o = check_output_size(opts, input.spec, cmd); !o)
                        st = Status::errorf("input '", job.input, "': ", o.message());
                if (!st)
                    refusal = st.message();
            }
            const nlohmann::ordered_json line
                = { { "frame", job.frame ? nlohmann::ordered_json(*job.frame)
                                         : nlohmann::ordered_json(nullptr) },
                    { "input", a.wedge   ? std::string("wedge")
                               : a.chart ? std::string("chart")
                                         : job.input },
                    { "output", job.output },
                    { "stats", job.stats },
                    { "preview", job.preview },
                    { "input_exists", exists },
                    { "error", refusal.empty() ? nlohmann::ordered_json(nullptr)
                                               : nlohmann::ordered_json(refusal) },
                    { "settings_hash", hash },
                    { "up_to_date", up_to_date(job, hash) } };
            std::cout << line.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace)
                      << "\n";
        }
        return 0;
    }

    const bool sequence = jobs.front().frame.has_value();
    size_t rendered = 0, skipped = 0, missing = 0;
    for (size_t i = 0; i < jobs.size(); ++i) {
        const FrameJob& job = jobs[i];
        const std::string where
            = sequence ? "frame " + std::to_string(*job.frame) + ": " : std::string();
        con.set_frame(i, sequence ? jobs.size() : 0, job.frame);
        if (Status s = check_outputs_spare_inputs(a, job); !s)
            return con.fail(where + s.message());
        FrameOutcome outcome = FrameOutcome::rendered;
        const Status s       = render_one(ctx, job, outcome);
        if (interrupted())
            return con.fail_interrupted(
                sequence ? where + "not written; " + std::to_string(rendered)
                               + " frames written before it are complete"
                         : std::string("no output written"));
        if (!s)
            return con.fail(where + s.message());
        rendered += outcome == FrameOutcome::rendered;
        skipped += outcome == FrameOutcome::up_to_date;
        missing += outcome == FrameOutcome::missing;
    }
    if (sequence)
        con.info("sequence of " + std::to_string(jobs.size()) + " frames: "
                 + std::to_string(rendered) + " rendered, " + std::to_string(skipped)
                 + " up to date (skipped), " + std::to_string(missing)
                 + " missing input (skipped) in " + format_seconds(seconds_since(t_start))
                 + " s");
    return 0;
}

int run(int argc, const char** argv)
{
    if (wants_help(argc, argv)) {
        std::cout << help_text();
        return 0;
    }
    CliArgs args;
    if (Status s = parse_command_line(argc, argv, args); !s)
        return Console(false, false).fail(s);
    const Console con(args.quiet, ::isatty(STDERR_FILENO) != 0, args.progress);

    if (args.version || args.list_stocks || !args.print_stock.empty()) {
        if (!args.input.empty() || args.wedge || args.chart || args.has_filmgrain
            || !args.output.empty())
            return con.fail("--version, --list-stocks and --print-stock print and exit: do "
                            "not combine them with INPUT, --wedge, --chart, --filmgrain or -o");
        if (args.version)
            std::cout << "filmgrain " << version_string() << " (OpenImageIO "
                      << OIIO_VERSION_STRING << ")\n";
        if (args.list_stocks)
            list_stocks();
        if (!args.print_stock.empty())
            return print_stock(args.print_stock, con);
        return 0;
    }
    if (argc <= 1) {
        std::cerr << help_text();
        return kExitError;
    }

    install_signal_handlers();
    if (args.threads > 0)
        OIIO::attribute("threads", args.threads);
    return render(args, con);
}

}  // namespace

}  // namespace filmgrain::cli

int main(int argc, const char** argv)
{
    int status = filmgrain::cli::kExitError;
    try {
        status = filmgrain::cli::run(argc, argv);
    } catch (const std::exception& e) {
        std::cerr << "filmgrain: error: internal error: " << e.what() << std::endl;
    } catch (...) {
        std::cerr << "filmgrain: error: internal error (unknown exception)" << std::endl;
    }
    // Leave no OIIO error pending (OIIO reports those at exit).
    OIIO::geterror();
    return status;
}
