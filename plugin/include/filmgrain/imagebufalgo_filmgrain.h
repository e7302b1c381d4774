// filmgrain: per-grain film simulation.
// The simulator as an OpenImageIO ImageBufAlgo-style operator.
//
// Conventions shared by every function in this header (as in OIIO's
// imagebufalgo.h):
// - Pairs. `bool op(ImageBuf& dst, const ImageBuf& src, ...)` writes dst and
//   returns true on success; `ImageBuf op(const ImageBuf& src, ...)` is a
//   wrapper around it that returns the result (with the error, if any, set
//   on the returned image: check `result.has_error()`).
// - Errors: never an exception, never an abort. On failure the message is
//   stored on dst (read it with dst.geterror()) and the function returns
//   false; the message names the field, its value and the rule it broke.
// - ROI: in *scan* pixels (the output grid over the whole film frame), not
//   in src pixels, (0, 0) at the display window's corner. The default
//   (undefined) ROI means the whole scan with its overscan (below). The
//   ROI's channel and z ranges are ignored: every layer is always written.
// - Threads: nthreads = 0 means OIIO's global default (the "threads"
//   attribute, all hardware threads unless changed); nthreads > 0 uses that
//   many worker threads.
// - Determinism: for a given (src pixels, stock, scene, scan size) every
//   output pixel is bit-identical whatever the thread count, tile size or
//   ROI that contains it (the core's guarantee, see filmgrain/render.h).
// - Aliasing: dst may be the same ImageBuf as src (src is read completely
//   before dst is reallocated).
// - Thread safety: the functions are reentrant; distinct calls may run
//   concurrently on distinct dst images.
//
// The operator holds no physics: it packs src into a float buffer, calls
// filmgrain::render_negative (core) and stores the result and its metadata
// in dst.
#pragma once

// OIIO's type-dispatch macros use `half` without including it.
#include <OpenImageIO/half.h>

#include <OpenImageIO/imagebuf.h>

#include <cstdint>

#include "filmgrain/render.h"
#include "filmgrain/stock.h"

#include <optional>

namespace filmgrain {

/// Everything the operator needs besides the images: the film, the shot and
/// the scan. A plain value type; copy it freely.
struct FilmgrainOptions {
    /// The film stock. Type Stock; default: the built-in default preset
    /// (`default_preset_name()`, the three-layer colour negative), loaded by
    /// the constructor. Should the embedded preset ever fail to parse (a
    /// build defect the core's tests catch), `stock` has no layers and its
    /// `name` holds the parse error, so every render fails with that message
    /// instead of silently using another film.
    Stock stock;

    /// The shot (SceneSettings, declared once in filmgrain/render.h with
    /// their defaults and ranges): exposure_stops, shutter_s,
    /// width_mm, seed, frame, static_grain, edge.
    SceneSettings scene;

    /// The simulation engine and its knobs (EngineOptions, declared once in
    /// filmgrain/render.h with their defaults and ranges): engine (default
    /// Engine::automatic, "auto": the paths the scene needs within
    /// `tolerance`; Engine::exact is the reference), tolerance (density
    /// error budget of the approximate paths, default 0.002, (0, 1]), and
    /// the expert overrides kinetics, photons, coverage, grains
    /// (std::optional, unset: the engine decides; not with Engine::exact)
    /// and samples (0: the engine's choice; [0, 256]).
    EngineOptions engine_options;

    /// Scan width in pixels over the whole frame. int64_t; default 0 =
    /// src's width. Must fit an OIIO image (at most 2^31 - 1).
    int64_t scan_width = 0;

    /// Scan height in pixels. int64_t; default 0 = src's height when
    /// scan_width is 0, else the frame's aspect at scan_width (rounded).
    int64_t scan_height = 0;

    /// Side of the square work tiles, scan pixels. int; default
    /// RenderSettings' default (64); range [1, 4096]. Speed only: never
    /// changes the output.
    int tile_size_px = RenderSettings().tile_size_px;

    /// Optional progress report in [0, 1], called from the calling thread
    /// about ten times a second; return false to cancel (the operator then
    /// fails with "render cancelled"). Default: none.
    ProgressCallback progress;

    /// Optional: receives the render's statistics (grain counts per layer,
    /// special input pixels, simulation time). Not owned; default: none.
    RenderStats* stats = nullptr;

    /// Default options: the default preset and the documented defaults.
    FilmgrainOptions();
};

namespace IBA {

/// Simulates exposing, developing and scanning a film negative of `src`.
///
/// src: scene-linear pixels; 1 channel (grey, read as R = G = B) or at least
///   3 channels (R, G, B first; alpha and any further channels are ignored).
///   2-channel images are an error. Any pixel type (converted to float). The
///   film frame covers src's display (full) window (its data window when no
///   display window is set): opts.scene.width_mm across it, square
///   pixels; pixels outside the data window are black. The negative covers
///   the data window, scaled to the scan and rounded outward to whole scan
///   pixels (MODEL.md 2): smaller than the display window (a crop, a CG
///   element's box) or larger (overscan: that margin is film too, at the
///   same pitch, at negative coordinates and beyond the display scan, as
///   in the EXR); the film's grain is laid out from the corner of the box
///   around both windows. Only the pixels under
///   the ROI plus a grain radius are read (a cache-backed src is read only
///   there); float pixels in memory are used in place, not copied. NaN and
///   Inf channels expose nothing and are counted in
///   stats->input.nonfinite_pixels.
/// dst: (re)allocated as float with one channel per stock layer, named
///   after the layer (stock order): negative density, -log10(transmittance)
///   plus the stock's base density. Its full (display) window is the scan
///   of src's display window, its data window the ROI (by default the
///   data window's scan, data_window_scan).
///   Metadata on dst's spec (strings unless noted): filmgrain:quantity,
///   filmgrain:stock (the full stock as JSON), filmgrain:stock_name,
///   filmgrain:seed (decimal: 64-bit), filmgrain:frame (decimal, only for
///   a frame of a sequence) and filmgrain:static (int, likewise),
///   filmgrain:grain_seed (decimal: the seed the grain was drawn from,
///   grain_seed(scene)), filmgrain:exposure_stops (float),
///   filmgrain:shutter_s (float), filmgrain:width_mm (float),
///   filmgrain:engine, filmgrain:version.
/// roi: scan pixels to render (default: the data window's scan). Must lie
///   inside the scan pixels over the film (the box around the display and
///   data windows, rounded outward).
/// nthreads: worker threads (0: OpenImageIO's "threads" attribute, as
///   every ImageBufAlgo function). Statistics: opts.stats.
bool filmgrain(OIIO::ImageBuf& dst, const OIIO::ImageBuf& src, const FilmgrainOptions& opts,
               OIIO::ROI roi = {}, int nthreads = 0);

/// As above, returning the result; on failure the result has the error set.
OIIO::ImageBuf filmgrain(const OIIO::ImageBuf& src, const FilmgrainOptions& opts,
                         OIIO::ROI roi = {}, int nthreads = 0);

}  // namespace IBA

/// The window the film frame covers: `spec`'s display (full) window, or
/// its data window when none is set (file coordinates).
OIIO::ROI film_frame_window(const OIIO::ImageSpec& spec);

/// The scan of that frame with `opts` (scan size and pitch; the overscan,
/// if any, lies beyond it).
Status frame_scan(const OIIO::ImageSpec& spec, const FilmgrainOptions& opts, ScanGeometry& out);

/// True when `spec`'s data window reaches beyond its display window
/// (overscan: rendered as film too, see IBA::filmgrain).
bool has_overscan(const OIIO::ImageSpec& spec);

namespace IBA {
/// The scan pixels `spec`'s data window covers with `opts`, in scan
/// coordinates ((0, 0) at the display window's corner): its film rectangle
/// rounded outward to whole scan pixels (MODEL.md 2), the operator's
/// default ROI and the negative's data window. `exact` (optional, 4 values
/// x0, y0, x1, y1) receives the rectangle before the rounding, `rounded`
/// (optional) whether the rounding moved it (then the operator's output
/// says so in its filmgrain:data_window_rounding attribute).
Status data_window_scan(const OIIO::ImageSpec& spec, const FilmgrainOptions& opts, Roi& out,
                        double* exact = nullptr, bool* rounded = nullptr);
}  // namespace IBA

/// Value of the filmgrain:quantity attribute: what the pixels mean.
inline constexpr const char* kFilmgrainQuantity
    = "negative density: -log10(transmittance) + base density";

}  // namespace filmgrain
