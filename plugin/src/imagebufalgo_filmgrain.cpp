// filmgrain: the ImageBufAlgo-style operator (see
// filmgrain/imagebufalgo_filmgrain.h). A thin adapter with the skeleton of
// OIIO's operators: check src, prepare the ROI and dst, run the kernel (here
// the core's render_negative), store errors on dst. No physics here.
#include "filmgrain/imagebufalgo_filmgrain.h"

#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>

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

namespace IBA {

namespace {

/// Checks src and returns the size of the whole image the film frame maps
/// to: src's display (full) window, or its data window when none is set.
bool source_frame(const OIIO::ImageBuf& src, int64_t& width, int64_t& height,
                  std::string& error)
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
    width  = spec.full_width > 0 ? spec.full_width : spec.width;
    height = spec.full_height > 0 ? spec.full_height : spec.height;
    return true;
}

/// The input the render reads, as an ImageView in frame coordinates (0,0 =
/// the display window's corner). When src holds float pixels in memory that
/// cover the window and dst is another image, the view points straight into
/// src (no copy); otherwise just the window is copied into `pixels`
/// (pixels outside src's data window read as 0, OIIO's convention), so a
/// cache-backed src is read only where the render looks.
bool source_view(const OIIO::ImageBuf& src, bool dst_aliases_src, const Roi& window,
                 int64_t frame_width, int64_t frame_height, std::vector<float>& pixels,
                 ImageView& view, std::string& error)
{
    const OIIO::ImageSpec& spec = src.spec();
    const int64_t fx = spec.full_width > 0 ? spec.full_x : spec.x;
    const int64_t fy = spec.full_height > 0 ? spec.full_y : spec.y;
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
    OIIO::ROI roi(static_cast<int>(window.x_begin + fx), static_cast<int>(window.x_end + fx),
                  static_cast<int>(window.y_begin + fy), static_cast<int>(window.y_end + fy), 0, 1,
                  0, nc);
    pixels.resize(static_cast<size_t>(std::max<int64_t>(1, window.npixels())) * nc);
    if (!window.empty() && !src.get_pixels(roi, OIIO::TypeFloat, pixels.data())) {
        error = OIIO::Strutil::fmt::format("cannot read the source pixels: {}", src.geterror());
        return false;
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
    spec.attribute("filmgrain:frame_width_mm", static_cast<float>(opts.scene.frame_width_mm));
    spec.attribute("filmgrain:engine", engine_name(opts.engine_options.engine));
    spec.attribute("filmgrain:version", version_string());
}

bool filmgrain_impl(OIIO::ImageBuf& dst, const OIIO::ImageBuf& src,
                    const FilmgrainOptions& opts, OIIO::ROI roi, int nthreads,
                    RenderStats* stats)
{
    int64_t frame_width = 0, frame_height = 0;
    std::string error;
    if (!source_frame(src, frame_width, frame_height, error)) {
        dst.errorfmt("filmgrain: {}", error);
        return false;
    }

    RenderSettings settings;
    static_cast<EngineOptions&>(settings) = opts.engine_options;
    settings.scan_width   = opts.scan_width;
    settings.scan_height  = opts.scan_height;
    settings.tile_size_px = opts.tile_size_px;
    settings.nthreads     = resolve_threads(nthreads);
    settings.progress     = opts.progress;

    ScanGeometry scan;
    if (Status s = scan_geometry(opts.scene, frame_width, frame_height, settings, scan); !s) {
        dst.errorfmt("filmgrain: {}", s.message());
        return false;
    }
    if (scan.width > INT_MAX || scan.height > INT_MAX) {
        dst.errorfmt("filmgrain: scan = {}x{}: an OpenImageIO image side must be at most {}",
                     scan.width, scan.height, INT_MAX);
        return false;
    }
    if (!roi.defined()) {
        roi = OIIO::ROI(0, static_cast<int>(scan.width), 0, static_cast<int>(scan.height));
    } else if (roi.xbegin < 0 || roi.ybegin < 0 || roi.xend > scan.width
               || roi.yend > scan.height || roi.xend <= roi.xbegin || roi.yend <= roi.ybegin) {
        dst.errorfmt("filmgrain: roi = {},{},{},{} (x,y,w,h) does not lie inside the {}x{} scan",
                     roi.xbegin, roi.ybegin, roi.width(), roi.height(), scan.width, scan.height);
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
    if (Status s = required_input_window(opts.stock, opts.scene, frame_width, frame_height,
                                         settings, window);
        !s) {
        dst.errorfmt("filmgrain: {}", s.message());
        return false;
    }
    std::vector<float> packed;
    ImageView view;
    if (!source_view(src, &dst == &src, window, frame_width, frame_height, packed, view, error)) {
        dst.errorfmt("filmgrain: {}", error);
        return false;
    }

    OIIO::ImageSpec spec(roi.width(), roi.height(), nlayers, OIIO::TypeFloat);
    spec.x           = roi.xbegin;
    spec.y           = roi.ybegin;
    spec.full_x      = 0;
    spec.full_y      = 0;
    spec.full_width  = static_cast<int>(scan.width);
    spec.full_height = static_cast<int>(scan.height);
    spec.channelnames.clear();
    for (const Layer& layer : opts.stock.layers)
        spec.channelnames.push_back(layer.name);
    set_metadata(spec, opts);

    // When dst is src, the view is a copy in `packed`: resetting dst is safe.
    dst.reset(spec, OIIO::InitializePixels::No);
    float* density = static_cast<float*>(dst.localpixels());
    if (!density) {
        dst.errorfmt("filmgrain: cannot allocate the {}x{}x{} output image", roi.width(),
                     roi.height(), nlayers);
        return false;
    }
    if (Status s = render_negative(opts.stock, opts.scene, view, settings, density, stats);
        !s) {
        dst.errorfmt("filmgrain: {}", s.message());
        return false;
    }
    return true;
}

}  // namespace

bool filmgrain(OIIO::ImageBuf& dst, const OIIO::ImageBuf& src, const FilmgrainOptions& opts,
               OIIO::ROI roi, int nthreads, RenderStats* stats)
{
    // No exception crosses the library boundary (allocation failures
    // included).
    try {
        return filmgrain_impl(dst, src, opts, roi, nthreads, stats);
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
