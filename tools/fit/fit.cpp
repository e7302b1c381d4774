// filmgrain-fit's search (fit.h).
#include "fit.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <sstream>

#include <nlopt.hpp>

#include "expect/expected_curve_model.h"
#include "analysis.h"
#include "granularity.h"
#include "model/exposure.h"
#include "model/image_formation.h"
#include "util/parallel.h"
#include "patch.h"
#include "strip.h"
#include "util/rng.h"

namespace filmgrain::fit {

namespace sm = filmgrain::sensitometry;

namespace {

/// What an objective returns for a candidate that cannot be measured (its
/// curve never reaches a target density): far above any measurable one,
/// and growing with the density it lacks, so that a search that starts or
/// strays there finds its way back.
constexpr double kUnmeasurable = 1e6;
double unmeasurable(const Stock& stock, const sm::Datasheet& sheet, DevelopModels& models)
{
    return kUnmeasurable * (1.0 + sm::density_shortfall(stock, sheet, models));
}

/// Bounds of the population search (real emulsion scale; the stock
/// format's ranges are wider; at most 15 grains per um^2 per population,
/// 30 per layer at the default 2 populations, the issue's 3-30): log10
/// grains_per_um2, log10 diameter_um,
/// diameter_log_sigma, log10 quantum_efficiency.
constexpr double kLo[4] = { std::log10(0.5), std::log10(0.2), 0.05, -2.0 };
constexpr double kHi[4] = { std::log10(kMaxGrainsPerPopulationPerUm2), std::log10(3.0), 0.8,
                            0.0 };
/// Bounds of a dye layer's cloud search (MODEL.md 8): log10
/// cloud_diameter_ratio, log10 cloud_density. Clouds at most twice their
/// grain's diameter: larger ones lower the granularity further (a VISION3
/// fit ran to 3, the previous bound), but spread each grain's image over
/// neighbouring pixels of a 4K scan, where the pixel scale no longer
/// applies (an hours-long grain-by-grain render).
constexpr double kCloudLo[2] = { std::log10(0.5), std::log10(0.05) };
constexpr double kCloudHi[2] = { std::log10(2.0), std::log10(5.0) };
/// Bounds of a coupler-limited population's max_dye_density over its
/// layer's cloud_density, and where it starts.
constexpr double kLimitLo = 0.05, kLimitHi = 1.0, kLimitStart = 0.7;
/// Upper bound of a layer's self-inhibition a (MODEL.md 10) in a stock
/// whose densities are clamped at max_density M. On a uniform patch the
/// layer's density above base is S exp(-a min(S, M)) for the uninhibited
/// S (Dbar is an expected density, clamped as every density is, MODEL.md
/// 5), whose slope exp(-a S) (1 - a S) is negative where a S > 1: with
/// a > 1 / M the characteristic curve falls with exposure somewhere below
/// the clamp, then rises again once Dbar is clamped. a <= 1 / M keeps every
/// curve rising.
double self_inhibition_hi(const Stock& stock) { return 1.0 / stock.max_density; }
/// Where it starts: 0.1 (P falls by a tenth at density 1 above base).
constexpr double kSelfInhibitionStart = 0.1;
/// Bounds of the rate search, log10 per second: k_pair, k_join, k_loss.
constexpr double kRateLo[3] = { 3.0, 2.0, -3.0 };
constexpr double kRateHi[3] = { 12.0, 11.0, 5.0 };

std::string format(double x, int precision = 4)
{
    std::ostringstream o;
    o.precision(precision);
    o << x;
    return o.str();
}

/// A uniform in [0, 1) from (seed, ids): the fit's only randomness.
double uniform(uint64_t seed, uint64_t a, uint64_t b, uint64_t c)
{
    return static_cast<double>(hash_ids(seed, a, b, c) >> 11) * 0x1.0p-53;
}

std::array<double, 3> luma_or_primary(const std::string& name)
{
    if (name == "R")
        return { 1.0, 0.0, 0.0 };
    if (name == "G")
        return { 0.0, 1.0, 0.0 };
    if (name == "B")
        return { 0.0, 0.0, 1.0 };
    return { 0.2126, 0.7152, 0.0722 };
}


/// The speed point every layer aims at: ISO 6 H_m = 0.8 / S; ISO 5800
/// H_M = sqrt(2) / S, every layer equally fast (so H_G = H_slow = H_M).
double target_speed_log10_h(const sm::Datasheet& sheet)
{
    const double s = *sheet.speed;
    return sheet.speed_standard == "ISO 5800" ? std::log10(std::sqrt(2.0) / s)
                                              : std::log10(0.8 / s);
}

/// What a miss of one of issue 10's figures (speed, slope, granularity)
/// beyond 0.9 of its tolerance adds, per squared tolerance unit: they are
/// held to their tolerance first, so that the characteristic curve's
/// points (our tolerance, 20 or so a layer, each a figure) are not bought
/// with them. (Until 2026-12-07 granularity was not held, so that one the
/// model cannot reach, model_limits, would not be traded for speed and
/// slope; held, such a granularity now weighs as they do.)
constexpr double kHeldMissWeight = 10.0;

/// Squared misses of one layer's figures in tolerance units (D-min aside:
/// the base absorbs it; only fog above the target D-min counts), issue
/// 10's near and beyond their tolerance weighted up (kHeldMissWeight).
double layer_objective(const sm::Datasheet& sheet, size_t i, const sm::DatasheetFigures& f,
                       double base_density)
{
    const sm::LayerTargets& t         = sheet.layers[i];
    const sm::DatasheetFigures::Layer& l = f.layers[i];
    const sm::Tolerances tol;
    const auto held_miss = [](double r) {
        const double over = std::max(0.0, std::fabs(r) - 0.9);
        return r * r + kHeldMissWeight * over * over;
    };
    double j = 0.0;
    if (sheet.speed)
        j += held_miss(kStopsPerDecade * (l.speed_log10_h.value - target_speed_log10_h(sheet))
                       / tol.speed_stops);
    if (t.slope) {
        j += held_miss((l.slope.value - *t.slope) / tol.slope);
        for (const sm::Figure& half : l.slope_halves)
            j += held_miss((half.value - *t.slope) / tol.slope_half);
    }
    for (size_t g = 0; g < t.granularity.size(); ++g) {
        j += held_miss((l.granularity[g].value / t.granularity[g].rms - 1.0)
                       / tol.granularity_rel);
    }
    if (t.d_min) {
        const double fog = l.d_min.value - base_density;
        const double r   = std::max(0.0, fog - *t.d_min) / tol.d_min;
        j += r * r;
    }
    // The curve's points above D-min (the base is fitted afterwards, so
    // net density is what the populations set), each a figure like the
    // others: the curve is the look, and its toe is what a grey ramp
    // through ADX reads (issue 40).
    if (!t.curve.empty()) {
        const double d_min = t.curve_d_min();
        for (size_t k = 0; k < t.curve.size(); ++k) {
            const double r = ((l.curve[k].value - l.d_min.value) - (t.curve[k].second - d_min))
                             / tol.curve_density;
            j += r * r;
        }
    }
    return j;
}

/// The base densities that put each layer's D-min on the datasheet's: the
/// stock's base_density the smallest base any layer needs, each layer's own
/// base_density the rest (a colour negative's mask), all >= 0. A layer
/// without a D-min target keeps its own. `f` was measured on `stock`.
void fit_base_densities(const sm::Datasheet& sheet, const sm::DatasheetFigures& f, Stock& stock)
{
    std::vector<std::pair<size_t, double>> need;  // stock layer, total base it needs
    for (size_t i = 0; i < sheet.layers.size(); ++i) {
        if (!sheet.layers[i].d_min)
            continue;
        size_t l = 0;
        while (l < stock.layers.size() && stock.layers[l].name != sheet.layers[i].name)
            ++l;
        if (l == stock.layers.size())
            continue;
        const double fog = f.layers[i].d_min.value - stock.layer_base_density(l);
        need.push_back({ l, std::max(0.0, *sheet.layers[i].d_min - fog) });
    }
    if (need.empty())
        return;
    double common = need.front().second;
    for (const auto& [l, b] : need)
        common = std::min(common, b);
    stock.base_density = common;
    for (const auto& [l, b] : need)
        stock.layers[l].base_density = b - common;
}

/// Reciprocity misses in tolerance units.
double reciprocity_objective(const sm::Datasheet& sheet, const sm::DatasheetFigures& f)
{
    double j = 0.0;
    for (const sm::Comparison& c : sm::compare_figures(sheet, f))
        if (c.figure.rfind("reciprocity", 0) == 0) {
            const double r = std::isfinite(c.miss) ? c.miss / c.tolerance : 1e3;
            j += r * r;
        }
    return j;
}

void set_population(Population& p, const double* x)
{
    p.grains_per_um2     = std::pow(10.0, x[0]);
    p.diameter_um        = std::pow(10.0, x[1]);
    p.diameter_log_sigma = x[2];
    p.quantum_efficiency = std::pow(10.0, x[3]);
}

void get_population(const Population& p, double* x)
{
    x[0] = std::log10(p.grains_per_um2);
    x[1] = std::log10(p.diameter_um);
    x[2] = p.diameter_log_sigma;
    x[3] = std::log10(p.quantum_efficiency);
    for (int k = 0; k < 4; ++k)
        x[k] = std::clamp(x[k], kLo[k], kHi[k]);
}

class Search {
public:
    Search(const sm::Datasheet& sheet, const FitOptions& options, Stock& stock, int& evaluations)
        : m_sheet(sheet), m_options(options), m_stock(stock), m_evaluations(evaluations)
    {
    }

    void say(const std::string& s) const
    {
        if (m_options.progress)
            m_options.progress(s);
    }

    /// Stage A for layer i of the datasheet (stock layer with that name).
    Status populations(size_t i, int round)
    {
        size_t l = 0;
        while (m_stock.layers[l].name != m_sheet.layers[i].name)
            ++l;
        const size_t np = m_stock.layers[l].populations.size();
        const bool dye  = m_stock.layers[l].image == LayerImage::dye;
        const bool inh  = !m_stock.inhibition.empty();
        // The coupler-limited populations' limits follow the clouds.
        std::vector<size_t> limited;
        for (size_t p = 0; p < np; ++p)
            if (m_stock.layers[l].populations[p].coupler_limited())
                limited.push_back(p);
        const size_t nc = 4 * np + (dye ? 2 : 0);   // index of the first limit
        const size_t nd = nc + limited.size();      // index of the inhibition
        const size_t n  = nd + (inh ? 1 : 0);
        std::vector<double> x0(n), lo(n), hi(n);
        for (size_t p = 0; p < np; ++p) {
            get_population(m_stock.layers[l].populations[p], &x0[4 * p]);
            x0[4 * p + 2] = std::min(x0[4 * p + 2], m_options.max_log_sigma);
            for (int k = 0; k < 4; ++k) {
                lo[4 * p + k] = kLo[k];
                hi[4 * p + k] = k == 2 ? m_options.max_log_sigma : kHi[k];
            }
        }
        if (dye) {
            const Layer& layer = m_stock.layers[l];
            x0[4 * np]     = std::clamp(std::log10(layer.cloud_diameter_ratio), kCloudLo[0], kCloudHi[0]);
            x0[4 * np + 1] = std::clamp(std::log10(layer.cloud_density), kCloudLo[1], kCloudHi[1]);
            for (int k = 0; k < 2; ++k) {
                lo[4 * np + k] = kCloudLo[k];
                hi[4 * np + k] = kCloudHi[k];
            }
        }
        for (size_t k = 0; k < limited.size(); ++k) {
            const Layer& layer = m_stock.layers[l];
            x0[nc + k] = std::clamp(layer.populations[limited[k]].max_dye_density
                                        / layer.cloud_density,
                                    kLimitLo, kLimitHi);
            lo[nc + k] = kLimitLo;
            hi[nc + k] = kLimitHi;
        }
        if (inh) {
            x0[nd] = std::clamp(m_stock.inhibition[l][l], 0.0, self_inhibition_hi(m_stock));
            lo[nd] = 0.0;
            hi[nd] = self_inhibition_hi(m_stock);
        }
        const auto set_layer = [&](Stock& stock, const std::vector<double>& x) {
            Layer& layer = stock.layers[l];
            for (size_t p = 0; p < np; ++p)
                set_population(layer.populations[p], &x[4 * p]);
            if (dye) {
                layer.cloud_diameter_ratio = std::pow(10.0, x[4 * np]);
                layer.cloud_density        = std::pow(10.0, x[4 * np + 1]);
            }
            for (size_t k = 0; k < limited.size(); ++k)
                layer.populations[limited[k]].max_dye_density = x[nc + k] * layer.cloud_density;
            if (inh)
                stock.inhibition[l][l] = x[nd];
        };
        // Tables at 1/100 s for the current rates: built once here.
        DevelopModels models(m_stock, m_options.search_curve);
        sm::FigureOptions fo;
        fo.curve              = m_options.search_curve;
        fo.reciprocity        = false;
        fo.granularity_bounds = false;  // the objective reads the values only
        // One evaluation of the objective on a trial stock of its own.
        const auto objective = [&](Stock& trial, const std::vector<double>& x) {
            set_layer(trial, x);
            sm::DatasheetFigures f;
            if (!sm::measure_datasheet_figures(trial, m_sheet, models, fo, f))
                return unmeasurable(trial, m_sheet, models);
            return layer_objective(m_sheet, i, f, trial.layer_base_density(l));
        };
        Stock first_trial        = m_stock;
        std::vector<double> best = x0;
        double best_j            = objective(first_trial, x0);  // builds the tables
        ++m_evaluations;
        // The starts run side by side: each has its own trial stock, and
        // the objective only reads the tables built above (one per rate set
        // and shutter, DevelopModels::get). Each start keeps the first
        // point of its lowest objective; taken in start order below, they
        // give what one start after another would (the first point of the
        // lowest objective overall, and the same stop once it is below
        // 1e-4): the same stock for any thread count.
        struct StartResult {
            std::vector<double> best;
            double best_j   = INFINITY;
            int evaluations = 0;
        };
        std::vector<StartResult> results(static_cast<size_t>(m_options.starts));
        std::atomic<bool> stop { false };
        std::mutex said;
        parallel_for(m_options.starts, m_options.search_curve.nthreads, stop,
                     [&](int, int64_t si) {
            const int s            = static_cast<int>(si);
            StartResult& result    = results[static_cast<size_t>(s)];
            Stock trial            = m_stock;
            std::vector<double> x  = x0;
            if (s > 0)
                for (size_t k = 0; k < n; ++k) {
                    // Jitter by up to +-15% of the range around the start.
                    const double u = uniform(m_options.seed, round * 131 + i, s, k);
                    x[k] = std::clamp(x[k] + (u - 0.5) * 0.3 * (hi[k] - lo[k]), lo[k], hi[k]);
                }
            nlopt::opt opt(nlopt::LN_SBPLX, static_cast<unsigned>(n));
            opt.set_lower_bounds(lo);
            opt.set_upper_bounds(hi);
            opt.set_maxeval(m_options.population_evals);
            opt.set_stopval(1e-4);
            opt.set_xtol_abs(1e-5);
            std::vector<double> step(n);
            for (size_t k = 0; k < n; ++k)
                step[k] = 0.08 * (hi[k] - lo[k]);
            opt.set_initial_step(step);
            struct Ctx {
                decltype(objective)* f;
                Stock* trial;
                StartResult* result;
            } ctx { &objective, &trial, &result };
            opt.set_min_objective(
                [](const std::vector<double>& xs, std::vector<double>&, void* data) {
                    Ctx* c         = static_cast<Ctx*>(data);
                    const double j = (*c->f)(*c->trial, xs);
                    ++c->result->evaluations;
                    if (j < c->result->best_j) {
                        c->result->best_j = j;
                        c->result->best   = xs;
                    }
                    return j;
                },
                &ctx);
            double minf = 0.0;
            try {
                opt.optimize(x, minf);
            } catch (const std::exception&) {
                // Roundoff or forced stops: the best point is kept above.
            }
            const std::lock_guard<std::mutex> lock(said);
            say("  round " + std::to_string(round + 1) + ", layer " + m_sheet.layers[i].name
                + ", start " + std::to_string(s + 1) + " of " + std::to_string(m_options.starts)
                + " done: objective " + format(result.best_j) + " (1 = one figure at tolerance)");
        });
        for (int s = 0; s < m_options.starts; ++s) {
            const StartResult& r = results[static_cast<size_t>(s)];
            m_evaluations += r.evaluations;
            if (r.best_j < best_j) {
                best_j = r.best_j;
                best   = r.best;
            }
            if (best_j < 1e-4)
                break;
        }
        say("  round " + std::to_string(round + 1) + ", layer " + m_sheet.layers[i].name
            + ": objective " + format(best_j) + ", " + std::to_string(m_evaluations)
            + " evaluations so far");
        set_layer(m_stock, best);
        return {};
    }

    /// Base density from the D-min targets (search precision).
    Status base()
    {
        DevelopModels models(m_stock, m_options.search_curve);
        sm::FigureOptions fo;
        fo.curve       = m_options.search_curve;
        fo.reciprocity = false;
        fo.granularity = false;
        sm::DatasheetFigures f;
        if (Status s = sm::measure_datasheet_figures(m_stock, m_sheet, models, fo, f); !s)
            return s;
        fit_base_densities(m_sheet, f, m_stock);
        return {};
    }

    /// Stage B: the rates shared by every population.
    Status rates(int round)
    {
        std::vector<double> x(3);
        const Population& p0 = m_stock.layers[0].populations[0];
        x[0] = std::clamp(std::log10(p0.k_pair_per_s), kRateLo[0], kRateHi[0]);
        x[1] = std::clamp(std::log10(p0.k_join_per_s), kRateLo[1], kRateHi[1]);
        x[2] = std::clamp(std::log10(p0.k_loss_per_s), kRateLo[2], kRateHi[2]);
        sm::FigureOptions fo;
        fo.curve       = m_options.rate_curve;
        fo.granularity = false;
        Stock trial    = m_stock;
        const auto set_rates = [](Stock& s, const std::vector<double>& r) {
            for (Layer& l : s.layers)
                for (Population& p : l.populations) {
                    p.k_pair_per_s = std::pow(10.0, r[0]);
                    p.k_join_per_s = std::pow(10.0, r[1]);
                    p.k_loss_per_s = std::pow(10.0, r[2]);
                }
        };
        std::vector<double> best = x;
        double best_j            = INFINITY;
        const auto objective = [&](const std::vector<double>& r) {
            set_rates(trial, r);
            DevelopModels models(trial, m_options.rate_curve);
            sm::DatasheetFigures f;
            ++m_evaluations;
            if (!sm::measure_datasheet_figures(trial, m_sheet, models, fo, f))
                return unmeasurable(trial, m_sheet, models);
            const double j = reciprocity_objective(m_sheet, f);
            if (j < best_j) {
                best_j = j;
                best   = r;
            }
            return j;
        };
        objective(x);
        nlopt::opt opt(nlopt::LN_SBPLX, 3);
        opt.set_lower_bounds(std::vector<double>(kRateLo, kRateLo + 3));
        opt.set_upper_bounds(std::vector<double>(kRateHi, kRateHi + 3));
        opt.set_maxeval(m_options.rate_evals);
        opt.set_stopval(1e-3);
        opt.set_xtol_abs(1e-3);
        opt.set_initial_step(std::vector<double>(3, 0.3));
        opt.set_min_objective(
            [](const std::vector<double>& r, std::vector<double>&, void* data) {
                return (*static_cast<decltype(objective)*>(data))(r);
            },
            const_cast<void*>(static_cast<const void*>(&objective)));
        double minf = 0.0;
        try {
            opt.optimize(x, minf);
        } catch (const std::exception&) {
        }
        set_rates(m_stock, best);
        say("  round " + std::to_string(round + 1) + ", rates: k_pair " + format(std::pow(10.0, best[0]))
            + " /s, k_join " + format(std::pow(10.0, best[1])) + " /s, k_loss "
            + format(std::pow(10.0, best[2])) + " /s: objective " + format(best_j) + ", "
            + std::to_string(m_evaluations) + " evaluations so far");
        return {};
    }

private:
    const sm::Datasheet& m_sheet;
    const FitOptions& m_options;
    Stock& m_stock;
    int& m_evaluations;
};

/// Whether the fitted stock has inhibition: options.inhibition, else on for
/// a colour negative datasheet.
bool fitted_inhibition(const sm::Datasheet& sheet, const FitOptions& options)
{
    if (options.inhibition)
        return *options.inhibition;
    return sheet.kind == "colour-negative";
}

/// The inhibition the search starts from: kSelfInhibitionStart in every
/// layer, none between layers.
void start_inhibition(const FitOptions& options, Stock& stock)
{
    stock.inhibition.assign(stock.layers.size(), std::vector<double>(stock.layers.size(), 0.0));
    for (size_t l = 0; l < stock.layers.size(); ++l)
        stock.inhibition[l][l] = kSelfInhibitionStart;
    stock.inhibitor_diffusion_um = options.inhibitor_diffusion_um;
}

/// Gives the first options.coupler_limited populations of every dye layer
/// without a limit one (kLimitStart of the cloud density).
void start_coupler_limits(const FitOptions& options, Stock& stock)
{
    for (Layer& l : stock.layers) {
        if (l.image != LayerImage::dye)
            continue;
        for (size_t p = 0; p < l.populations.size()
                           && p < static_cast<size_t>(options.coupler_limited);
             ++p)
            if (!l.populations[p].coupler_limited())
                l.populations[p].max_dye_density = kLimitStart * l.cloud_density;
    }
}

/// The image the fitted layers get: options.image, else dye for a colour
/// negative datasheet.
LayerImage fitted_image(const sm::Datasheet& sheet, const FitOptions& options)
{
    if (options.image)
        return *options.image;
    return sheet.kind == "colour-negative" ? LayerImage::dye : LayerImage::silver;
}

/// FitOptions::light_spread given to `stock`'s layers, each population's
/// quantum efficiency divided by the uniform-field gain it adds, and
/// FitOptions::film_base to the stock.
void apply_light_spread(const FitOptions& options, Stock& stock)
{
    if (options.film_base) {
        stock.base_thickness_um     = options.film_base->thickness_um;
        stock.base_refractive_index = options.film_base->refractive_index;
        stock.rear_face             = options.film_base->rear_face;
    }
    for (Layer& l : stock.layers) {
        const auto it = options.light_spread.find(l.name);
        if (it == options.light_spread.end())
            continue;
        const double before  = l.uniform_field_gain();
        l.scatter            = it->second.scatter;
        l.scatter_sigma_um   = it->second.scatter_sigma_um;
        l.halation           = it->second.halation;
        l.halation_radius_um = it->second.halation_radius_um;
        l.halation_kernel    = it->second.halation_kernel;
        for (Population& p : l.populations)
            p.quantum_efficiency *= before / l.uniform_field_gain();
    }
}

}  // namespace

Status initial_stock(const sm::Datasheet& sheet, const FitOptions& options, Stock& out)
{
    if (sheet.layers.empty())
        return Status::errorf("datasheet '", sheet.name, "' has no layers");
    if (!sheet.speed)
        return Status::errorf("datasheet '", sheet.name, "' gives no speed: the fit needs one");
    Stock s;
    s.name        = sheet.name;
    bool has_curve = false;
    for (const sm::LayerTargets& t : sheet.layers)
        has_curve = has_curve || !t.curve.empty();
    s.description = "Fitted by filmgrain-fit to the published figures of " + sheet.name
                    + " (speed, slope, D-min, RMS granularity, reciprocity"
                    + (has_curve ? ", characteristic curve" : "")
                    + "); a model of those figures, not the product.";
    s.exposure_at_grey_lxs = 10.0 / *sheet.speed;
    s.development_time_s   = options.development_time_s;
    s.development_tau_s    = options.development_tau_s;
    s.fog_tau_s            = options.fog_tau_s;
    s.base_density         = 0.0;
    s.max_density          = 4.0;
    // MODEL.md 11: the datasheet's Status M -> APD map, as published (no
    // figure is fitted with it: it only says how the densities print).
    s.status_m_to_apd      = sheet.printing_density;
    s.layers.clear();
    for (const sm::LayerTargets& t : sheet.layers) {
        Layer l;
        l.name        = t.name;
        l.sensitivity = luma_or_primary(t.name);
        // Dye clouds start as large as their grain, of density 1 (they
        // block 90% of what an opaque disc would).
        l.image = fitted_image(sheet, options);
        if (l.image == LayerImage::dye) {
            l.cloud_profile        = options.cloud_profile;
            l.cloud_diameter_ratio = options.start_cloud_ratio;
            l.cloud_density        = 1.0;
        }
        l.populations.clear();
        // Siedentopf: sigma_D^2 = 0.434 a D / A gives the mean developed
        // grain area a at the first granularity target (default: RMS 10
        // at net 1.0).
        const double rms = t.granularity.empty() ? 10.0 : t.granularity.front().rms;
        const double d_g = t.granularity.empty() ? 1.0 : t.granularity.front().density;
        const double a_dev
            = (rms / 1000.0) * (rms / 1000.0) * sm::kGranularityApertureAreaUm2 / (kLog10E * d_g);
        // Its grains: that image's diameter over the clouds' ratio.
        const double d_dev = std::sqrt(4.0 * a_dev / M_PI)
                             / (l.image == LayerImage::dye ? options.start_cloud_ratio : 1.0);
        for (int p = 0; p < options.populations; ++p) {
            Population pop;
            // Largest first, each next 0.7 times as large; together a
            // potential D-max of about 3.2.
            pop.diameter_um        = d_dev * std::pow(0.7, p);
            pop.diameter_log_sigma = 0.35;
            const double ea        = M_PI / 4.0 * pop.diameter_um * pop.diameter_um
                              * std::exp(pop.diameter_log_sigma * pop.diameter_log_sigma);
            // (the developed image's area: a dye layer's cloud).
            const double image = l.image == LayerImage::dye
                                     ? options.start_cloud_ratio * options.start_cloud_ratio
                                     : 1.0;
            pop.grains_per_um2 = 3.2 / options.populations / (kLog10E * ea * image);
            pop.quantum_efficiency = 0.5;
            pop.k_pair_per_s       = 1e7;
            pop.k_join_per_s       = 1e6;
            pop.k_loss_per_s       = 10.0;
            double x[4];
            get_population(pop, x);
            set_population(pop, x);
            l.populations.push_back(pop);
        }
        s.layers.push_back(l);
    }
    if (fitted_inhibition(sheet, options))
        start_inhibition(options, s);
    start_coupler_limits(options, s);
    if (Status st = s.validate(); !st)
        return st;
    out = s;
    return {};
}

Status measure(const Stock& stock, const sm::Datasheet& sheet, const ExpectedCurveOptions& curve,
               sm::DatasheetFigures& figures, std::vector<sm::Comparison>& comparisons)
{
    DevelopModels models(stock, curve);
    sm::FigureOptions fo;
    fo.curve              = curve;
    fo.unreached_is_error = false;  // reported as missed (the stock is still written)
    if (Status s = sm::measure_datasheet_figures(stock, sheet, models, fo, figures); !s)
        return s;
    comparisons = sm::compare_figures(sheet, figures);
    return {};
}

Status granularity_curve(const Stock& stock, const sm::Datasheet& sheet,
                         const ExpectedCurveOptions& curve,
                         const std::vector<double>& net_densities,
                         std::vector<std::vector<std::pair<double, sm::Figure>>>& out)
{
    DevelopModels models(stock, curve);
    return sm::granularity_against_density(stock, sheet, models, net_densities, out);
}

Status fit_stock(const sm::Datasheet& sheet, const FitOptions& options, FitResult& out)
{
    const auto t0 = std::chrono::steady_clock::now();
    if (options.populations < 1 || options.populations > 4)
        return Status::errorf("populations = ", options.populations, ": must be in [1, 4]");
    if (options.starts < 1 || options.starts > 16)
        return Status::errorf("starts = ", options.starts, ": must be in [1, 16]");
    if (options.rounds < 1 || options.rounds > 8)
        return Status::errorf("rounds = ", options.rounds, ": must be in [1, 8]");
    if (options.population_evals < 1 || options.rate_evals < 1)
        return Status::errorf("evaluation budgets must be >= 1");
    if (options.coupler_limited < 0 || options.coupler_limited > 4)
        return Status::errorf("coupler_limited = ", options.coupler_limited,
                              ": must be in [0, 4]");
    if (options.coupler_limited > 0
        && (fitted_image(sheet, options) != LayerImage::dye
            || options.cloud_profile != CloudProfile::disc))
        return Status::errorf("coupler-limited populations need dye layers with disc clouds "
                              "(--image dye --cloud-profile disc)");
    if (!(options.start_cloud_ratio >= 0.5 && options.start_cloud_ratio <= 2.0))
        return Status::errorf("start_cloud_ratio = ", options.start_cloud_ratio,
                              ": must be in [0.5, 2]");
    if (!(options.max_log_sigma >= kLo[2] && options.max_log_sigma <= kHi[2]))
        return Status::errorf("max_log_sigma = ", options.max_log_sigma, ": must be in [", kLo[2],
                              ", ", kHi[2], "]");
    if (options.start && options.start_cloud_ratio != 1.0)
        return Status::errorf("start_cloud_ratio sets the physical guess's clouds: a start "
                              "stock (--start) brings its own");
    const auto in_sheet = [&](const std::string& name) {
        return std::any_of(sheet.layers.begin(), sheet.layers.end(),
                           [&](const sm::LayerTargets& t) { return t.name == name; });
    };
    for (const auto& [name, spread] : options.light_spread)
        if (!in_sheet(name))
            return Status::errorf("light spread for layer '", name, "', which is not in datasheet '",
                                  sheet.name, "'");
    if (!options.layers.empty() && !options.start)
        return Status::errorf("fitting only some layers needs a start stock (--start)");
    for (const std::string& name : options.layers)
        if (!in_sheet(name))
            return Status::errorf("layer '", name, "' is not in datasheet '", sheet.name, "'");
    Stock stock;
    if (options.start) {
        stock = *options.start;
        if (options.image)
            for (Layer& l : stock.layers)
                if (l.image != *options.image) {
                    l.image = *options.image;
                    if (l.image == LayerImage::dye) {
                        l.cloud_profile        = options.cloud_profile;
                        l.cloud_diameter_ratio = 1.0;
                        l.cloud_density        = 1.0;
                    }
                }
        if (options.inhibition && *options.inhibition != stock.inhibits()) {
            stock.inhibition.clear();
            if (*options.inhibition)
                start_inhibition(options, stock);
        }
        start_coupler_limits(options, stock);
        if (Status s = stock.validate(); !s)
            return s;
    } else if (Status s = initial_stock(sheet, options, stock); !s) {
        return s;
    }
    {
        // The spread's keys are checked before the search, not after it.
        Stock spread = stock;
        apply_light_spread(options, spread);
        if (Status s = spread.validate(); !s)
            return s;
    }
    out = FitResult();
    Search search(sheet, options, stock, out.evaluations);
    const bool rates = options.fit_rates && sheet.has_reciprocity;
    for (int round = 0; round < options.rounds; ++round) {
        for (size_t i = 0; i < sheet.layers.size(); ++i)
            if (options.layers.empty()
                || std::find(options.layers.begin(), options.layers.end(), sheet.layers[i].name)
                       != options.layers.end())
                if (Status s = search.populations(i, round); !s)
                    return s;
        if (Status s = search.base(); !s)
            return s;
        if (rates && round + 1 < options.rounds)
            if (Status s = search.rates(round); !s)
                return s;
    }
    apply_light_spread(options, stock);
    if (options.progress)
        options.progress("measuring the result at full precision ...");
    if (Status s = measure(stock, sheet, options.final_curve, out.figures, out.comparisons); !s)
        return s;
    out.stock   = stock;
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return {};
}

double smallest_granularity_after(double rms1, double net1_density, double net2_density,
                                  double grains_per_um2, double above_base1_density)
{
    const double s1 = rms1 / 1000.0;
    const double k1 = std::log(10.0) * above_base1_density;  // bounds K_1(0)
    // sigma_2^2 >= g(r): the first term rises with r, the second falls
    // (r <= 1 < net2 / net1); the smallest over a fine grid in log r
    // (steps of 1e-3: g's minimum is flat to far below the bound's use).
    const auto g = [&](double log_r) {
        const double r     = std::exp(log_r);
        const double first = std::isfinite(k1) ? r * std::exp(-(1.0 - r) * k1) * s1 * s1 : 0.0;
        const double d     = net2_density - r * net1_density;
        return first + d * d / (r * grains_per_um2 * sm::kGranularityApertureAreaUm2);
    };
    constexpr int kNodes = 40000;
    constexpr double kLo = -40.0;  // r = 4e-18: below it the second term only grows
    double best_g        = g(kLo);
    for (int n = 1; n <= kNodes; ++n)
        best_g = std::min(best_g, g(kLo - kLo * n / kNodes));
    return 1000.0 * std::sqrt(best_g);
}

double smallest_falling_miss(double t1, double net1_density, double t2, double net2_density,
                             double grains_per_um2, double above_base1_density)
{
    const auto reachable = [&](double m) {
        return smallest_granularity_after(t1 * (1.0 - m), net1_density, net2_density,
                                          grains_per_um2, above_base1_density)
               <= t2 * (1.0 + m);
    };
    if (reachable(0.0))
        return 0.0;
    double lo = 0.0, hi = 1.0;  // m = 1 reads t1 as 0: always reachable
    for (int it = 0; it < 50; ++it) {
        const double m = 0.5 * (lo + hi);
        (reachable(m) ? hi : lo) = m;
    }
    return hi;
}

std::vector<std::string> model_limits(const sm::Datasheet& sheet, bool inhibited,
                                      const std::vector<double>& grains_per_um2)
{
    inhibited = inhibited && grains_per_um2.size() == sheet.layers.size();
    const double tolerance = sm::Tolerances().granularity_rel;
    std::vector<std::string> out;
    for (size_t i = 0; i < sheet.layers.size(); ++i) {
        const sm::LayerTargets& t = sheet.layers[i];
        // The D-min the net densities stand on (needed to read gross targets
        // as net and to bound the density above base); NAN if unknown.
        const double d_min = t.d_min || !t.curve.empty() ? t.curve_d_min() : NAN;
        // The worst falling pair (one reading: net or gross alike, by
        // density as the datasheet states them).
        double worst = 0.0;
        const sm::GranularityTarget* a = nullptr;
        const sm::GranularityTarget* b = nullptr;
        for (const sm::GranularityTarget& lo : t.granularity)
            for (const sm::GranularityTarget& hi : t.granularity) {
                if (!(lo.net == hi.net && lo.density < hi.density && lo.rms > hi.rms))
                    continue;
                double miss = (lo.rms - hi.rms) / (lo.rms + hi.rms);
                if (inhibited) {
                    const double shift = lo.net ? 0.0 : d_min;  // gross -> net
                    if (std::isnan(shift))
                        continue;
                    const double above_base
                        = std::isnan(d_min) ? INFINITY : lo.density - shift + d_min;
                    miss = smallest_falling_miss(lo.rms, lo.density - shift, hi.rms,
                                                 hi.density - shift, grains_per_um2[i], above_base);
                }
                if (miss > worst) {
                    worst = miss;
                    a     = &lo;
                    b     = &hi;
                }
            }
        // Reachable within the tolerance (a bound equal to it, up to the
        // rounding of the targets' difference, is reachable at it).
        if (!a || !(worst > tolerance + 1e-12))
            continue;
        std::ostringstream o;
        o << t.name << " RMS granularity falls from " << format(a->rms) << " at "
          << (a->net ? "net " : "") << "D " << format(a->density) << " to " << format(b->rms)
          << " at " << (b->net ? "net " : "") << "D " << format(b->density) << ": ";
        if (inhibited)
            o << "inhibition (MODEL.md 10) lets the granularity fall, but a layer of at most "
              << format(grains_per_um2[i]) << " grains per um^2 cannot fall that steeply";
        else
            o << "it grows with density (every P(develop) grows with exposure)";
        o << ", so at least one of the two misses by " << format(100.0 * worst, 3)
          << "% or more (tolerance " << format(100.0 * tolerance, 3) << "%)";
        out.push_back(o.str());
    }
    return out;
}

std::string comparison_table(const std::vector<sm::Comparison>& comparisons)
{
    std::ostringstream o;
    o << "| figure | target | achieved | error bound | miss | tolerance | |\n"
         "| --- | --- | --- | --- | --- | --- | --- |\n";
    for (const sm::Comparison& c : comparisons) {
        const bool rel = c.unit == "relative";
        o << "| " << c.figure << " | " << format(c.target) << " | "
          << (std::isfinite(c.achieved) ? format(c.achieved) : std::string("never reached"))
          << " | "
          << format(c.error, 2) << " | "
          << (rel ? format(100.0 * c.miss, 3) + "%" : format(c.miss, 3) + " " + c.unit) << " | "
          << (rel ? format(100.0 * c.tolerance, 3) + "%" : format(c.tolerance, 3) + " " + c.unit)
          << " | " << (c.met() ? "met" : "**missed**") << " |\n";
    }
    return o.str();
}

}  // namespace filmgrain::fit

namespace filmgrain::fit {

bool RenderCheckRow::agrees() const
{
    return std::fabs(rendered - analytic) <= 3.0 * rendered_se + analytic_error;
}

std::string RenderCheckRow::line() const
{
    std::ostringstream o;
    o << figure << ": analytic " << format(analytic) << " (bound " << format(analytic_error, 2)
      << "), rendered " << format(rendered) << " +- " << format(rendered_se, 2) << ", z "
      << format(rendered_se > 0.0 ? (rendered - analytic) / rendered_se : 0.0, 3) << ", "
      << (agrees() ? "agrees" : "DISAGREES");
    return o.str();
}

bool layer_develops_alone(const Stock& stock, size_t layer)
{
    if (!stock.inhibits())
        return true;
    const std::vector<double>& row = stock.inhibition[layer];
    for (size_t j = 0; j < row.size(); ++j)
        if (j != layer && row[j] != 0.0)
            return false;
    return true;
}

Stock layer_alone(const Stock& stock, size_t layer)
{
    Stock one  = stock;
    one.layers = { stock.layers[layer] };
    // The Status M -> APD map reads the layers R, G and B together
    // (MODEL.md 11): a layer alone has none (and no figure uses it).
    one.status_m_to_apd.reset();
    if (stock.inhibits())
        one.inhibition = { { stock.inhibition[layer][layer] } };
    return one;
}

Status render_check(const Stock& full_stock, const sm::Datasheet& sheet,
                    const sm::DatasheetFigures& figures, uint64_t seed, int nthreads,
                    const std::function<void(const std::string&)>& progress,
                    std::vector<RenderCheckRow>& out)
{
    out.clear();
    sm::MeasureSettings ms;
    ms.engine   = Engine::exact;
    ms.nthreads = nthreads;
    const bool iso5800    = sheet.speed_standard == "ISO 5800";
    const double crit_net = iso5800 ? sm::kIso5800SpeedNetDensity : sm::kIso6SpeedNetDensity;
    uint64_t patch        = 0;
    // The stock each patch renders: the whole stock, or only the checked
    // layer where no other layer inhibits it (the same image of that layer
    // in distribution, a third of a colour stock's work).
    Stock stock = full_stock;
    const auto expose = [&](double log10_h, double shutter_s, double side_um, double pitch_um,
                            sm::PatchReading& r, std::vector<std::vector<double>>* t) {
        sm::PatchSpec p;
        p.exposure_lxs = std::isfinite(log10_h) ? std::pow(10.0, log10_h) : 0.0;
        p.shutter_s    = shutter_s;
        p.side_um      = side_um;
        p.pitch_um     = pitch_um;
        p.seed         = sm::patch_seed(seed, patch++);
        p.blocks       = 8;
        return sm::expose_patch(stock, p, ms, r, t);
    };
    const auto say = [&](const std::string& s) {
        if (progress)
            progress(s);
    };
    for (size_t i = 0; i < sheet.layers.size(); ++i) {
        const sm::LayerTargets& t         = sheet.layers[i];
        const sm::DatasheetFigures::Layer& f = figures.layers[i];
        size_t l = 0;
        while (full_stock.layers[l].name != t.name)
            ++l;
        if (layer_develops_alone(full_stock, l)) {
            stock = layer_alone(full_stock, l);
            l     = 0;
        } else {
            stock = full_stock;
        }
        say("  render check: layer " + t.name
            + (stock.layers.size() == 1 ? " rendered alone" : " rendered with every layer"));
        // D-min: the unexposed patch.
        sm::PatchReading fog;
        if (Status s = expose(-INFINITY, sm::kDatasheetShutterS, 1000.0, 8.0, fog, nullptr); !s)
            return s;
        const sm::LayerReading& fr = fog.layers[l];
        out.push_back({ t.name + " D-min", f.d_min.value, f.d_min.error, fr.density, fr.density_se });
        say("  render check: " + out.back().line());
        // The speed point: net density crit_net at H_m.
        sm::PatchReading sp;
        if (Status s = expose(f.speed_log10_h.value, sm::kDatasheetShutterS, 1000.0, 8.0, sp, nullptr); !s)
            return s;
        const double se_net = std::hypot(sp.layers[l].density_se, fr.density_se);
        out.push_back({ t.name + " net density at the speed point", crit_net, f.d_min.error,
                        sp.layers[l].density - fr.density, se_net });
        say("  render check: " + out.back().line());
        if (t.slope) {
            sm::PatchReading a, b;
            if (Status s = expose(t.slope_log10_h_lo, sm::kDatasheetShutterS, 600.0, 8.0, a, nullptr); !s)
                return s;
            if (Status s = expose(t.slope_log10_h_hi, sm::kDatasheetShutterS, 600.0, 8.0, b, nullptr); !s)
                return s;
            const double span = t.slope_log10_h_hi - t.slope_log10_h_lo;
            out.push_back({ t.name + " slope", f.slope.value, f.slope.error,
                            (b.layers[l].density - a.layers[l].density) / span,
                            std::hypot(a.layers[l].density_se, b.layers[l].density_se) / span });
            say("  render check: " + out.back().line());
        }
        // Granularity: the exposure at which the analytic curve reaches
        // the target density (the curve at the final precision).
        if (!t.granularity.empty()) {
            std::vector<ExpectedCurve> curves;
            SceneSettings scene;
            scene.shutter_s = sm::kDatasheetShutterS;
            if (Status s = expected_curves(stock, scene, ExpectedCurveOptions(), curves); !s)
                return s;
            const ExpectedCurve& c = curves[l];
            const double sens      = stock.layers[l].neutral_weight();
            for (size_t g = 0; g < t.granularity.size(); ++g) {
                const sm::GranularityTarget& gt = t.granularity[g];
                const double d = gt.net ? c.min_density() + gt.density : gt.density;
                const double x = sm::log10_exposure_at_density(c, sens, d);
                sm::PatchReading r;
                std::vector<std::vector<double>> tr;
                if (Status s = expose(x, sm::kDatasheetShutterS, 1200.0, 2.0, r, &tr); !s)
                    return s;
                const filmgrain::ApertureTemplate ap
                    = filmgrain::make_circular_aperture(sm::kGranularityApertureUm, r.pitch_um);
                const sm::GranularityReading gr
                    = sm::read_granularity(tr[l], r.side_px, ap, 12, stock.layer_base_density(l), 4);
                out.push_back({ t.name + " RMS at " + (gt.net ? "net " : "gross ")
                                    + format(gt.density),
                                f.granularity[g].value, f.granularity[g].error,
                                1000.0 * gr.sigma_density, 1000.0 * gr.sigma_density_se });
                say("  render check: " + out.back().line());
            }
        }
        // Reciprocity: at each time, the analytic shift's exposure must
        // give the speed-point density again.
        for (size_t k = 0; k < figures.reciprocity.size(); ++k) {
            const double time_s = figures.reciprocity[k].first;
            const double stops  = figures.reciprocity_layer_stops[k][l];
            sm::PatchReading r;
            if (Status s = expose(f.speed_log10_h.value + stops / kStopsPerDecade, time_s, 1000.0,
                                  8.0, r, nullptr);
                !s)
                return s;
            out.push_back({ t.name + " net density at the speed point, " + format(time_s)
                                + " s, +" + format(stops, 3) + " stops",
                            crit_net, f.d_min.error, r.layers[l].density - fr.density,
                            std::hypot(r.layers[l].density_se, fr.density_se) });
            say("  render check: " + out.back().line());
        }
    }
    return {};
}

}  // namespace filmgrain::fit
