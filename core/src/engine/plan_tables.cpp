// The kinetics of a plan (MODEL.md 3-4; plan_context.h): the chain, or a
// table of P(develop | N) where one pays for itself, the fast kernel's
// curve folded from it, and the density error they add.
#include "engine/plan_context.h"

#include <cmath>

#include "expect/grain_counts.h"
#include "util/rng.h"
#include "util/sampling.h"

namespace filmgrain::planning {

namespace {

/// What a table saves on each grain beyond its chain, in chain steps
/// (events and photon arrivals, ~14 ns each): with P(develop | mean
/// photons) a grain is decided by one uniform at its centre's exposure,
/// without the disc integral of its exposure, the Poisson count and the
/// chain's set-up. Measured on 32x24 frames, 2 threads, early-stopped chain
/// against the fast kernel, per grain: color-negative 0.55 against 0.09 us
/// (32 steps), vision3-500t 1.9 against 0.7 us (84 steps); the smaller is
/// taken. (A table also opens the pixel scale, which saves every grain's
/// cost; not counted.)
constexpr double kTableSavedStepsPerGrain = 32.0;

/// Largest photon count a table covers; grains beyond run the chain
/// (early_stop, exact). Keeps the build cost bounded for blown highlights.
constexpr uint64_t kTablePhotonCap = uint64_t(1) << 12;
/// Normal score of the largest grain a table must cover: grains above it
/// (about one in 740) that also catch more photons than the table holds run
/// the chain instead (early_stop, exact).
constexpr double kTableAreaQuantileZ = 3.0;
/// Exposure value a table covers (diffuse white, ~2.5 stops over grey):
/// a property of the scene, not of the pixels, so that a ROI render uses
/// the same table, and draws the same grains, as the full frame.
constexpr double kTableTopValue = 1.0;

/// The largest exposure value v of a layer over an input region, and where.
struct RegionValues {
    double max = 0.0;
    int64_t max_x = 0, max_y = 0;
};
RegionValues region_values(const LayerExposure& ex, const InputRegion& r)
{
    RegionValues out;
    for (int64_t y = r.y0; y < r.y1; ++y)
        for (int64_t x = r.x0; x < r.x1; ++x) {
            const double v = ex.value(x, y);
            if (v > out.max) {
                out.max   = v;
                out.max_x = x;
                out.max_y = y;
            }
        }
    return out;
}

/// Chain steps (events and photon arrivals) per grain that the
/// early-stopped chain (KineticsMethod::early_stop) spends on a population
/// at the stock's grey exposure, estimated from a fixed pilot sample of 256
/// grains: sizes from the population's distribution, photon counts, develop
/// uniforms and chains drawn as the render draws them. The cost a table
/// would save; deterministic (seeded), and a property of the stock and the
/// scene, not of the pixels.
double early_stop_steps_per_grain(const Population& pop, const KineticsRates& rates,
                                   double photons_per_um2, double shutter_s,
                                   const Development& dev, uint64_t key)
{
    constexpr int kPilotGrains = 256;
    uint64_t steps = 0;
    for (int i = 0; i < kPilotGrains; ++i) {
        Rng draw(hash_ids(key, static_cast<uint64_t>(i)), Stage::photons);
        const double u_dev = draw.uniform();
        const uint64_t needed = dev.n4_needed(u_dev);
        const double z     = std::clamp(normal_quantile(draw.uniform_open0()), -9.0, 9.0);
        const double d_um  = diameter_at_z_um(pop, z);
        const uint64_t n   = sample_poisson(photons_per_um2 * M_PI / 4.0 * d_um * d_um, draw);
        if (needed == 0 || n < 4 || needed == std::numeric_limits<uint64_t>::max())
            continue;
        Rng chain(hash_ids(key, static_cast<uint64_t>(i)), Stage::kinetics);
        uint64_t events = 0, arrivals = 0;
        simulate_latent_image(n, shutter_s, rates, chain, &events, needed, &arrivals);
        steps += events + arrivals;
    }
    return static_cast<double>(steps) / kPilotGrains;
}

/// A population of a layer that reads a table: its grains and its mean
/// absorbed photons per (value x square micrometre).
struct TableUser {
    const Population* population;
    double photons_per_value_um2;
};

/// Bound on the bias of a layer's patch-mean density caused by one table,
/// read by `users` (populations of the layer), over uniform exposure
/// values from `value_max` down 16 stops. A patch's density is
/// D = 0.434 sum_pop n E[a P(N)] (MODEL.md 5), so a table error e(N) moves
/// it by 0.434 sum_N W_N e(N), with W_N = sum_pop n E[a 1{N_g = N}] at the
/// same exposure value: the populations read the same nodes. Node errors
/// are independent Monte Carlo errors: their sum has standard deviation
/// sqrt(sum W_N^2 se_N^2), counted at 2 sigma; interpolation errors may all
/// lean one way, so they add as W_N times the bound. Counts above the
/// table run the chain.
double table_density_error(const std::vector<TableUser>& users, const DevelopTable& table,
                           double value_max)
{
    double worst = 0.0;
    std::vector<double> w(static_cast<size_t>(table.max_photons()) + 1);
    for (int k = 0; k <= 32; ++k) {
        const double v = value_max * std::exp2(-0.5 * k);
        std::fill(w.begin(), w.end(), 0.0);
        double interp = 0.0;
        for (const TableUser& u : users)
            for_each_size_and_count(
                *u.population, u.photons_per_value_um2 * v,
                [&](size_t, double weight, double a, uint64_t n, double p) {
                    const double x = u.population->grains_per_um2 * weight * a * p;
                    w[static_cast<size_t>(n)] += x;
                    if (!table.is_node(n))
                        interp += x * table.max_interpolation_error();
                },
                table.max_photons());
        double var = 0.0;
        for (size_t n = 0; n < w.size(); ++n)
            if (w[n] > 0.0) {
                const double se = table.standard_error(n);
                var += w[n] * w[n] * se * se;
            }
        worst = std::max(worst, kLog10E * (2.0 * std::sqrt(var) + interp));
    }
    return worst;
}

}  // namespace

namespace {

/// Asks for a table for population p of layer l, whose region's largest
/// exposure value is v_max and whose exposure saturates at v_saturated.
void request_table(const PlanContext& c, size_t l, size_t p, const PopulationPlan& pp,
                   double n_mean_area, double v_max, double v_saturated, TableRequests& tables)
{
    const Population& pop = c.stock.layers[l].populations[p];
    // What the frame's grains would cost without a table, at grey (or at
    // the saturated exposure, where grey lies past it: an exposure offset
    // of many stops): their early-stopped chains, and the per-grain work
    // the table saves. (The whole frame, and grey rather than the pixels:
    // a ROI render must decide as the full frame does.) Not needed when
    // the table is asked for explicitly.
    const double pilot_value = std::min(kGreyValue, v_saturated);
    const double steps
        = c.forced_table
              ? 0.0
              : pop.grains_per_um2 * c.frame.width_um * c.frame.height_um
                    * (early_stop_steps_per_grain(pop, pp.rates,
                                                  pp.photons_per_value_um2 * pilot_value,
                                                  c.scene.shutter_s, c.development,
                                                  hash_ids(grain_seed(c.scene), 0x9170, l, p))
                       + kTableSavedStepsPerGrain);
    // The photon count of a grain short of the largest ones at the table's
    // top value, plus 6 Poisson sigmas; brighter grains run the
    // early-stopped chain (quickly decided: they develop).
    const double d_q = diameter_at_z_um(pop, kTableAreaQuantileZ);
    const double lam = pp.photons_per_value_um2 * kTableTopValue * M_PI / 4.0 * d_q * d_q;
    const double n_need = lam + 6.0 * std::sqrt(lam) + 10.0;
    // Budget: a node error e moves a patch density by at most
    // 0.434 n E[a] e; nodes' errors partly average (estimated below).
    const double target = std::max(c.fast ? 5e-3 : 0.0,
                                   kTableShare * c.settings.tolerance / (kLog10E * n_mean_area));
    // Rounded up to a power of two so that renders share tables
    // (shared_develop_table). The table's stream is the same for every seed
    // and frame (keyed by the rates' order only): a sequence's frames (and
    // any seed) share one table, so the table's own error is the same on
    // every frame (no flicker of mean density from frame to frame) and is
    // paid once per process; frame_seed(seed, frame) still renders as the
    // single image of that seed.
    uint64_t n_max = 64;
    while (n_max < n_need && n_max < kTablePhotonCap)
        n_max *= 2;
    std::vector<TableRequest>& requests = tables.requests;
    size_t r = 0;
    while (r < requests.size()
           && !(requests[r].rates.k_pair_per_s == pp.rates.k_pair_per_s
                && requests[r].rates.k_join_per_s == pp.rates.k_join_per_s
                && requests[r].rates.k_loss_per_s == pp.rates.k_loss_per_s))
        ++r;
    if (r == requests.size()) {
        TableRequest req;
        req.rates                         = pp.rates;
        req.options.max_photons           = n_max;
        req.options.target_standard_error = target;
        req.options.stream_key            = hash_ids(0x7ab1e, r);
        req.options.nthreads              = c.settings.nthreads;
        req.options.cancel                = c.cancel;
        req.grain_steps                   = steps;
        requests.push_back(req);
    } else {
        auto& o                 = requests[r].options;
        o.max_photons           = std::max(o.max_photons, n_max);
        o.target_standard_error = std::min(o.target_standard_error, target);
        requests[r].grain_steps += steps;
    }
    tables.needs.push_back({ l, p, r, v_max, n_need > kTablePhotonCap });
}

}  // namespace

/// The kinetics chooser, per population of layer l: the exact engine's
/// chain; fog for a layer no light reaches (plan_unlit_layers); the
/// early-stopped chain where no table can serve; else a table request
/// (built or refused by build_tables). Whether light reaches the layer is
/// read over the region the render reads (read_region), the same for
/// every tile and, where the stock spreads light or inhibits, for every
/// ROI. Its reasons go to plan.notes.
Status choose_kinetics(const PlanContext& c, size_t l, LayerPlan& plan, TableRequests& tables)
{
    const Layer& layer = c.stock.layers[l];
    double n_mean_area = 0.0;
    for (size_t p = 0; p < plan.populations.size(); ++p)
        n_mean_area += layer.populations[p].grains_per_um2 * plan.populations[p].grains.mean_area_um2();
    const RegionValues values = region_values(plan.exposure, c.region);
    const bool unlit          = !(values.max > 0.0);
    if (c.settings.kinetics == KineticsMethod::fog && !unlit)
        return Status::errorf("kinetics=fog: light reaches layer '", layer.name,
                              "' (input pixel (", values.max_x, ", ", values.max_y,
                              ") gives it an exposure of ",
                              format_g(values.max * c.lxs_per_value),
                              " lxs): fog alone decides only layers that no light reaches");
    if (unlit && !c.exact && (!c.settings.kinetics || c.settings.kinetics == KineticsMethod::fog)) {
        plan.unlit = true;
        for (PopulationPlan& pp : plan.populations)
            pp.kinetics = KineticsMethod::fog;
        return {};
    }
    for (size_t p = 0; p < plan.populations.size(); ++p) {
        PopulationPlan& pp    = plan.populations[p];
        const Population& pop = layer.populations[p];
        if (c.exact) {
            pp.kinetics = KineticsMethod::chain;
            continue;
        }
        KineticsMethod want = c.settings.kinetics ? *c.settings.kinetics : KineticsMethod::table;
        // The curve is built from the table: both ask for one.
        if (want == KineticsMethod::curve)
            want = KineticsMethod::table;
        if (want == KineticsMethod::table && pop.rate_area_exponent != 0.0) {
            want = KineticsMethod::early_stop;
            PlanNotes::Kinetics note;
            note.kind       = PlanNotes::Kinetics::Kind::size_dependent;
            note.population = p;
            plan.notes.kinetics.push_back(note);
        }
        pp.kinetics = want;
        if (want == KineticsMethod::table)
            request_table(c, l, p, pp, n_mean_area, values.max, plan.exposure.max_value(),
                          tables);
    }
    return {};
}

/// Builds the requested tables. A table is built only when it costs fewer
/// chain steps (events and photon arrivals) than the frame's grains would
/// spend in the early-stopped chain, which decides most grains within a
/// few steps, and in the per-grain work the table saves
/// (kTableSavedStepsPerGrain): otherwise that chain runs, with the exact
/// engine's results and no error of its own. The decision depends on
/// seeded pilots and the table's full cost only, never on which tables
/// earlier renders left in the cache, nor on the ROI.
Status build_tables(const PlanContext& c, TableRequests& tables)
{
    for (TableRequest& req : tables.requests) {
        const auto t0 = std::chrono::steady_clock::now();
        // kinetics=table asked for explicitly: built whatever it costs.
        // Otherwise only when predicted to cost less than the chains it
        // replaces, and stopped (deterministically) if it costs more than
        // twice that after all.
        const bool pays = c.forced_table
                          || DevelopTable::predicted_steps(req.options, req.rates,
                                                           c.scene.shutter_s, c.development)
                                 <= req.grain_steps;
        if (pays) {
            if (!c.forced_table)
                req.options.step_budget
                    = static_cast<uint64_t>(std::clamp(2.0 * req.grain_steps, 1.0, 1e18));
            req.table
                = shared_develop_table(req.rates, c.scene.shutter_s, c.development, req.options);
        }
        // Setup time: the pilot, and the build when there is one.
        req.seconds = seconds_since(t0);
        if (c.cancelled())
            return Status::error("render cancelled");
    }
    return {};
}

/// Gives each population that asked for a table its table (or the
/// early-stopped chain where the table was refused), and the fast
/// per-grain kernel's curve where it runs; adds their error bounds to the
/// layers' error estimates. Returns, per layer, the tables' and curves'
/// density error bounds over the exposures a table covers (to 16x (4
/// stops) past where a mean-sized grain of its least sensitive reader has
/// the table's largest count as its mean, and 16 stops below): what the
/// raster's budget is sized from. The error estimate is over the region's
/// exposures (for --stats); the bound depends on neither the region nor
/// its pixels, so the raster's rows are the same for every ROI.
std::vector<double> attach_tables(const PlanContext& c, const TableRequests& tables,
                                  std::vector<LayerPlan>& out)
{
    std::vector<double> kinetics_bound(out.size(), 0.0);
    std::vector<bool> charged(tables.requests.size(), false);
    std::vector<std::shared_ptr<const DevelopCurve>> curves(tables.requests.size());
    // The populations of each layer that read each table, and the layer's
    // region's largest exposure value.
    struct Readers {
        std::vector<TableUser> users;
        double value_max = 0.0, bound_value = 0.0;
    };
    std::vector<std::vector<Readers>> readers(out.size(),
                                              std::vector<Readers>(tables.requests.size()));
    for (const TableNeed& need : tables.needs) {
        LayerPlan& plan        = out[need.layer];
        PopulationPlan& pp     = plan.populations[need.population];
        const TableRequest& rq = tables.requests[need.request];
        if (!charged[need.request]) {  // a shared table's time is charged once
            plan.setup_seconds += rq.seconds;
            charged[need.request] = true;
        }
        if (!rq.table || !rq.table->complete()
            || (rq.options.step_budget && rq.table->total_steps() > rq.options.step_budget)) {
            pp.kinetics = KineticsMethod::early_stop;
            PlanNotes::Kinetics note;
            note.kind        = PlanNotes::Kinetics::Kind::table_refused;
            note.population  = need.population;
            note.grain_steps = rq.grain_steps;
            plan.notes.kinetics.push_back(note);
            continue;
        }
        pp.table = rq.table;
        const Population& pop = c.stock.layers[need.layer].populations[need.population];
        Readers& r = readers[need.layer][need.request];
        r.users.push_back({ &pop, pp.photons_per_value_um2 });
        r.value_max = need.value_max;
        if (pp.photons_per_value_um2 > 0.0)
            r.bound_value = std::max(r.bound_value,
                                     16.0 * static_cast<double>(pp.table->max_photons())
                                         / (pp.grains.mean_area_um2() * pp.photons_per_value_um2));
        // The fast per-grain kernel (P(develop | mean photons), one uniform
        // per grain) wherever a table is built, unless the table itself
        // was asked for.
        if ((!c.settings.kinetics || *c.settings.kinetics == KineticsMethod::curve)
            && c.settings.grains != GrainMethod::exact) {
            if (!curves[need.request])
                curves[need.request] = std::make_shared<const DevelopCurve>(*pp.table);
            pp.kinetics = KineticsMethod::curve;
            pp.curve    = curves[need.request];
            pp.fast     = std::make_shared<const FastGrains>(pp.grains);
            // Exposure: integrated over the disc, as the population's plan
            // already says (from the tile's plane for grains up to an input
            // pixel in radius, grain_kernel.h; the input image's integral
            // for larger ones, 0.3-1.4 us each). Sampling larger grains at
            // their centre instead was measured biased by -0.10 D (-0.27 on
            // edges) on a natural image under 1.5 um input pixels and 6 um
            // grains (docs/performance/README.md, "Grains larger than the
            // input pixels, measured"). engine=fast samples the centre.
            // A curve error e moves a patch density by at most 0.434 n E[a] e.
            const double curve_bound = kLog10E * pop.grains_per_um2 * pp.grains.mean_area_um2()
                                       * pp.curve->max_interpolation_error();
            plan.error_estimate += curve_bound;
            kinetics_bound[need.layer] += curve_bound;
        }
        PlanNotes::Kinetics note;
        note.kind       = PlanNotes::Kinetics::Kind::table;
        note.population = need.population;
        note.table      = need.request;
        note.capped     = need.capped;
        plan.notes.kinetics.push_back(note);
    }
    // Each table's bound over its readers in a layer. The region's
    // estimate (--stats) is over a part of the bound's range, so capped by
    // it: both take the largest of a grid of exposures, and a grid point of
    // the region's may land nearer the peak by ~0.1%, which made
    // error_estimate exceed the tolerance it was sized for.
    for (size_t l = 0; l < out.size(); ++l)
        for (size_t q = 0; q < tables.requests.size(); ++q) {
            const Readers& r = readers[l][q];
            if (r.users.empty())
                continue;
            const DevelopTable& table = *tables.requests[q].table;
            const double bound        = table_density_error(r.users, table, r.bound_value);
            out[l].error_estimate
                += std::min(bound, table_density_error(r.users, table, r.value_max));
            kinetics_bound[l] += bound;
        }
    return kinetics_bound;
}

/// grains=fast asked for without the curve: the kernel's grains with the
/// population's own decisions (to measure the curve and the raster against
/// exact decisions and coverage on the same grains).
void choose_grains(const PlanContext& c, std::vector<LayerPlan>& out)
{
    if (c.settings.grains != GrainMethod::fast)
        return;
    for (LayerPlan& plan : out)
        for (PopulationPlan& pp : plan.populations)
            if (!pp.fast)
                pp.fast = std::make_shared<const FastGrains>(pp.grains);
}

}  // namespace filmgrain::planning
