// The render driver: tiles, threads, and the per-grain pipeline of the exact
// engine (MODEL.md 1-5 in order). The physics lives in the per-section
// files; this file only schedules it.
#include "filmgrain/render.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "development.h"
#include "exposure.h"
#include "geometry.h"
#include "image_formation.h"
#include "kinetics.h"
#include "rng.h"
#include "sampling.h"

namespace filmgrain {

Status SceneSettings::validate() const
{
    if (!std::isfinite(exposure_stops) || exposure_stops < -64.0 || exposure_stops > 64.0)
        return Status::errorf("exposure = ", exposure_stops, " stops: must be in [-64, 64]");
    if (!std::isfinite(shutter_s) || shutter_s <= 0.0 || shutter_s > 1e7)
        return Status::errorf("shutter = ", shutter_s, " s: must be in (0, 1e7]");
    if (!std::isfinite(frame_width_mm) || frame_width_mm <= 0.0 || frame_width_mm > 1e9)
        return Status::errorf("width_mm = ", frame_width_mm, ": must be in (0, 1e9]");
    return {};
}

const char* engine_name(Engine engine)
{
    switch (engine) {
    case Engine::exact: return "exact";
    }
    return "unknown";
}

bool parse_engine(const std::string& name, Engine& out)
{
    if (name == "exact") {
        out = Engine::exact;
        return true;
    }
    return false;
}

Status scan_geometry(const SceneSettings& scene, int64_t input_width, int64_t input_height,
                     const RenderSettings& settings, ScanGeometry& out)
{
    FrameGeometry g;
    if (Status s = FrameGeometry::make(scene.frame_width_mm, input_width, input_height,
                                       settings.scan_width, settings.scan_height, g);
        !s)
        return s;
    out.width           = g.scan_width;
    out.height          = g.scan_height;
    out.frame_width_um  = g.width_um;
    out.frame_height_um = g.height_um;
    out.input_pitch_um  = g.input_pitch_um;
    out.pitch_x_um      = g.scan_pitch_x_um;
    out.pitch_y_um      = g.scan_pitch_y_um;
    return {};
}

namespace {

/// Everything a tile needs to know about one population, prepared once.
struct PopulationPlan {
    PopulationGrains grains;
    /// Mean absorbed photons per (value x square micrometre):
    /// quantum_efficiency * 4.09e3 * H per unit value (MODEL.md 2).
    double photons_per_value_um2;
    KineticsRates rates;
    double rate_area_exponent;
};

struct LayerPlan {
    LayerExposure exposure;
    std::vector<PopulationPlan> populations;
};

/// Counters of one layer, summed over tiles (integers: order-independent).
struct LayerCounters {
    std::atomic<uint64_t> grains { 0 }, developed { 0 }, photons { 0 }, events { 0 };
};

/// Per-worker scratch buffers, reused from tile to tile.
struct TileScratch {
    std::vector<Disc> discs, bucketed;
    std::vector<size_t> offsets, fill;
};

/// The exact engine: a read-only plan shared by all workers, plus counters
/// that the workers add to (integers, so the order does not matter).
class ExactRenderer {
public:
    ExactRenderer(const Stock& stock, const SceneSettings& scene, const ImageView& input,
                  const FrameGeometry& frame, const Roi& roi, float* out)
        : m_stock(stock)
        , m_scene(scene)
        , m_frame(frame)
        , m_roi(roi)
        , m_out(out)
        , m_development(stock)
        , m_counters(stock.layers.size())
    {
        const double lxs_per_value = exposure_lxs_per_unit_value(stock.exposure_at_grey_lxs,
                                                                 scene.exposure_stops);
        for (size_t l = 0; l < stock.layers.size(); ++l) {
            const Layer& layer = stock.layers[l];
            LayerPlan plan { LayerExposure(input, layer.sensitivity, frame.input_pitch_um), {} };
            for (size_t p = 0; p < layer.populations.size(); ++p) {
                const Population& pop = layer.populations[p];
                plan.populations.push_back(
                    { PopulationGrains(pop, scene.seed, static_cast<uint32_t>(l),
                                       static_cast<uint32_t>(p)),
                      pop.quantum_efficiency * kPhotonsPerUm2PerLxs * lxs_per_value,
                      { pop.k_pair_per_s, pop.k_join_per_s, pop.k_loss_per_s },
                      pop.rate_area_exponent });
            }
            m_layers.push_back(std::move(plan));
        }
    }

    double max_radius_um() const
    {
        double r = 0.0;
        for (const auto& layer : m_layers)
            for (const auto& pop : layer.populations)
                r = std::max(r, pop.grains.max_radius_um());
        return r;
    }

    /// Renders the scan pixels [x0, x1) x [y0, y1) of every layer.
    void render_tile(TileScratch& scratch, int64_t x0, int64_t y0, int64_t x1, int64_t y1)
    {
        const RectUm rect = m_frame.scan_rect(x0, y0, x1, y1);
        for (size_t l = 0; l < m_layers.size(); ++l) {
            scratch.discs.clear();
            uint64_t grains = 0, developed = 0, photons = 0, events = 0;
            for (const PopulationPlan& pop : m_layers[l].populations) {
                pop.grains.for_each_grain_near(rect, [&](const Grain& g) {
                    const Disc disc { g.x_um, g.y_um, g.radius_um };
                    if (!disc_touches_rect(disc, rect.x0_um, rect.y0_um, rect.x1_um, rect.y1_um))
                        return;
                    uint64_t n = 0, ev = 0;
                    const bool dev = simulate_grain(m_layers[l], pop, g, n, ev);
                    // Count each grain once: in the tile holding its centre.
                    if (g.x_um >= rect.x0_um && g.x_um < rect.x1_um && g.y_um >= rect.y0_um
                        && g.y_um < rect.y1_um) {
                        ++grains;
                        developed += dev;
                        photons += n;
                        events += ev;
                    }
                    if (dev)
                        scratch.discs.push_back(disc);
                });
            }
            LayerCounters& c = m_counters[l];
            c.grains += grains;
            c.developed += developed;
            c.photons += photons;
            c.events += events;
            write_densities(scratch, l, x0, y0, x1, y1);
        }
    }

    void fill_stats(RenderStats& stats) const
    {
        stats.layers.clear();
        const size_t nl = m_stock.layers.size();
        const int64_t npix = m_roi.npixels();
        for (size_t l = 0; l < nl; ++l) {
            LayerStats ls;
            ls.name             = m_stock.layers[l].name;
            ls.grains           = m_counters[l].grains;
            ls.developed        = m_counters[l].developed;
            ls.absorbed_photons = m_counters[l].photons;
            ls.kinetics_events  = m_counters[l].events;
            // Fixed summation order (row-major): deterministic.
            double sum = 0.0;
            for (int64_t i = 0; i < npix; ++i)
                sum += m_out[static_cast<size_t>(i) * nl + l];
            ls.mean_density = npix ? sum / static_cast<double>(npix) : 0.0;
            stats.layers.push_back(ls);
        }
    }

private:
    /// MODEL.md 2-4 for one grain: absorbed photons, latent image,
    /// development. Returns whether it develops.
    bool simulate_grain(const LayerPlan& layer, const PopulationPlan& pop, const Grain& g,
                        uint64_t& photons, uint64_t& events) const
    {
        const double mean = pop.photons_per_value_um2
                            * layer.exposure.integrate_over_disc(g.x_um, g.y_um, g.radius_um);
        Rng photon_rng(g.id, Stage::photons);
        photons = sample_poisson(mean, photon_rng);
        LatentImage latent;
        // Fewer than four electrons cannot build a 4-centre: n4 = 0 exactly,
        // so the chain need not run (its other outcomes are not observed).
        if (photons >= 4) {
            const double area  = M_PI * g.radius_um * g.radius_um;
            const double scale = rate_scale_for_area(area, pop.grains.mean_area_um2(),
                                                     pop.rate_area_exponent);
            const KineticsRates rates { pop.rates.k_pair_per_s * scale,
                                        pop.rates.k_join_per_s * scale,
                                        pop.rates.k_loss_per_s * scale };
            Rng kinetics_rng(g.id, Stage::kinetics);
            latent = simulate_latent_image(photons, m_scene.shutter_s, rates, kinetics_rng,
                                           &events);
        }
        Rng development_rng(g.id, Stage::development);
        return m_development.develops(latent.n4, development_rng.uniform());
    }

    /// MODEL.md 5: exact coverage of each scan pixel by the developed discs.
    void write_densities(TileScratch& scratch, size_t layer, int64_t x0, int64_t y0,
                         int64_t x1, int64_t y1) const
    {
        auto& offsets  = scratch.offsets;
        auto& bucketed = scratch.bucketed;
        auto& fill     = scratch.fill;
        const int64_t tw = x1 - x0, th = y1 - y0;
        const double px = m_frame.scan_pitch_x_um, py = m_frame.scan_pitch_y_um;
        // Bucket the discs by the pixels they touch, keeping their order.
        offsets.assign(static_cast<size_t>(tw * th + 1), 0);
        const auto for_each_pixel = [&](const Disc& d, auto&& f) {
            const int64_t ix0 = std::max<int64_t>(x0, static_cast<int64_t>(std::floor((d.x_um - d.r_um) / px)));
            const int64_t ix1 = std::min<int64_t>(x1 - 1, static_cast<int64_t>(std::floor((d.x_um + d.r_um) / px)));
            const int64_t iy0 = std::max<int64_t>(y0, static_cast<int64_t>(std::floor((d.y_um - d.r_um) / py)));
            const int64_t iy1 = std::min<int64_t>(y1 - 1, static_cast<int64_t>(std::floor((d.y_um + d.r_um) / py)));
            for (int64_t iy = iy0; iy <= iy1; ++iy)
                for (int64_t ix = ix0; ix <= ix1; ++ix)
                    if (disc_touches_rect(d, ix * px, iy * py, (ix + 1) * px, (iy + 1) * py))
                        f(static_cast<size_t>((iy - y0) * tw + (ix - x0)));
        };
        for (const Disc& d : scratch.discs)
            for_each_pixel(d, [&](size_t i) { ++offsets[i + 1]; });
        for (size_t i = 1; i < offsets.size(); ++i)
            offsets[i] += offsets[i - 1];
        bucketed.resize(offsets.back());
        fill.assign(offsets.begin(), offsets.end() - 1);
        for (const Disc& d : scratch.discs)
            for_each_pixel(d, [&](size_t i) { bucketed[fill[i]++] = d; });

        const size_t nl       = m_stock.layers.size();
        const double pixel_um2 = px * py;
        for (int64_t iy = y0; iy < y1; ++iy)
            for (int64_t ix = x0; ix < x1; ++ix) {
                const size_t i = static_cast<size_t>((iy - y0) * tw + (ix - x0));
                const double covered
                    = union_coverage_um2(bucketed.data() + offsets[i],
                                         offsets[i + 1] - offsets[i], ix * px, iy * py,
                                         (ix + 1) * px, (iy + 1) * py);
                const double t = 1.0 - covered / pixel_um2;
                const size_t o = static_cast<size_t>((iy - m_roi.y_begin) * m_roi.width()
                                                     + (ix - m_roi.x_begin));
                m_out[o * nl + layer] = static_cast<float>(
                    density_from_transmittance(t, m_stock.max_density, m_stock.base_density));
            }
    }

    const Stock& m_stock;
    const SceneSettings& m_scene;
    const FrameGeometry& m_frame;
    Roi m_roi;
    float* m_out;
    Development m_development;
    std::vector<LayerPlan> m_layers;
    std::vector<LayerCounters> m_counters;
};

/// Counts the special input pixels the render reads.
InputStats scan_input(const ImageView& input, const FrameGeometry& frame, const Roi& roi,
                      double margin_um)
{
    InputStats s;
    const RectUm r  = frame.scan_rect(roi.x_begin, roi.y_begin, roi.x_end, roi.y_end);
    const double p  = frame.input_pitch_um;
    const auto clip = [](double v, int64_t n) {
        return std::clamp<int64_t>(static_cast<int64_t>(std::floor(v)), 0, n);
    };
    const int64_t x0 = clip((r.x0_um - margin_um) / p, input.width);
    const int64_t x1 = clip((r.x1_um + margin_um) / p + 1, input.width);
    const int64_t y0 = clip((r.y0_um - margin_um) / p, input.height);
    const int64_t y1 = clip((r.y1_um + margin_um) / p + 1, input.height);
    const int nc     = std::min(input.channels, 3);
    for (int64_t y = y0; y < y1; ++y)
        for (int64_t x = x0; x < x1; ++x) {
            const float* px = input.pixel(x, y);
            bool nonfinite = false, negative = false, denormal = false;
            for (int c = 0; c < nc; ++c) {
                nonfinite |= !std::isfinite(px[c]);
                negative |= px[c] < 0.0f;
                denormal |= std::fpclassify(px[c]) == FP_SUBNORMAL;
            }
            s.nonfinite_pixels += nonfinite;
            s.negative_pixels += negative && !nonfinite;
            s.denormal_pixels += denormal && !nonfinite;
        }
    s.pixels_read = static_cast<uint64_t>(std::max<int64_t>(0, x1 - x0))
                    * static_cast<uint64_t>(std::max<int64_t>(0, y1 - y0));
    return s;
}

Status validate_request(const Stock& stock, const SceneSettings& scene, const ImageView& input,
                        const RenderSettings& settings, const float* density)
{
    if (Status s = stock.validate(); !s)
        return Status::errorf("stock '", stock.name, "': ", s.message());
    if (Status s = scene.validate(); !s)
        return s;
    if (!input.pixels)
        return Status::error("input image has no pixels (null buffer)");
    if (input.width <= 0 || input.height <= 0)
        return Status::errorf("input image is ", input.width, "x", input.height,
                              ": must have at least one pixel");
    if (input.channels != 1 && input.channels < 3)
        return Status::errorf("input image has ", input.channels,
                              " channels: expected 1 (grey) or 3 or more (R, G, B first)");
    if (!density)
        return Status::error("output buffer is null");
    if (settings.tile_size_px < 1 || settings.tile_size_px > 4096)
        return Status::errorf("tile size = ", settings.tile_size_px, ": must be in [1, 4096]");
    if (settings.nthreads < 0)
        return Status::errorf("nthreads = ", settings.nthreads, ": must be >= 0");
    return {};
}

}  // namespace

Status render_negative(const Stock& stock, const SceneSettings& scene, const ImageView& input,
                       const RenderSettings& settings, float* density, RenderStats* stats)
{
    try {
        if (Status s = validate_request(stock, scene, input, settings, density); !s)
            return s;
        FrameGeometry frame;
        if (Status s = FrameGeometry::make(scene.frame_width_mm, input.width, input.height,
                                           settings.scan_width, settings.scan_height, frame);
            !s)
            return s;
        Roi roi = settings.roi;
        if (roi.empty()) {
            roi = { 0, 0, frame.scan_width, frame.scan_height };
        } else if (roi.x_begin < 0 || roi.y_begin < 0 || roi.x_end > frame.scan_width
                   || roi.y_end > frame.scan_height) {
            return Status::errorf("roi = ", roi.x_begin, ",", roi.y_begin, ",", roi.width(), ",",
                                  roi.height(), " (x,y,w,h) lies outside the ", frame.scan_width,
                                  "x", frame.scan_height, " scan");
        }

        const auto start = std::chrono::steady_clock::now();
        const int64_t ts = settings.tile_size_px;
        const int64_t ntx = (roi.width() + ts - 1) / ts, nty = (roi.height() + ts - 1) / ts;
        const int64_t ntiles = ntx * nty;
        int nthreads = settings.nthreads > 0 ? settings.nthreads
                                             : static_cast<int>(std::thread::hardware_concurrency());
        nthreads = static_cast<int>(std::clamp<int64_t>(nthreads, 1, std::max<int64_t>(1, ntiles)));

        ExactRenderer renderer(stock, scene, input, frame, roi, density);
        std::vector<TileScratch> scratch(static_cast<size_t>(nthreads));
        std::atomic<int64_t> next_tile { 0 }, tiles_done { 0 };
        std::atomic<bool> cancel { false };
        std::mutex mutex;
        std::condition_variable wake;
        std::string worker_error;
        const auto work = [&](TileScratch& tile_scratch) {
            try {
                for (int64_t t; !cancel && (t = next_tile++) < ntiles;) {
                    const int64_t x0 = roi.x_begin + (t % ntx) * ts;
                    const int64_t y0 = roi.y_begin + (t / ntx) * ts;
                    renderer.render_tile(tile_scratch, x0, y0, std::min(x0 + ts, roi.x_end),
                                  std::min(y0 + ts, roi.y_end));
                    ++tiles_done;
                }
            } catch (const std::exception& e) {
                std::lock_guard<std::mutex> lock(mutex);
                worker_error = e.what();
                cancel       = true;
            }
            wake.notify_all();
        };
        std::vector<std::thread> threads;
        for (int t = 0; t < nthreads; ++t)
            threads.emplace_back(work, std::ref(scratch[static_cast<size_t>(t)]));
        {
            std::unique_lock<std::mutex> lock(mutex);
            while (tiles_done < ntiles && !cancel) {
                wake.wait_for(lock, std::chrono::milliseconds(100));
                if (settings.progress && !cancel) {
                    lock.unlock();
                    if (!settings.progress(static_cast<double>(tiles_done) / ntiles))
                        cancel = true;
                    lock.lock();
                }
            }
        }
        for (auto& th : threads)
            th.join();
        if (!worker_error.empty())
            return Status::errorf("render failed: ", worker_error);
        if (tiles_done < ntiles)
            return Status::error("render cancelled");
        if (settings.progress)
            settings.progress(1.0);

        if (stats) {
            renderer.fill_stats(*stats);
            stats->engine = engine_name(settings.engine);
            stats->input  = scan_input(input, frame, roi, renderer.max_radius_um());
            stats->simulate_seconds
                = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        }
        return {};
    } catch (const std::exception& e) {
        return Status::errorf("render failed: ", e.what());
    }
}

}  // namespace filmgrain
