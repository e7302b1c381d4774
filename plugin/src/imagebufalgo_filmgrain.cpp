// filmgrain: the ImageBufAlgo-style operator (see
// filmgrain/imagebufalgo_filmgrain.h). A thin adapter with the skeleton of
// OIIO's operators: check src, prepare the ROI and dst, run the kernel (here
// the core's render_negative), store errors on dst. No physics here.
#include "filmgrain/imagebufalgo_filmgrain.h"

#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>

#include <algorithm>
#include <climits>
#include <exception>
#include <string>
#include <vector>

#include "filmgrain/version.h"

namespace filmgrain {

FilmgrainOptions::FilmgrainOptions()
{
    if (Status s = load_stock(default_preset_name(), stock); !s) {
        stock      = Stock();
        stock.name = std::string("default preset (failed to load: ") + s.message() + ")";
        stock.layers.clear();  // fails validation: every render reports it
    }
}

OIIO::ROI film_frame_window(const OIIO::ImageSpec& spec)
{
    if (spec.full_width > 0 && spec.full_height > 0)
        return OIIO::ROI(spec.full_x, spec.full_x + spec.full_width, spec.full_y,
                         spec.full_y + spec.full_height);
    return OIIO::ROI(spec.x, spec.x + spec.width, spec.y, spec.y + spec.height);
}

Status frame_scan(const OIIO::ImageSpec& spec, const FilmgrainOptions& opts, ScanGeometry& out)
{
    const OIIO::ROI frame = film_frame_window(spec);
    RenderSettings settings;
    settings.scan_width  = opts.scan_width;
    settings.scan_height = opts.scan_height;
    return scan_geometry(opts.scene, frame.width(), frame.height(), settings, out);
}

bool has_overscan(const OIIO::ImageSpec& spec)
{
    return spec.full_width > 0 && spec.full_height > 0
           && (spec.x < spec.full_x || spec.y < spec.full_y
               || int64_t(spec.x) + spec.width > int64_t(spec.full_x) + spec.full_width
               || int64_t(spec.y) + spec.height > int64_t(spec.full_y) + spec.full_height);
}

namespace IBA {

namespace {

/// Checks src's channels and depth.
bool check_source(const OIIO::ImageBuf& src, std::string& error)
{
    if (!src.initialized()) {
        error = src.has_error() ? src.geterror() : std::string("source image is empty");
        return false;
    }
    const OIIO::ImageSpec& spec = src.spec();
    if (spec.nchannels != 1 && spec.nchannels < 3) {
        error = OIIO::Strutil::fmt::format(
            "source image has {} channels: expected 1 (grey) or at least 3 (R, G, B first)",
            spec.nchannels);
        return false;
    }
    if (spec.depth > 1) {
        error = OIIO::Strutil::fmt::format("source image is a {}-deep volume: expected a 2D image",
                                           spec.depth);
        return false;
    }
    return true;
}

/// Where the film lies in src and in the scan. The frame is src's display
/// (full) window (its data window when none is set): width_mm
/// across it. The film the core renders is the box around the display and
/// the data windows (`film_*`, src pixels), at the display window's pitch;
/// the scan's grid is the display window's (scan_w x scan_h over it: the
/// core's scan reference), continued beyond it over the whole film. Scan
/// coordinates (ROI, output windows) keep (0, 0) at the display window's
/// corner, so overscan has negative coordinates, as in the EXR. The
/// default output is the data window's scan, rounded outward to whole scan
/// pixels (MODEL.md 2).
struct FilmMapping {
    int64_t film_x = 0, film_y = 0;  ///< the film's corner, src pixels
    int64_t film_w = 0, film_h = 0;  ///< the film's size, src pixels
    double film_width_mm = 0.0;      ///< the film's width
    int64_t scan_w = 0, scan_h = 0;  ///< the display window's scan
    Roi reference;                   ///< the display window, film pixels
    ScanGeometry scan;               ///< the core's scan of the film
    Roi data_scan;                   ///< the data window's scan (rounded)
    double data_scan_exact[4] = {};  ///< ... before the rounding
    bool data_scan_rounded() const
    {
        return data_scan_exact[0] != double(data_scan.x_begin)
               || data_scan_exact[1] != double(data_scan.y_begin)
               || data_scan_exact[2] != double(data_scan.x_end)
               || data_scan_exact[3] != double(data_scan.y_end);
    }
};

bool map_film(const OIIO::ImageSpec& spec, const FilmgrainOptions& opts, FilmMapping& m,
              std::string& error)
{
    const OIIO::ROI frame = film_frame_window(spec);
    const int64_t fx = frame.xbegin, fy = frame.ybegin, fw = frame.width(), fh = frame.height();
    ScanGeometry display;
    if (Status s = frame_scan(spec, opts, display); !s) {
        error = s.message();
        return false;
    }
    m        = FilmMapping();
    m.scan_w = display.width;
    m.scan_h = display.height;
    const int64_t x0 = std::min<int64_t>(fx, spec.x), y0 = std::min<int64_t>(fy, spec.y);
    const int64_t x1 = std::max<int64_t>(fx + fw, int64_t(spec.x) + spec.width);
    const int64_t y1 = std::max<int64_t>(fy + fh, int64_t(spec.y) + spec.height);
    m.film_x = x0, m.film_y = y0, m.film_w = x1 - x0, m.film_h = y1 - y0;
    m.film_width_mm = opts.scene.width_mm * static_cast<double>(m.film_w)
                      / static_cast<double>(fw);
    m.reference = Roi { fx - x0, fy - y0, fx - x0 + fw, fy - y0 + fh };
    SceneSettings scene  = opts.scene;
    scene.width_mm = m.film_width_mm;
    RenderSettings settings;
    settings.scan_width     = m.scan_w;
    settings.scan_height    = m.scan_h;
    settings.scan_reference = m.reference;
    if (Status s = scan_geometry(scene, m.film_w, m.film_h, settings, m.scan); !s) {
        error = s.message();
        return false;
    }
    m.data_scan = scan_pixels_over(m.scan,
                                   Roi { spec.x - x0, spec.y - y0, spec.x - x0 + spec.width,
                                         spec.y - y0 + spec.height },
                                   m.data_scan_exact);
    return true;
}

/// The input the render reads, as an ImageView in film coordinates (0,0 =
/// the film's corner: the display window's, unless there is overscan).
/// When src holds float pixels in memory that cover the window and dst is
/// another image, the view points straight into src (no copy); otherwise
/// just the window is copied into `pixels`, so a cache-backed src is read
/// only where the render looks. Pixels of the film outside src's data
/// window (a data window inside the display window) are the nearest data
/// pixel's (`edge` clamp: the scene continues, MODEL.md 2), or 0 (gate,
/// OIIO's convention).
bool source_view(const OIIO::ImageBuf& src, bool dst_aliases_src, const Roi& window,
                 const FilmMapping& film, FrameEdge edge, std::vector<float>& pixels,
                 ImageView& view, std::string& error)
{
    const OIIO::ImageSpec& spec = src.spec();
    const int64_t fx = film.film_x, fy = film.film_y;
    const int64_t frame_width = film.film_w, frame_height = film.film_h;
    view             = ImageView();
    view.full_width  = frame_width;
    view.full_height = frame_height;
    const int64_t dx0 = spec.x - fx, dy0 = spec.y - fy;
    const bool covers = dx0 <= window.x_begin && dy0 <= window.y_begin
                        && dx0 + spec.width >= window.x_end && dy0 + spec.height >= window.y_end
                        && dx0 >= 0 && dy0 >= 0 && dx0 + spec.width <= frame_width
                        && dy0 + spec.height <= frame_height;
    if (!dst_aliases_src && covers && spec.format == OIIO::TypeFloat && src.localpixels()
        && src.storage() == OIIO::ImageBuf::LOCALBUFFER) {
        view.pixels   = static_cast<const float*>(src.localpixels());
        view.width    = spec.width;
        view.height   = spec.height;
        view.channels = spec.nchannels;
        view.x_stride = spec.nchannels;
        view.y_stride = static_cast<int64_t>(spec.width) * spec.nchannels;
        view.x_origin = dx0;
        view.y_origin = dy0;
        return true;
    }
    const int nc = spec.nchannels == 1 ? 1 : 3;
    pixels.resize(static_cast<size_t>(std::max<int64_t>(1, window.npixels())) * nc);
    const bool inside = dx0 <= window.x_begin && dy0 <= window.y_begin
                        && dx0 + spec.width >= window.x_end && dy0 + spec.height >= window.y_end;
    if (edge == FrameEdge::clamp && !inside && !window.empty()) {
        // Beyond src's data window the scene continues (MODEL.md 2): each
        // pixel there is the nearest data pixel's. Row by row: the data
        // row nearest, its span under the window read once, the runs
        // beyond its ends filled with them.
        const int64_t ww = window.width();
        for (int64_t y = window.y_begin; y < window.y_end; ++y) {
            const int64_t sy = std::clamp<int64_t>(y + fy, spec.y, int64_t(spec.y) + spec.height - 1);
            const int64_t sx0 = std::clamp<int64_t>(window.x_begin + fx, spec.x,
                                                    int64_t(spec.x) + spec.width - 1);
            const int64_t sx1 = std::clamp<int64_t>(window.x_end - 1 + fx, spec.x,
                                                    int64_t(spec.x) + spec.width - 1);
            float* row = pixels.data() + static_cast<size_t>((y - window.y_begin) * ww) * nc;
            float* span = row + static_cast<size_t>(sx0 - fx - window.x_begin) * nc;
            const OIIO::ROI read(static_cast<int>(sx0), static_cast<int>(sx1 + 1),
                                 static_cast<int>(sy), static_cast<int>(sy + 1), 0, 1, 0, nc);
            if (!src.get_pixels(read, OIIO::TypeFloat, span)) {
                error = OIIO::Strutil::fmt::format("cannot read the source pixels: {}",
                                                   src.geterror());
                return false;
            }
            for (int64_t x = 0; x < sx0 - fx - window.x_begin; ++x)
                std::copy_n(span, nc, row + static_cast<size_t>(x) * nc);
            const float* last = row + static_cast<size_t>(sx1 - fx - window.x_begin) * nc;
            for (int64_t x = sx1 - fx - window.x_begin + 1; x < ww; ++x)
                std::copy_n(last, nc, row + static_cast<size_t>(x) * nc);
        }
    } else {
        OIIO::ROI roi(static_cast<int>(window.x_begin + fx), static_cast<int>(window.x_end + fx),
                      static_cast<int>(window.y_begin + fy), static_cast<int>(window.y_end + fy),
                      0, 1, 0, nc);
        if (!window.empty() && !src.get_pixels(roi, OIIO::TypeFloat, pixels.data())) {
            error = OIIO::Strutil::fmt::format("cannot read the source pixels: {}",
                                               src.geterror());
            return false;
        }
    }
    view.pixels   = pixels.data();
    view.width    = window.width();
    view.height   = window.height();
    view.channels = nc;
    view.x_origin = window.x_begin;
    view.y_origin = window.y_begin;
    return true;
}

/// OIIO's global thread default when nthreads is 0.
int resolve_threads(int nthreads)
{
    if (nthreads > 0)
        return nthreads;
    int n = 0;
    OIIO::getattribute("threads", n);
    return n > 0 ? n : 0;  // 0: the core uses all hardware threads
}

void set_metadata(OIIO::ImageSpec& spec, const FilmgrainOptions& opts)
{
    spec.attribute("filmgrain:quantity", kFilmgrainQuantity);
    spec.attribute("filmgrain:stock", stock_to_json(opts.stock));
    spec.attribute("filmgrain:stock_name", opts.stock.name);
    spec.attribute("filmgrain:seed", std::to_string(opts.scene.seed));
    if (opts.scene.frame) {
        spec.attribute("filmgrain:frame", std::to_string(*opts.scene.frame));
        spec.attribute("filmgrain:static", opts.scene.static_grain ? 1 : 0);
    }
    spec.attribute("filmgrain:grain_seed", std::to_string(grain_seed(opts.scene)));
    spec.attribute("filmgrain:exposure_stops", static_cast<float>(opts.scene.exposure_stops));
    spec.attribute("filmgrain:shutter_s", static_cast<float>(opts.scene.shutter_s));
    spec.attribute("filmgrain:width_mm", static_cast<float>(opts.scene.width_mm));
    spec.attribute("filmgrain:edge", name_of(opts.scene.edge));
    spec.attribute("filmgrain:engine", name_of(opts.engine_options.engine));
    spec.attribute("filmgrain:version", version_string());
}

bool filmgrain_impl(OIIO::ImageBuf& dst, const OIIO::ImageBuf& src,
                    const FilmgrainOptions& opts, OIIO::ROI roi, int nthreads)
{
    RenderStats* const stats = opts.stats;
    std::string error;
    FilmMapping film;
    if (!check_source(src, error) || !map_film(src.spec(), opts, film, error)) {
        dst.errorfmt("filmgrain: {}", error);
        return false;
    }
    // The core sees the film (with its overscan) as its frame, and the
    // display window's scan as its scan (the reference).
    SceneSettings scene  = opts.scene;
    scene.width_mm = film.film_width_mm;

    RenderSettings settings;
    static_cast<EngineOptions&>(settings) = opts.engine_options;
    settings.scan_width     = film.scan_w;
    settings.scan_height    = film.scan_h;
    settings.scan_reference = film.reference;
    settings.tile_size_px   = opts.tile_size_px;
    settings.nthreads       = resolve_threads(nthreads);
    settings.progress       = opts.progress;

    const Roi all = film.scan.frame_pixels;
    if (film.scan_w > INT_MAX || film.scan_h > INT_MAX || all.x_begin < INT_MIN
        || all.y_begin < INT_MIN || all.x_end > INT_MAX || all.y_end > INT_MAX) {
        dst.errorfmt("filmgrain: scan = {}x{}: an OpenImageIO image side must be at most {}",
                     film.scan_w, film.scan_h, INT_MAX);
        return false;
    }
    // roi is in scan pixels with (0, 0) at the display window's corner, as
    // the core's (the display window is its scan reference); by default the
    // data window's scan.
    if (!roi.defined()) {
        const Roi& d = film.data_scan;
        roi = OIIO::ROI(static_cast<int>(d.x_begin), static_cast<int>(d.x_end),
                        static_cast<int>(d.y_begin), static_cast<int>(d.y_end));
    } else if (roi.xbegin < all.x_begin || roi.ybegin < all.y_begin || roi.xend > all.x_end
               || roi.yend > all.y_end || roi.xend <= roi.xbegin || roi.yend <= roi.ybegin) {
        dst.errorfmt("filmgrain: roi = {},{},{},{} (x,y,w,h) does not lie inside the {}x{} "
                     "scan{} ([{}, {}) x [{}, {}))",
                     roi.xbegin, roi.ybegin, roi.width(), roi.height(), film.scan_w,
                     film.scan_h,
                     all.x_begin < 0 || all.y_begin < 0 || all.x_end > film.scan_w
                             || all.y_end > film.scan_h
                         ? " with its overscan"
                         : "",
                     all.x_begin, all.x_end, all.y_begin, all.y_end);
        return false;
    }
    settings.roi = Roi { roi.xbegin, roi.ybegin, roi.xend, roi.yend };

    // Validate before allocating: a broken stock must not become a
    // 0-channel image.
    if (Status s = opts.stock.validate(); !s) {
        dst.errorfmt("filmgrain: stock '{}': {}", opts.stock.name, s.message());
        return false;
    }
    const int nlayers = static_cast<int>(opts.stock.layers.size());

    // Only the input under the ROI (plus a grain radius) is read.
    Roi window;
    if (Status s = required_input_window(opts.stock, scene, film.film_w, film.film_h, settings,
                                         window);
        !s) {
        dst.errorfmt("filmgrain: {}", s.message());
        return false;
    }
    std::vector<float> packed;
    ImageView view;
    if (!source_view(src, &dst == &src, window, film, opts.scene.edge, packed, view, error)) {
        dst.errorfmt("filmgrain: {}", error);
        return false;
    }

    OIIO::ImageSpec spec(roi.width(), roi.height(), nlayers, OIIO::TypeFloat);
    spec.x           = roi.xbegin;
    spec.y           = roi.ybegin;
    spec.full_x      = 0;
    spec.full_y      = 0;
    spec.full_width  = static_cast<int>(film.scan_w);
    spec.full_height = static_cast<int>(film.scan_h);
    spec.channelnames.clear();
    for (const Layer& layer : opts.stock.layers)
        spec.channelnames.push_back(layer.name);
    set_metadata(spec, opts);
    // MODEL.md 2: a data window that does not fall on whole scan pixels is
    // rounded outward; the header says from what.
    const double* exact = film.data_scan_exact;
    const Roi& d        = film.data_scan;
    if (film.data_scan_rounded())
        spec.attribute("filmgrain:data_window_rounding",
                       OIIO::Strutil::fmt::format(
                           "the input's data window covers scan pixels [{:.6g}, {:.6g}) x "
                           "[{:.6g}, {:.6g}), rounded outward to [{}, {}) x [{}, {})",
                           exact[0], exact[2], exact[1], exact[3], d.x_begin, d.x_end,
                           d.y_begin, d.y_end));

    // When dst is src, the view is a copy in `packed`: resetting dst is safe.
    dst.reset(spec, OIIO::InitializePixels::No);
    float* density = static_cast<float*>(dst.localpixels());
    if (!density) {
        dst.errorfmt("filmgrain: cannot allocate the {}x{}x{} output image", roi.width(),
                     roi.height(), nlayers);
        return false;
    }
    if (Status s = render_negative(opts.stock, scene, view, settings, density, stats);
        !s) {
        dst.errorfmt("filmgrain: {}", s.message());
        return false;
    }
    if (stats) {
        // The core read the window over the film; the pixels read are those
        // of src's data window in it (the rest of the film is no light).
        const OIIO::ImageSpec& in = src.spec();
        const int64_t dx0 = in.x - film.film_x, dy0 = in.y - film.film_y;
        const int64_t w   = std::min<int64_t>(window.x_end, dx0 + in.width)
                          - std::max<int64_t>(window.x_begin, dx0);
        const int64_t h   = std::min<int64_t>(window.y_end, dy0 + in.height)
                          - std::max<int64_t>(window.y_begin, dy0);
        stats->input.pixels_read = static_cast<uint64_t>(std::max<int64_t>(0, w))
                                   * static_cast<uint64_t>(std::max<int64_t>(0, h));
    }
    return true;
}

}  // namespace

Status data_window_scan(const OIIO::ImageSpec& spec, const FilmgrainOptions& opts, Roi& out,
                        double* exact, bool* rounded)
{
    FilmMapping film;
    std::string error;
    if (!map_film(spec, opts, film, error))
        return Status::error(error);
    out = film.data_scan;
    if (exact)
        std::copy_n(film.data_scan_exact, 4, exact);
    if (rounded)
        *rounded = film.data_scan_rounded();
    return {};
}

bool filmgrain(OIIO::ImageBuf& dst, const OIIO::ImageBuf& src, const FilmgrainOptions& opts,
               OIIO::ROI roi, int nthreads)
{
    // No exception crosses the library boundary (allocation failures
    // included).
    try {
        return filmgrain_impl(dst, src, opts, roi, nthreads);
    } catch (const std::exception& e) {
        dst.errorfmt("filmgrain: {}", e.what());
    } catch (...) {
        dst.errorfmt("filmgrain: unknown exception");
    }
    return false;
}

OIIO::ImageBuf filmgrain(const OIIO::ImageBuf& src, const FilmgrainOptions& opts,
                         OIIO::ROI roi, int nthreads)
{
    OIIO::ImageBuf result;
    if (!filmgrain(result, src, opts, roi, nthreads) && !result.has_error())
        result.errorfmt("filmgrain: failed");
    return result;
}

}  // namespace IBA

}  // namespace filmgrain
