// The render driver: checks a request, plans it (engine_plan.h), splits
// the ROI into tiles, runs them on the core's threads with progress and
// cancellation (parallel.h), and gathers the statistics. Settings live in
// settings.cpp, a tile's pipeline in tile_renderer.cpp, the physics in the
// per-section files.
#include "filmgrain/render.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <functional>
#include <vector>

#include "engine/engine_plan.h"
#include "engine/settings.h"
#include "model/exposure.h"
#include "model/geometry.h"
#include "model/image_formation.h"
#include "util/parallel.h"
#include "engine/tile_renderer.h"

namespace filmgrain {

namespace {

/// Counts the special input pixels the render reads; `direct`: each
/// layer's exposure straight from the input (saturated pixels, MODEL.md 2).
/// A row an item on the core's threads (the counts are sums: the same
/// whatever the threads).
InputStats scan_input(const ImageView& input, const InputRegion& r,
                      const std::vector<LayerExposure>& direct, int nthreads)
{
    const int nc       = std::min(input.channels, 3);
    const int64_t rows = std::max<int64_t>(0, r.y1 - r.y0);
    std::vector<InputStats> counts(static_cast<size_t>(parallel_workers(rows, nthreads)));
    std::atomic<bool> stop { false };
    parallel_for(rows, nthreads, stop, [&](int worker, int64_t row) {
        InputStats& s  = counts[static_cast<size_t>(worker)];
        const int64_t y = r.y0 + row;
        for (int64_t x = r.x0; x < r.x1; ++x) {
            const float* px = input.pixel(x, y);
            bool nonfinite = false, nan = false, negative = false, denormal = false;
            for (int c = 0; c < nc; ++c) {
                nonfinite |= !std::isfinite(px[c]);
                nan |= std::isnan(px[c]);
                negative |= px[c] < 0.0f;
                denormal |= std::fpclassify(px[c]) == FP_SUBNORMAL;
            }
            bool saturated = false;
            for (const LayerExposure& e : direct)
                saturated |= e.saturates(x, y);
            s.nonfinite_pixels += nonfinite;
            s.nan_pixels += nan;
            s.saturated_pixels += saturated;
            s.negative_pixels += negative && !nonfinite;
            s.denormal_pixels += denormal && !nonfinite;
        }
    });
    InputStats s;
    for (const InputStats& c : counts) {
        s.nonfinite_pixels += c.nonfinite_pixels;
        s.nan_pixels += c.nan_pixels;
        s.saturated_pixels += c.saturated_pixels;
        s.negative_pixels += c.negative_pixels;
        s.denormal_pixels += c.denormal_pixels;
    }
    s.pixels_read = static_cast<uint64_t>(std::max<int64_t>(0, r.x1 - r.x0))
                    * static_cast<uint64_t>(rows);
    return s;
}

Status validate_request(const Stock& stock, const SceneSettings& scene, const ImageView& input,
                        const RenderSettings& settings, const float* density)
{
    if (Status s = stock.validate(); !s)
        return Status::errorf("stock '", stock.name, "': ", s.message());
    if (Status s = scene.validate(); !s)
        return s;
    if (Status s = settings.validate(); !s)
        return s;
    if (!input.pixels)
        return Status::error("input image has no pixels (null buffer)");
    if (input.frame_width() <= 0 || input.frame_height() <= 0)
        return Status::errorf("input image is ", input.frame_width(), "x", input.frame_height(),
                              ": must have at least one pixel");
    if (input.width < 0 || input.height < 0 || input.x_origin < 0 || input.y_origin < 0
        || input.x_origin + input.width > input.frame_width()
        || input.y_origin + input.height > input.frame_height())
        return Status::errorf("input window ", input.width, "x", input.height, " at ",
                              input.x_origin, ",", input.y_origin, " lies outside the ",
                              input.frame_width(), "x", input.frame_height(), " image");
    if (input.channels != 1 && input.channels < 3)
        return Status::errorf("input image has ", input.channels,
                              " channels: expected 1 (grey) or 3 or more (R, G, B first)");
    if (!density)
        return Status::error("output buffer is null");
    return {};
}

/// plan_layers, stoppable. Without a progress callback it runs here. With
/// one it reports 0 first, then runs as the one item of a polled
/// parallel_for: a worker plans while this thread (the caller's, as
/// ProgressCallback promises) reports 0 about every 100 ms and cancels the
/// plan when told to: its tables,
/// inhibitor blur and light spread take seconds on a 4K frame of a
/// fine-grained stock.
Status plan_stoppably(const Stock& stock, const SceneSettings& scene, const ImageView& input,
                      const FrameGeometry& frame, const Roi& roi, const RenderSettings& settings,
                      std::vector<LayerPlan>& plan)
{
    if (!settings.progress)
        return plan_layers(stock, scene, input, frame, roi, settings, plan);
    // Reported once before any work, so that a cancel at the first report
    // is honoured however fast the plan and the render would be (a small
    // frame with its tables on disk can finish before the first 100 ms).
    if (!settings.progress(0.0))
        return Status::error("render cancelled");
    std::atomic<bool> cancel { false }, stop { false };
    Status status;
    parallel_for(
        1, 1, stop,
        [&](int, int64_t) {
            status = plan_layers(stock, scene, input, frame, roi, settings, plan, &cancel);
        },
        [&](int64_t) {
            if (!cancel && !settings.progress(0.0))
                cancel = true;
        });
    if (cancel)
        return Status::error("render cancelled");
    return status;
}

}  // namespace

Status required_input_window(const Stock& stock, const SceneSettings& scene,
                             int64_t input_width, int64_t input_height,
                             const RenderSettings& settings, Roi& out)
{
    try {
        if (Status s = stock.validate(); !s)
            return Status::errorf("stock '", stock.name, "': ", s.message());
        if (Status s = scene.validate(); !s)
            return s;
        FrameGeometry frame;
        if (Status s = frame_geometry(scene, input_width, input_height, settings, frame); !s)
            return s;
        const Roi roi = settings.roi.empty() ? Roi { 0, 0, frame.scan_width, frame.scan_height }
                                             : settings.roi;
        ImageView whole;
        whole.width  = input_width;
        whole.height = input_height;
        const InputRegion r = read_region(stock, scene, whole, frame, roi);
        out                 = Roi { r.x0, r.y0, std::max(r.x0, r.x1), std::max(r.y0, r.y1) };
        return {};
    } catch (const std::exception& e) {
        return Status::errorf("required_input_window: ", e.what());
    }
}

Status render_negative(const Stock& stock, const SceneSettings& scene, const ImageView& input,
                       const RenderSettings& settings, float* density, RenderStats* stats)
{
    try {
        if (Status s = validate_request(stock, scene, input, settings, density); !s)
            return s;
        FrameGeometry frame;
        if (Status s = frame_geometry(scene, input.frame_width(), input.frame_height(),
                                      settings, frame);
            !s)
            return s;
        Roi roi = settings.roi;
        const Roi all = frame.frame_scan_pixels();
        if (roi.empty()) {
            roi = { 0, 0, frame.scan_width, frame.scan_height };
        } else if (roi.x_begin < all.x_begin || roi.y_begin < all.y_begin
                   || roi.x_end > all.x_end || roi.y_end > all.y_end) {
            if (all.x_begin == 0 && all.y_begin == 0 && all.x_end == frame.scan_width
                && all.y_end == frame.scan_height)
                return Status::errorf("roi = ", roi.x_begin, ",", roi.y_begin, ",", roi.width(),
                                      ",", roi.height(), " (x,y,w,h) lies outside the ",
                                      frame.scan_width, "x", frame.scan_height, " scan");
            return Status::errorf("roi = ", roi.x_begin, ",", roi.y_begin, ",", roi.width(), ",",
                                  roi.height(), " (x,y,w,h) lies outside the scan's pixels over "
                                  "the frame, [", all.x_begin, ", ", all.x_end, ") x [",
                                  all.y_begin, ", ", all.y_end, ")");
        }

        // The window must hold every input pixel the render reads.
        const InputRegion need = read_region(stock, scene, input, frame, roi);
        if (need.x1 > need.x0 && need.y1 > need.y0
            && (need.x0 < input.x_origin || need.y0 < input.y_origin
                || need.x1 > input.x_origin + input.width
                || need.y1 > input.y_origin + input.height))
            return Status::errorf("input window ", input.width, "x", input.height, " at ",
                                  input.x_origin, ",", input.y_origin,
                                  " does not cover the input pixels the render reads: [",
                                  need.x0, ", ", need.x1, ") x [", need.y0, ", ", need.y1,
                                  ") (see required_input_window)");

        const auto start = std::chrono::steady_clock::now();
        std::vector<LayerPlan> plan;
        if (Status s = plan_stoppably(stock, scene, input, frame, roi, settings, plan); !s)
            return s;

        // Tiles hold at most kGrainsPerTile grains (all layers that
        // generate grains: a layer wholly at pixel scale has none, its work
        // is per pixel) whatever the pixel size: memory follows the tile's
        // work, every thread gets tiles, and a stop is seen within a tile
        // (render_tile checks it every few thousand grains). Speed only:
        // never the output.
        double grains_per_px = 0.0;
        for (size_t l = 0; l < stock.layers.size(); ++l)
            if (!plan[l].pixel_model || plan[l].min_developed_per_pixel > 0.0)
                for (const Population& pop : stock.layers[l].populations)
                    grains_per_px
                        += pop.grains_per_um2 * frame.scan_pitch_x_um * frame.scan_pitch_y_um;
        constexpr double kGrainsPerTile = 1 << 18;
        // (Clamped as a double: with every layer at pixel scale the side is
        // unbounded, beyond what an int64_t holds.)
        const int64_t ts = static_cast<int64_t>(
            std::clamp(std::sqrt(kGrainsPerTile / std::max(grains_per_px, 1e-300)), 1.0,
                       static_cast<double>(settings.tile_size_px)));
        const int64_t ntx = (roi.width() + ts - 1) / ts, nty = (roi.height() + ts - 1) / ts;
        const int64_t ntiles = ntx * nty;

        std::atomic<bool> stop { false };
        bool cancelled = false;
        TileRenderer renderer(stock, scene, frame, roi, plan, density, stop);
        std::vector<TileScratch> scratch(
            static_cast<size_t>(parallel_workers(ntiles, settings.nthreads)));
        std::function<void(int64_t)> poll;
        if (settings.progress)
            poll = [&](int64_t done) {
                if (!stop && !settings.progress(static_cast<double>(done) / ntiles)) {
                    cancelled = true;
                    stop      = true;
                }
            };
        const int64_t done = parallel_for(
            ntiles, settings.nthreads, stop,
            [&](int worker, int64_t t) {
                const int64_t x0 = roi.x_begin + (t % ntx) * ts;
                const int64_t y0 = roi.y_begin + (t / ntx) * ts;
                renderer.render_tile(scratch[static_cast<size_t>(worker)], x0, y0,
                                     std::min(x0 + ts, roi.x_end), std::min(y0 + ts, roi.y_end));
            },
            poll);
        if (cancelled || done < ntiles)
            return Status::error("render cancelled");
        if (settings.progress)
            settings.progress(1.0);

        if (stats) {
            renderer.fill_stats(*stats);
            stats->engine = name_of(settings.engine);
            std::vector<LayerExposure> direct;
            for (size_t l = 0; l < stock.layers.size(); ++l)
                direct.emplace_back(input, stock.layers[l].sensitivity, frame.input_pitch_um,
                                    plan[l].exposure.max_value(), scene.edge);
            stats->input = scan_input(input, need, direct, settings.nthreads);
            stats->simulate_seconds
                = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        }
        return {};
    } catch (const std::exception& e) {
        return Status::errorf("render failed: ", e.what());
    }
}

}  // namespace filmgrain
