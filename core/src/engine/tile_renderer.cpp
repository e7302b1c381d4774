// Rendering a tile with a plan's paths (tile_renderer.h).
#include "engine/tile_renderer.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <type_traits>

#include "model/development.h"
#include "model/exposure.h"
#include "model/kinetics.h"
#include "util/parallel.h"
#include "kernels/pixel_model.h"
#include "util/rng.h"
#include "util/sampling.h"

namespace filmgrain {

namespace {

/// Counters of one layer, summed over tiles (integers: order-independent).
struct LayerCounters {
    std::atomic<uint64_t> grains { 0 }, developed { 0 }, photons { 0 }, events { 0 },
        decided_early { 0 };
};

/// What happened to one grain.
struct GrainOutcome {
    bool developed         = false;
    bool decided_early     = false;
    uint64_t photons       = 0;
    uint64_t events        = 0;
};

}  // namespace

/// The tile renderer's state and pipeline (TileRenderer forwards to it).
class TileRenderer::Impl {
public:
    Impl(const Stock& stock, const SceneSettings& scene, const FrameGeometry& frame,
         const Roi& roi, const std::vector<LayerPlan>& layers, float* out,
         const std::atomic<bool>& stop)
        : m_stock(stock)
        , m_scene(scene)
        , m_frame(frame)
        , m_roi(roi)
        , m_layers(layers)
        , m_out(out)
        , m_development(stock)
        , m_counters(stock.layers.size())
        , m_stop(stop)
    {
        for (size_t l = 0; l < stock.layers.size(); ++l)
            m_to_density.emplace_back(stock.max_density, stock.layer_base_density(l));
    }

    /// Renders the scan pixels [x0, x1) x [y0, y1) of every layer.
    void render_tile(TileScratch& scratch, int64_t x0, int64_t y0, int64_t x1, int64_t y1)
    {
        for (size_t l = 0; l < m_layers.size(); ++l) {
            if (m_layers[l].pixel_model)
                write_pixel_scale(scratch, l, x0, y0, x1, y1);
            else
                render_grains(scratch, l, x0, y0, x1, y1);
        }
    }

    /// Layer l's scan pixels [x0, x1) x [y0, y1) grain by grain: its grains
    /// generated, exposed and developed, their image written.
    void render_grains(TileScratch& scratch, size_t l, int64_t x0, int64_t y0, int64_t x1,
                       int64_t y1)
    {
        const RectUm rect      = m_frame.scan_rect(x0, y0, x1, y1);
        const LayerPlan& layer = m_layers[l];
        scratch.discs.clear();
        scratch.population_end.clear();
        uint64_t grains = 0, developed = 0, photons = 0, events = 0, early = 0;
        bool plane_filled = false;
        for (const PopulationPlan& pop : layer.populations) {
            if (pop.fast && pop.kinetics == KineticsMethod::fog) {
                // No light: no exposure to read; every grain of the
                // fog's thinned process develops (but for inhibition).
                FastCounts c;
                if (layer.inhibition)
                    develop_fast<false>(layer, pop, rect, scratch, c, NoLight {});
                else
                    develop_fast<true>(layer, pop, rect, scratch, c, NoLight {});
                grains += c.grains;
                developed += c.developed;
                scratch.population_end.push_back(scratch.discs.size());
                continue;
            }
            if (pop.fast) {
                if (!plane_filled) {
                    // Grain centres lie within margin_um of the tile,
                    // their discs within twice that.
                    const bool discs = std::any_of(
                        layer.populations.begin(), layer.populations.end(),
                        [](const PopulationPlan& pp) {
                            return pp.fast && pp.exposure == ExposureMethod::disc;
                        });
                    // (No wider: a ROI's render reads no input beyond
                    // read_region. The grain filter reads this plane
                    // and keeps every grain of a cell whose discs may
                    // reach past it.)
                    const double m = (discs ? 2.0 : 1.0) * layer.margin_um;
                    scratch.plane.fill(layer.exposure, m_frame,
                                       { rect.x0_um - m, rect.y0_um - m, rect.x1_um + m,
                                         rect.y1_um + m });
                    plane_filled = true;
                }
                FastCounts c;
                // The exposure integral of a batch's grain i (value x
                // um^2), the j-th of the indices given to prepare().
                struct Centre {
                    const ExposurePlane& plane;
                    void prepare(const FastGrains::Batch&, const uint32_t*, size_t) const {}
                    double operator()(const FastGrains::Batch& b, size_t i, size_t) const
                    {
                        return plane.at(b.x[i], b.y[i]) * b.r[i] * b.r[i] * M_PI;
                    }
                };
                // Over the disc: from the plane, a cell at a time, for
                // discs up to half an input pixel in radius (they cross
                // at most one pixel edge each way), one at a time up to
                // a pixel, else (grains larger than the input pixels)
                // from the input image.
                struct Disc {
                    const ExposurePlane& plane;
                    const LayerExposure& exposure;
                    TileScratch::DiscBatch& scratch;
                    double pitch_um;  ///< the input pixel's
                    void prepare(const FastGrains::Batch& b, const uint32_t* index,
                                 size_t m) const
                    {
                        scratch.resize(m);
                        for (size_t j = 0; j < m; ++j) {
                            scratch.x[j] = b.x[index[j]];
                            scratch.y[j] = b.y[index[j]];
                            scratch.r[j] = b.r[index[j]];
                        }
                        plane.integrals_over_discs(scratch.x.data(), scratch.y.data(),
                                                   scratch.r.data(), m, scratch.value.data());
                    }
                    double operator()(const FastGrains::Batch& b, size_t i, size_t j) const
                    {
                        const double r_um = b.r[i];
                        if (r_um <= 0.5 * pitch_um)
                            return scratch.value[j];
                        return r_um <= pitch_um
                                   ? plane.integral_over_disc(b.x[i], b.y[i], r_um)
                                   : exposure.integrate_over_disc(b.x[i], b.y[i], r_um);
                    }
                };
                const Centre centre { scratch.plane };
                const Disc disc { scratch.plane, layer.exposure, scratch.disc_batch,
                                  scratch.plane.pitch_um() };
                // Silver without inhibition (the common case) runs the
                // kernel without the per-grain checks of MODEL.md 8, 10.
                const bool plain = layer.image_reach == 1.0 && !layer.inhibition;
                const auto run = [&](const auto& integral) {
                    if (plain)
                        develop_fast<true>(layer, pop, rect, scratch, c, integral);
                    else
                        develop_fast<false>(layer, pop, rect, scratch, c, integral);
                };
                if (pop.exposure == ExposureMethod::centre)
                    run(centre);
                else
                    run(disc);
                grains += c.grains;
                developed += c.developed;
                photons += c.photons;
                events += c.events;
                scratch.population_end.push_back(scratch.discs.size());
                continue;
            }
            // Each bin's cells as far as its own grains' images reach.
            pop.grains.for_each_grain_near(rect, std::max(1.0, layer.image_reach),
                                           [&](const Grain& g) {
                poll_stop(scratch.grains_seen);
                const Disc disc { g.x_um, g.y_um, g.radius_um };
                if (!image_touches_rect(layer, disc, rect))
                    return;
                const GrainOutcome o = simulate_grain(layer, pop, g);
                // Count each grain once: in the tile holding its centre.
                if (g.x_um >= rect.x0_um && g.x_um < rect.x1_um && g.y_um >= rect.y0_um
                    && g.y_um < rect.y1_um) {
                    ++grains;
                    developed += o.developed;
                    photons += o.photons;
                    events += o.events;
                    early += o.decided_early;
                }
                if (o.developed)
                    scratch.discs.push_back(disc);
            });
            scratch.population_end.push_back(scratch.discs.size());
        }
        LayerCounters& c = m_counters[l];
        c.grains += grains;
        c.developed += developed;
        c.photons += photons;
        c.events += events;
        c.decided_early += early;
        write_densities(scratch, l, x0, y0, x1, y1);
    }

    void fill_stats(RenderStats& stats) const
    {
        stats.layers.clear();
        const size_t nl    = m_stock.layers.size();
        const int64_t npix = m_roi.npixels();
        for (size_t l = 0; l < nl; ++l) {
            LayerStats ls;
            ls.name             = m_stock.layers[l].name;
            ls.grains           = m_counters[l].grains;
            ls.developed        = m_counters[l].developed;
            ls.absorbed_photons = m_counters[l].photons;
            ls.kinetics_events  = m_counters[l].events;
            ls.decided_early    = m_counters[l].decided_early;
            ls.path             = m_layers[l].path;
            ls.reason           = m_layers[l].reason;
            ls.error_estimate   = m_layers[l].error_estimate;
            ls.setup_seconds    = m_layers[l].setup_seconds;
            ls.estimated_seconds = m_layers[l].estimated_seconds;
            // Fixed summation order (row-major): deterministic.
            double sum = 0.0;
            for (int64_t i = 0; i < npix; ++i)
                sum += m_out[static_cast<size_t>(i) * nl + l];
            ls.mean_density = npix ? sum / static_cast<double>(npix) : 0.0;
            stats.layers.push_back(ls);
        }
    }

private:
    /// Mean absorbed photons of a grain (MODEL.md 2).
    double photon_mean(const LayerPlan& layer, const PopulationPlan& pop, const Grain& g) const
    {
        const double integral
            = pop.exposure == ExposureMethod::disc
                  ? layer.exposure.integrate_over_disc(g.x_um, g.y_um, g.radius_um)
                  : layer.exposure.value_at(g.x_um, g.y_um) * M_PI * g.radius_um * g.radius_um;
        return pop.photons_per_value_um2 * integral;
    }

    KineticsRates scaled_rates(const PopulationPlan& pop, const Grain& g) const
    {
        const double area  = M_PI * g.radius_um * g.radius_um;
        const double scale = rate_scale_for_area(area, pop.grains.mean_area_um2(),
                                                 pop.rate_area_exponent);
        return { pop.rates.k_pair_per_s * scale, pop.rates.k_join_per_s * scale,
                 pop.rates.k_loss_per_s * scale };
    }

    /// Leaves the tile (throws Stopped) once the render is stopped; looks
    /// at the flag each time the count passes a multiple of 4096 grains (a
    /// few microseconds of work apart). `count`: the worker's grain counter
    /// (TileScratch::grains_seen); `grains`: how many were just visited (a
    /// cell's batch in the fast kernel).
    void poll_stop(uint32_t& count, uint32_t grains = 1) const
    {
        const uint32_t before = count;
        count += grains;
        if ((before >> 12) != (count >> 12) && m_stop.load(std::memory_order_relaxed))
            throw Stopped {};
    }

    /// Counters of the fast kernel for one population and tile.
    struct FastCounts {
        uint64_t grains = 0, developed = 0, photons = 0, events = 0;
    };

    /// Cells of up to this many input pixels a side are filtered
    /// (grain_filter): their bound reads at most (this + 2)^2 pixels of
    /// the plane.
    static constexpr double kFilteredCellPitches = 4.0;

    /// The disc integrals weight the plane's values by areas that sum to
    /// pi r^2 to within the segment table's 1e-6 r^2 an edge: the filter's
    /// bound of a grain's mean photons takes this relative margin.
    static constexpr double kDiscAreaMargin = 1e-5;

    /// Filtering a lit population with a curve to the grains that can
    /// develop: a grain of radius r in cell (b, cx, cy) absorbs on average
    /// at most k v_max pi r^2 photons (MODEL.md 2's mean, photon_mean, at
    /// the largest value), v_max being the largest exposure value over the
    /// pixels the discs of the cell's grains can touch (times 1 +
    /// kDiscAreaMargin), so it develops with probability at most the
    /// curve's bound there (the inhibitors only lower it: log factor >= 0),
    /// and not at all when its uniform u < 1 - that bound. v_max comes from
    /// the tile's plane; a cell whose discs may reach beyond it, or of a bin
    /// whose cells are wider than kFilteredCellPitches pixels, keeps every
    /// grain. Which grains are dropped never changes an outcome: they
    /// cannot develop.
    struct GrainFilter {
        const DevelopCurve* curve = nullptr;  ///< null: every grain kept
        /// sqrt(k v_max pi (1 + kDiscAreaMargin)), sqrt(photons) per um:
        /// times r, the root of the bound of a grain's mean photons.
        double root_photons_per_um = 0.0;
        /// 1 - the bound at the cell's largest radius: a grain whose u is
        /// below it cannot develop, whatever its radius.
        double min_u = 0.0;
        explicit operator bool() const { return curve != nullptr; }
        bool may_keep(uint32_t u_bits) const
        {
            return uniform_from_bits(u_bits) >= min_u;
        }
        /// Whether a grain of radius r and development bits u_bits can
        /// develop (as develop_fast reads u from them).
        bool operator()(double r_um, uint32_t u_bits) const
        {
            return uniform_from_bits(u_bits)
                   >= 1.0 - curve->probability_bound_at_root(root_photons_per_um * r_um);
        }
    };
    static GrainFilter grain_filter(const DevelopCurve& curve, double k, const FastGrains& fast,
                                    size_t b, const ExposurePlane& plane, int64_t cx, int64_t cy)
    {
        const PopulationGrains::Bin& bin = fast.bins()[b];
        if (!(bin.cell_um <= kFilteredCellPitches * plane.pitch_um()))
            return {};
        // The cell's largest radius (the table's top node may differ from
        // the bin's by rounding).
        const double r  = std::max(bin.max_radius_um, fast.largest_radius_um(b));
        const double x0 = static_cast<double>(cx) * bin.cell_um;
        const double y0 = static_cast<double>(cy) * bin.cell_um;
        const double v_max
            = plane.max_over(x0 - r, y0 - r, x0 + bin.cell_um + r, y0 + bin.cell_um + r);
        if (!(v_max < std::numeric_limits<double>::infinity()))
            return {};
        GrainFilter f { &curve, std::sqrt(k * v_max * M_PI * (1.0 + kDiscAreaMargin)) };
        // The bound grows with r: at the cell's largest radius (a hair
        // more, for the interpolation's rounding) it holds every grain's.
        f.min_u = 1.0
                  - curve.probability_bound_at_root(f.root_photons_per_um * r * (1.0 + 1e-9));
        return f;
    }

    /// develop_fast's exposure integral for the fog's thinned grains
    /// (KineticsMethod::fog): none is read; each grain develops with
    /// probability 1, times the inhibitors' factor.
    struct NoLight {
        void prepare(const FastGrains::Batch&, const uint32_t*, size_t) const {}
        double operator()(const FastGrains::Batch&, size_t, size_t) const { return 0.0; }
    };

    /// Whether a grain's image (its disc, or its cloud) touches `rect`.
    static bool image_touches_rect(const LayerPlan& layer, const Disc& grain, const RectUm& rect)
    {
        const Disc image = layer.image_reach == 1.0
                               ? grain
                               : Disc { grain.x_um, grain.y_um, layer.image_reach * grain.r_um };
        return disc_touches_rect(image, rect.x0_um, rect.y0_um, rect.x1_um, rect.y1_um);
    }

    /// MODEL.md 1-4 for the grains of a population near a tile, by the fast
    /// per-grain kernel (grain_kernel.h): one uniform per grain against
    /// P(develop | mean photons). `integral(batch, i)` is the exposure value
    /// integrated over the disc (value x um^2), chosen once per population.
    /// Developed grains whose image touches the tile are appended to
    /// `discs`, in the grains' order.
    /// `Plain`: the layer is silver and not inhibited (no reach or uniform
    /// to adjust per grain).
    /// A cell at a time: first every grain's mean photons and decision from
    /// the curve in one loop without branches, then the grains whose image
    /// touches the tile counted and their discs kept, the few beyond the
    /// curve (blown highlights, or no curve) decided from their photon
    /// count.
    template<bool Plain, typename Integral>
    void develop_fast(const LayerPlan& layer, const PopulationPlan& pop, const RectUm& rect,
                      TileScratch& scratch, FastCounts& c, const Integral& integral) const
    {
        const FramePlane* inhibition = layer.inhibition.get();
        // The fog's thinned grains (KineticsMethod::fog): decided without
        // light or curve.
        constexpr bool kFog = std::is_same_v<Integral, NoLight>;
        // Without a curve (grains=fast asked for with other kinetics) every
        // grain takes the population's own decision.
        const DevelopCurve* curve = kFog ? nullptr : pop.curve.get();
        const double lambda_max
            = kFog ? std::numeric_limits<double>::infinity() : curve ? curve->lambda_max() : -1.0;
        const double k            = pop.photons_per_value_um2;
        const RectUm tile         = rect;
        std::vector<Disc>& discs  = scratch.discs;
        size_t nd                 = discs.size();
        // A lit population with a curve: of each cell only the grains that
        // can develop (grain_filter) are positioned and decided; the others
        // are counted.
        const ExposurePlane* filter_plane = !kFog && curve ? &scratch.plane : nullptr;
        const auto filter_of = [&](size_t bin, int64_t cx, int64_t cy) {
            return filter_plane ? grain_filter(*curve, k, *pop.fast, bin, *filter_plane, cx, cy)
                                : GrainFilter {};
        };
        // Each bin's cells as far as its own grains' images reach.
        pop.fast->for_each_cell_batch(
            rect, Plain ? 1.0 : std::max(1.0, layer.image_reach), scratch.batch, filter_of,
            [&](const FastGrains::Batch& b) {
                const size_t n = b.n;
                poll_stop(scratch.grains_seen, static_cast<uint32_t>(b.drawn));
                if (scratch.lambda.size() < n) {
                    scratch.lambda.resize(n);
                    scratch.u.resize(n);
                    scratch.decided.resize(n);
                    scratch.touching.resize(n);
                }
                // Each grain counted once: in the tile holding its centre.
                c.grains += pop.fast->drawn_within(b, tile);
                // The grains whose image touches the tile, in order: the
                // only ones whose exposure is read (a grain of a nearby cell
                // may lie beyond the input window a ROI was given).
                uint32_t* touching = scratch.touching.data();
                size_t m           = 0;
                for (size_t i = 0; i < n; ++i) {
                    const Disc disc { b.x[i], b.y[i], b.r[i] };
                    touching[m] = static_cast<uint32_t>(i);
                    m += Plain ? disc_touches_rect(disc, tile.x0_um, tile.y0_um, tile.x1_um,
                                                   tile.y1_um)
                               : image_touches_rect(layer, disc, tile);
                }
                // u in (0, 1); develops iff u >= 1 - P, as
                // Development::develops. Kept for the second loop where the
                // inhibitors change it.
                const auto uniform_of = [&](size_t i) {
                    double u = uniform_from_bits(b.u_bits[i]);
                    if constexpr (!Plain)
                        if (inhibition)
                            u = inhibited_uniform(u, inhibition->at(b.x[i], b.y[i]));
                    return u;
                };
                double* lambda   = scratch.lambda.data();
                double* uniform  = scratch.u.data();
                uint8_t* decided = scratch.decided.data();
                if (m > 0)
                    integral.prepare(b, touching, m);
                // Every touching grain's mean photons and its decision from
                // the curve (j: its place among them).
                const auto first_loop = [&](auto with_curve) {
                    for (size_t j = 0; j < m; ++j) {
                        const size_t i = touching[j];
                        const double l = k * integral(b, i, j);
                        const double u = uniform_of(i);
                        lambda[j]      = l;
                        if constexpr (!Plain)
                            uniform[j] = u;
                        // A grain beyond the curve reads it at 0 here and
                        // is decided below. A fog grain develops with
                        // probability 1: u >= 1 - 1 (inhibited u may be
                        // negative).
                        if constexpr (kFog)
                            decided[j] = u >= 0.0;
                        else if constexpr (decltype(with_curve)::value)
                            decided[j] = u >= 1.0 - curve->probability(l <= lambda_max ? l : 0.0);
                        else
                            decided[j] = 0;
                    }
                };
                if (curve)
                    first_loop(std::true_type {});
                else
                    first_loop(std::false_type {});
                if (discs.size() < nd + m)
                    discs.resize(std::max(2 * discs.size(), nd + m));
                for (size_t j = 0; j < m; ++j) {
                    const size_t i = touching[j];
                    const Disc disc { b.x[i], b.y[i], b.r[i] };
                    bool developed = decided[j];
                    GrainOutcome o;  // photons and events: only beyond the curve
                    if (!(lambda[j] <= lambda_max)) {
                        // The photon count, then the table or the chain, as
                        // the table path does.
                        const Grain g { disc.x_um, disc.y_um, disc.r_um, b.grain_id(i) };
                        o = decide_from_mean(pop, g, lambda[j], Plain ? uniform_of(i) : uniform[j]);
                        developed = o.developed;
                    }
                    // Counted in the tile holding its centre (as c.grains).
                    if (disc.x_um >= tile.x0_um && disc.x_um < tile.x1_um
                        && disc.y_um >= tile.y0_um && disc.y_um < tile.y1_um) {
                        c.developed += developed;
                        c.photons += o.photons;
                        c.events += o.events;
                    }
                    // Kept only if developed, without a branch on it.
                    discs[nd] = disc;
                    nd += developed;
                }
            });
        discs.resize(nd);
    }

    /// MODEL.md 2-4 for one grain: absorbed photons, latent image,
    /// development, by the population's methods. Every random value comes
    /// from the grain's own streams, one per stage.
    GrainOutcome simulate_grain(const LayerPlan& layer, const PopulationPlan& pop,
                                const Grain& g) const
    {
        GrainOutcome o;
        Rng development_rng(g.id, Stage::development);
        double u = development_rng.uniform();
        if (layer.inhibition)
            u = inhibited_uniform(u, layer.inhibition->at(g.x_um, g.y_um));
        if (pop.kinetics == KineticsMethod::fog) {
            // A grain of the fog's thinned process: develops with
            // probability 1 (u >= 1 - 1), times the inhibitors' factor.
            o.developed = u >= 0.0;
            return o;
        }
        if (pop.kinetics == KineticsMethod::chain) {
            // The reference: every grain's absorbed photons, then its chain
            // until the grain's fate is decided. u is drawn first and n4
            // never decreases, so the chain stopped when n4 reaches
            // n4_needed(u) (and not run when that is 0, or when no n4
            // decides) develops the grain exactly when the full chain of
            // the same stream would (kinetics test
            // StoppedChainDecidesAsTheFullChain).
            Rng photon_rng(g.id, Stage::photons);
            o.photons             = sample_poisson(photon_mean(layer, pop, g), photon_rng);
            const uint64_t needed = m_development.n4_needed(u);
            o.developed           = needed == 0;
            // Fewer than four electrons cannot build a 4-centre: n4 = 0
            // exactly, so the chain need not run.
            if (o.photons >= 4 && needed != 0
                && needed != std::numeric_limits<uint64_t>::max())
                run_chain_until_decided(pop, g, needed, o);
            return o;
        }
        // Both faster paths first ask whether u alone decides: every grain
        // develops with probability at least f (the fog), i.e. whenever
        // u >= 1 - f, whatever its photons.
        return decide_from_mean(pop, g, photon_mean(layer, pop, g), u);
    }

    /// The faster paths of MODEL.md 2-4 for a grain with mean absorbed
    /// photons `mean` and develop uniform u: whether u alone decides, else
    /// the photon count, then the table or the chain until decided.
    GrainOutcome decide_from_mean(const PopulationPlan& pop, const Grain& g, double mean,
                                  double u) const
    {
        GrainOutcome o;
        const uint64_t needed = m_development.n4_needed(u);
        if (needed == 0) {
            o.developed = o.decided_early = true;
            return o;
        }
        Rng photon_rng(g.id, Stage::photons);
        o.photons = sample_poisson(mean, photon_rng);
        if (o.photons < 4 || needed == std::numeric_limits<uint64_t>::max())
            return o;  // no 4-centre can form, or none would suffice
        if (pop.table && o.photons <= pop.table->max_photons()) {
            o.developed = u >= 1.0 - pop.table->probability(o.photons);
            return o;
        }
        // early_stop (or a grain brighter than the table).
        run_chain_until_decided(pop, g, needed, o);
        return o;
    }

    /// The chain of a grain with o.photons absorbed photons, from its own
    /// stream, until n4 reaches `needed` (the count that decides it), if
    /// ever: o.developed and o.events.
    void run_chain_until_decided(const PopulationPlan& pop, const Grain& g, uint64_t needed,
                                 GrainOutcome& o) const
    {
        Rng kinetics_rng(g.id, Stage::kinetics);
        const LatentImage latent = simulate_latent_image(
            o.photons, m_scene.shutter_s, scaled_rates(pop, g), kinetics_rng, &o.events, needed);
        o.developed = latent.n4 >= needed;
    }

    /// MODEL.md 5 at pixel scale (pixel_model.h): each pixel's exposure
    /// value is the area-weighted mean of the input pixels under it; its
    /// transmittance is drawn from the layer's pixel model. A layer with a
    /// pixel floor (engine_plan.h) draws only the pixels whose expected
    /// developed grains reach it; the others are rendered grain by grain
    /// first (a pixel's path depends on its own exposure alone, so any
    /// tiling gives the same image).
    void write_pixel_scale(TileScratch& scratch, size_t layer, int64_t x0, int64_t y0, int64_t x1,
                           int64_t y1)
    {
        const int64_t tw = x1 - x0, th = y1 - y0;
        const size_t n   = static_cast<size_t>(tw * th);
        const LayerPlan& plan = m_layers[layer];
        scratch.values.resize(n);
        // The scan pixels' edges on the film.
        std::vector<double>& xs = scratch.edges_x;
        std::vector<double>& ys = scratch.edges_y;
        xs.resize(static_cast<size_t>(tw + 1));
        ys.resize(static_cast<size_t>(th + 1));
        for (int64_t i = 0; i <= tw; ++i)
            xs[static_cast<size_t>(i)] = m_frame.scan_rect(x0 + i, y0, x0 + i, y0).x0_um;
        for (int64_t j = 0; j <= th; ++j)
            ys[static_cast<size_t>(j)] = m_frame.scan_rect(x0, y0 + j, x0, y0 + j).y0_um;
        plan.exposure.means_over_grid(xs, ys, scratch.values.data());
        // MODEL.md 10: the inhibitors' log factor at each pixel's centre
        // (it is constant over each input pixel; a scan pixel that spans
        // several takes its centre's).
        const double* log_factor = nullptr;
        if (plan.inhibition) {
            scratch.log_factor.resize(n);
            for (size_t j = 0; j < static_cast<size_t>(th); ++j)
                for (size_t i = 0; i < static_cast<size_t>(tw); ++i)
                    scratch.log_factor[j * static_cast<size_t>(tw) + i]
                        = plan.inhibition->at(0.5 * (xs[i] + xs[i + 1]), 0.5 * (ys[j] + ys[j + 1]));
            log_factor = scratch.log_factor.data();
        }
        // Which pixels the model draws.
        size_t drawn = n;
        if (plan.min_developed_per_pixel > 0.0) {
            scratch.drawn.resize(n);
            drawn = 0;
            for (size_t i = 0; i < n; ++i) {
                const double developed = plan.pixel_model->developed_per_pixel_at(
                    scratch.values[i], log_factor ? log_factor[i] : 0.0);
                scratch.drawn[i] = developed >= plan.min_developed_per_pixel;
                drawn += scratch.drawn[i];
            }
            // Grain by grain where a pixel is not drawn: in each band of
            // kBand rows, the runs of columns that hold one, runs less than
            // kBand columns apart joined (the drawn pixels among them are
            // written again below).
            constexpr int64_t kBand = 16;
            scratch.columns.resize(static_cast<size_t>(tw));
            for (int64_t b0 = y0; b0 < y1 && drawn < n; b0 += kBand) {
                const int64_t b1 = std::min(b0 + kBand, y1);
                std::fill(scratch.columns.begin(), scratch.columns.end(), uint8_t { 0 });
                for (int64_t iy = b0; iy < b1; ++iy)
                    for (int64_t i = 0; i < tw; ++i)
                        scratch.columns[static_cast<size_t>(i)]
                            |= !scratch.drawn[static_cast<size_t>((iy - y0) * tw + i)];
                for (int64_t i = 0; i < tw;) {
                    if (!scratch.columns[static_cast<size_t>(i)]) {
                        ++i;
                        continue;
                    }
                    int64_t end = i + 1, last = i + 1;  // one past the run's last such column
                    for (; end < tw && end < last + kBand; ++end)
                        if (scratch.columns[static_cast<size_t>(end)])
                            last = end + 1;
                    render_grains(scratch, layer, x0 + i, b0, x0 + last, b1);
                    i = last;
                }
            }
            if (drawn == 0)
                return;
        }
        scratch.fraction.resize(n);
        sample_pixel_transmittance(*plan.pixel_model, plan.pixel_key, x0, y0, x1, y1,
                                   scratch.values.data(), log_factor, scratch.fraction.data());
        for (int64_t iy = y0; iy < y1; ++iy)
            for (int64_t ix = x0; ix < x1; ++ix) {
                const size_t i = static_cast<size_t>((iy - y0) * tw + (ix - x0));
                if (drawn == n || scratch.drawn[i])
                    store_density(layer, ix, iy, 1.0 - scratch.fraction[i]);
            }
    }

    void store_transmittance(size_t layer, int64_t ix, int64_t iy, double transmittance) const
    {
        const size_t nl = m_stock.layers.size();
        const size_t o  = static_cast<size_t>((iy - m_roi.y_begin) * m_roi.width()
                                             + (ix - m_roi.x_begin));
        m_out[o * nl + layer] = static_cast<float>(m_to_density[layer](transmittance));
    }

    void store_density(size_t layer, int64_t ix, int64_t iy, double covered_fraction) const
    {
        store_transmittance(layer, ix, iy, 1.0 - covered_fraction);
    }

    /// MODEL.md 5: the covered fraction of each pixel of the tile by the
    /// layer's coverage method, then densities. exact: the area covered by
    /// the union of the developed discs (grid_coverage, equal to
    /// union_coverage_um2 of every pixel to rounding); scanline and raster:
    /// sampled (image_formation.h).
    void write_densities(TileScratch& scratch, size_t layer, int64_t x0, int64_t y0, int64_t x1,
                         int64_t y1) const
    {
        const int64_t tw = x1 - x0, th = y1 - y0;
        const LayerPlan& plan = m_layers[layer];
        const double px = m_frame.scan_pitch_x_um, py = m_frame.scan_pitch_y_um;
        // The coverages place scan pixel x at [x px, (x + 1) px): where the
        // scan's grid starts elsewhere on the film (a scan reference inside
        // the frame), the discs move by the grid's origin instead.
        if (m_frame.scan_origin_x_um != 0.0 || m_frame.scan_origin_y_um != 0.0)
            for (Disc& d : scratch.discs) {
                d.x_um -= m_frame.scan_origin_x_um;
                d.y_um -= m_frame.scan_origin_y_um;
            }
        scratch.fraction.resize(static_cast<size_t>(tw * th));
        double* fraction = scratch.fraction.data();
        if (plan.dye_samples > 0) {  // MODEL.md 8: the mean of 10^-D
            dye_transmittance(scratch.discs, scratch.population_end, m_stock.layers[layer],
                              m_stock.max_density, x0, y0,
                              x1, y1, px, py, plan.dye_samples, scratch.dye, fraction);
            for (int64_t iy = y0; iy < y1; ++iy)
                for (int64_t ix = x0; ix < x1; ++ix)
                    store_transmittance(layer, ix, iy,
                                        fraction[static_cast<size_t>((iy - y0) * tw + (ix - x0))]);
            return;
        }
        switch (plan.coverage) {
        case CoverageMethod::exact:
            grid_coverage(scratch.discs, x0, y0, x1, y1, px, py, scratch.grid, fraction);
            break;
        case CoverageMethod::scanline:
            scanline_coverage(scratch.discs, x0, y0, x1, y1, px, py, plan.coverage_samples,
                              scratch.scanline, fraction);
            break;
        case CoverageMethod::raster:
            raster_coverage(scratch.discs, x0, y0, x1, y1, px, py, plan.coverage_samples,
                            scratch.raster, fraction);
            break;
        }
        for (int64_t iy = y0; iy < y1; ++iy)
            for (int64_t ix = x0; ix < x1; ++ix)
                store_density(layer, ix, iy, fraction[static_cast<size_t>((iy - y0) * tw + (ix - x0))]);
    }

    const Stock& m_stock;
    const SceneSettings& m_scene;
    const FrameGeometry& m_frame;
    Roi m_roi;
    const std::vector<LayerPlan>& m_layers;
    float* m_out;
    Development m_development;
    /// Each layer's density of a transmittance (MODEL.md 5).
    std::vector<DensityFromTransmittance> m_to_density;
    std::vector<LayerCounters> m_counters;
    const std::atomic<bool>& m_stop;
};


TileRenderer::TileRenderer(const Stock& stock, const SceneSettings& scene,
                           const FrameGeometry& frame, const Roi& roi,
                           const std::vector<LayerPlan>& layers, float* out,
                           const std::atomic<bool>& stop)
    : m_impl(std::make_unique<Impl>(stock, scene, frame, roi, layers, out, stop))
{
}

TileRenderer::~TileRenderer() = default;

void TileRenderer::render_tile(TileScratch& scratch, int64_t x0, int64_t y0, int64_t x1,
                               int64_t y1)
{
    m_impl->render_tile(scratch, x0, y0, x1, y1);
}

void TileRenderer::fill_stats(RenderStats& stats) const { m_impl->fill_stats(stats); }

}  // namespace filmgrain
