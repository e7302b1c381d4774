// filmgrain-sensitometry: virtual test strips exposed with the real engine
// and read like a densitometer. Writes CSV for every curve and
// results.json with every derived number, then runs plot.py, which draws
// the PNG plots and writes summary.md. Usage: see --help.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "util/parse_number.h"
#include "analysis.h"
#include "expect/boolean_model.h"
#include "model/development.h"
#include "model/geometry.h"
#include "model/image_formation.h"
#include "filmgrain/render.h"
#include "filmgrain/wedge.h"
#include "granularity.h"
#include "patch.h"
#include "reciprocity.h"
#include "strip.h"

#ifndef FILMGRAIN_SENSITOMETRY_SOURCE_DIR
#define FILMGRAIN_SENSITOMETRY_SOURCE_DIR "."
#endif

namespace fs = filmgrain::sensitometry;
using filmgrain::Status;
using filmgrain::Stock;
using json = nlohmann::json;

namespace {

const std::vector<std::string> kSections = { "curves",      "reciprocity", "grain_size",
                                             "development", "granularity", "wedge" };

struct Options {
    std::string out_dir;
    std::string engine = "exact";
    int nthreads       = 0;
    uint64_t seed      = 1;
    std::set<std::string> sections { kSections.begin(), kSections.end() };
    bool plot               = true;
    std::string python      = "/usr/bin/python3";
    std::string source_dir  = FILMGRAIN_SENSITOMETRY_SOURCE_DIR;
};

void usage(std::ostream& os)
{
    os << "usage: filmgrain-sensitometry --out DIR [options]\n"
          "Exposes virtual test strips with the real engine and measures them.\n"
          "  --out DIR         output directory (CSV, PNG, results.json, summary.md)\n"
          "  --engine NAME     render engine (default exact)\n"
          "  --threads N       worker threads per render (default 0: all)\n"
          "  --seed N          seed of every grain pattern (default 1)\n"
          "  --only A,B        sections to run (default all): curves, reciprocity,\n"
          "                    grain_size, development, granularity, wedge\n"
          "  --no-plot         do not run plot.py\n"
          "  --python PATH     interpreter for plot.py (default /usr/bin/python3)\n"
          "  --source DIR      directory holding plot.py and stocks/ (default: the\n"
          "                    source tree this tool was built from)\n";
}

/// One CSV file, written row by row.
class Csv {
public:
    Csv(const std::string& path, const std::vector<std::string>& header) : m_out(path)
    {
        m_out.precision(8);
        for (size_t i = 0; i < header.size(); ++i)
            m_out << (i ? "," : "") << header[i];
        m_out << "\n";
    }
    template<typename... T> void row(const T&... v)
    {
        bool first = true;
        ((m_out << (first ? "" : ",") << v, first = false), ...);
        m_out << "\n";
    }
    bool ok() const { return static_cast<bool>(m_out); }

private:
    std::ofstream m_out;
};

json metrics_json(const fs::CurveMetrics& m)
{
    return { { "base_fog_density", m.base_fog_density },
             { "d_max", m.d_max },
             { "speed_log10_h", m.speed_log10_h },
             { "iso_speed", m.iso_speed },
             { "gamma", m.gamma },
             { "gamma_se", m.gamma_se },
             { "gamma_log10_h_centre", m.gamma_log10_h_centre },
             { "iso_delta_density", m.iso_delta_density },
             { "iso_mean_gradient", m.iso_mean_gradient },
             { "toe_slope", m.toe_slope },
             { "shoulder_slope", m.shoulder_slope },
             { "straight_log10_h", { m.straight_log10_h_lo, m.straight_log10_h_hi } },
             { "latitude_log10_h", { m.latitude_log10_h_lo, m.latitude_log10_h_hi } },
             { "latitude_stops", m.latitude_stops } };
}

class Tool {
public:
    explicit Tool(const Options& o) : m_opt(o)
    {
        filmgrain::parse_name(o.engine, m_settings.engine);
        m_settings.nthreads = o.nthreads;
    }

    int run()
    {
        const auto start = std::chrono::steady_clock::now();
        // --only refreshes some sections: keep the others' results.
        if (m_opt.sections.size() < kSections.size()) {
            std::ifstream old(path("results.json"));
            if (old)
                m_results = json::parse(old, nullptr, false);
            if (m_results.is_discarded() || !m_results.is_object())
                m_results = json::object();
        }
        m_results["engine"] = filmgrain::name_of(m_settings.engine);
        m_results["seed"]   = m_opt.seed;
        for (const std::string& name : kSections) {
            if (!m_opt.sections.count(name))
                continue;
            const auto t0 = std::chrono::steady_clock::now();
            std::cerr << "filmgrain-sensitometry: " << name << " ..." << std::endl;
            m_results.erase(name);
            Status s = name == "curves"        ? curves()
                       : name == "reciprocity" ? reciprocity()
                       : name == "grain_size"  ? grain_size()
                       : name == "development" ? development()
                       : name == "granularity" ? granularity()
                                               : wedge();
            if (!s) {
                std::cerr << "filmgrain-sensitometry: " << name << ": " << s.message() << "\n";
                return 1;
            }
            const double sec = seconds_since(t0);
            m_results["timing_s"][name] = sec;
            std::cerr << "filmgrain-sensitometry: " << name << " done in " << sec << " s\n";
        }
        double total = 0.0;
        for (const std::string& name : kSections)
            if (m_results["timing_s"].contains(name))
                total += m_results["timing_s"][name].get<double>();
        m_results["timing_s"]["measurements"] = total;
        {
            std::ofstream out(path("results.json"));
            out << m_results.dump(2) << "\n";
            if (!out) {
                std::cerr << "filmgrain-sensitometry: cannot write " << path("results.json") << "\n";
                return 1;
            }
        }
        if (m_opt.plot) {
            const std::string cmd = m_opt.python + " '" + m_opt.source_dir + "/plot.py' '"
                                    + m_opt.out_dir + "'";
            std::cerr << "filmgrain-sensitometry: " << cmd << std::endl;
            if (std::system(cmd.c_str()) != 0) {
                std::cerr << "filmgrain-sensitometry: plot.py failed\n";
                return 1;
            }
        }
        std::cerr << "filmgrain-sensitometry: all done in " << seconds_since(start) << " s\n";
        return 0;
    }

private:
    static double seconds_since(std::chrono::steady_clock::time_point t0)
    {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    std::string path(const std::string& file) const { return m_opt.out_dir + "/" + file; }

    Status load(const std::string& name, Stock& stock) const
    {
        if (name == "dense")
            return filmgrain::load_stock(m_opt.source_dir + "/stocks/dense.json", stock);
        return filmgrain::load_stock(name, stock);
    }

    /// A stock's characteristic curve at 1e-2 s (measured once, shared by
    /// the sections that need it).
    Status curve_of(const std::string& name, fs::Curve*& out)
    {
        auto it = m_curves.find(name);
        if (it == m_curves.end()) {
            Stock stock;
            if (Status s = load(name, stock); !s)
                return s;
            fs::StripSpec spec;
            // Six decades: from the flat fog to the top of the shoulder (the
            // last half decade costs as much as all the rest: photons).
            spec.log10_h_min  = -6.5;
            spec.log10_h_max  = -0.5;
            spec.budget.min_area_um2 = 6.0e4;
            spec.log10_h_step = 0.1;
            spec.shutter_s    = 1e-2;
            spec.seed         = m_opt.seed;
            fs::Curve c;
            if (Status s = fs::expose_strip(stock, spec, m_settings, c); !s)
                return s;
            it = m_curves.emplace(name, std::move(c)).first;
        }
        out = &it->second;
        return {};
    }

    // 1. Characteristic curves.
    Status curves()
    {
        for (const std::string name : { "paper", "color-negative" }) {
            fs::Curve* c;
            if (Status s = curve_of(name, c); !s)
                return s;
            Csv csv(path("curve_" + name + ".csv"),
                    { "engine", "stock", "layer", "shutter_s", "log10_h_lxs", "density",
                      "density_se", "fog_density", "area_um2" });
            json& j = m_results["curves"][name];
            j["shutter_s"]      = c->shutter_s;
            j["seconds"]        = c->seconds;
            j["clamped_pixels"] = c->clamped_pixels;
            j["clamp_density_bound"] = c->clamp_density_bound;
            j["patches"]        = c->area_um2.size() + 1;
            for (const fs::LayerCurve& l : c->layers) {
                for (size_t i = 0; i < l.log10_h.size(); ++i)
                    csv.row(c->engine, name, l.name, c->shutter_s, l.log10_h[i], l.density[i],
                            l.density_se[i], l.fog_density, c->area_um2[i]);
                const fs::CurveMetrics m = fs::analyse_curve(l);
                j["layers"][l.name] = metrics_json(m);
                j["layers"][l.name]["fog_density_se"] = l.fog_density_se;
            }
            if (!csv.ok())
                return Status::errorf("cannot write curve_", name, ".csv");
        }
        return {};
    }

    // 2. Reciprocity.
    Status reciprocity()
    {
        const double target = 1.0;
        for (const std::string name : { "paper", "color-negative" }) {
            Stock stock;
            if (Status s = load(name, stock); !s)
                return s;
            fs::Curve* c;
            if (Status s = curve_of(name, c); !s)
                return s;
            std::vector<double> fog;
            double guess = 0.0;
            for (const fs::LayerCurve& l : c->layers) {
                fog.push_back(l.fog_density);
                guess += fs::first_crossing(l.log10_h, l.density, l.fog_density + target)
                         / c->layers.size();
            }
            guess = 0.1 * std::round(guess * 10.0);
            fs::PatchBudget budget;
            // log10 H to ~0.005 (0.02 stop): far finer than the effects.
            budget.max_area_um2 = 1.0e6;
            budget.max_cost_s   = 0.2;
            std::vector<double> shutters;
            for (int e = -6; e <= 3; ++e)
                shutters.push_back(std::pow(10.0, e));
            // Start at 1e-2 s and walk outwards, each guess from its neighbour.
            std::map<double, fs::ReciprocityPoint> found;
            const size_t ref = 4;
            std::vector<size_t> order { ref };
            for (size_t i = ref + 1; i < shutters.size(); ++i)
                order.push_back(i);
            for (size_t i = ref; i-- > 0;)
                order.push_back(i);
            double seconds = 0.0;
            for (size_t k = 0; k < order.size(); ++k) {
                const size_t i = order[k];
                double g = guess;
                if (i > ref && found.count(shutters[i - 1]))
                    g = 0.1 * std::round(found[shutters[i - 1]].log10_h * 10.0);
                if (i < ref && found.count(shutters[i + 1]))
                    g = 0.1 * std::round(found[shutters[i + 1]].log10_h * 10.0);
                fs::ReciprocityPoint p;
                if (Status s = fs::exposure_for_net_density(stock, shutters[i], target, fog, g,
                                                            budget, m_settings,
                                                            fs::patch_seed(m_opt.seed, 1000 + i), p);
                    !s)
                    return s;
                seconds += p.seconds;
                found[shutters[i]] = p;
            }
            const double h_ref = found[1e-2].log10_h;
            Csv csv(path("reciprocity_" + name + ".csv"),
                    { "engine", "stock", "net_density", "shutter_s", "log10_h_lxs", "log10_h_se",
                      "stops_vs_10ms", "patches" });
            std::vector<fs::ReciprocityPoint> pts;
            json& j = m_results["reciprocity"][name];
            for (const auto& [t, p] : found) {
                const double stops = (p.log10_h - h_ref) / std::log10(2.0);
                csv.row(filmgrain::name_of(m_settings.engine), name, target, t, p.log10_h,
                        p.log10_h_se, stops, p.patches);
                j["points"].push_back({ { "shutter_s", t }, { "log10_h", p.log10_h },
                                        { "log10_h_se", p.log10_h_se }, { "stops_vs_10ms", stops } });
                pts.push_back(p);
            }
            const fs::SchwarzschildFit f = fs::fit_schwarzschild(pts, 10.0);
            size_t best = 0;
            for (size_t i = 0; i < pts.size(); ++i)
                if (pts[i].log10_h < pts[best].log10_h)
                    best = i;
            j["net_density"]            = target;
            j["schwarzschild_p"]        = f.p;
            j["schwarzschild_p_se"]     = f.p_se;
            j["schwarzschild_from_s"]   = 10.0;
            j["schwarzschild_intercept"] = f.intercept;
            j["optimum_shutter_s"]      = pts[best].shutter_s;
            j["seconds"]                = seconds;
        }
        return {};
    }

    /// A sweep (3, 4): for each value of `values`, the paper stock with
    /// `set(stock, value)` applied, exposed from 10^log10_h_min to
    /// 10^log10_h_max lx s in 0.1 steps within the sweeps' budget, seeded
    /// by stream_base + value * stream_scale; its first layer's points are
    /// written to `curves` after the value, then `point(stock, value,
    /// curve, metrics)` is called.
    using SweepPoint = std::function<void(const Stock&, double, const fs::Curve&,
                                          const fs::CurveMetrics&)>;
    Status paper_sweep(const std::vector<double>& values,
                       const std::function<void(Stock&, double)>& set, double log10_h_min,
                       double log10_h_max, uint64_t stream_base, double stream_scale,
                       Csv& curves, const SweepPoint& point)
    {
        Stock base;
        if (Status s = load("paper", base); !s)
            return s;
        for (double v : values) {
            Stock stock = base;
            set(stock, v);
            fs::StripSpec spec;
            spec.log10_h_min         = log10_h_min;
            spec.log10_h_max         = log10_h_max;
            spec.log10_h_step        = 0.1;
            spec.budget.max_area_um2 = 1.0e6;
            spec.budget.max_cost_s   = 0.25;
            spec.seed = fs::patch_seed(m_opt.seed,
                                       stream_base + static_cast<uint64_t>(v * stream_scale));
            fs::Curve c;
            if (Status s = fs::expose_strip(stock, spec, m_settings, c); !s)
                return s;
            const fs::LayerCurve& l = c.layers[0];
            for (size_t i = 0; i < l.log10_h.size(); ++i)
                curves.row(c.engine, v, l.log10_h[i], l.density[i], l.density_se[i]);
            point(stock, v, c, fs::analyse_curve(l));
        }
        return {};
    }

    // 3. Grain size and speed.
    Status grain_size()
    {
        Csv curves(path("grain_size_curves.csv"),
                   { "engine", "diameter_um", "log10_h_lxs", "density", "density_se" });
        Csv table(path("grain_size.csv"),
                  { "engine", "diameter_um", "fog_density", "speed_log10_h", "iso_speed",
                    "gamma", "d_max" });
        return paper_sweep(
            { 4.0, 6.0, 9.0 },
            [](Stock& stock, double d) { stock.layers[0].populations[0].diameter_um = d; }, -4.5,
            -0.5, 2000, 10.0, curves,
            [&](const Stock&, double d, const fs::Curve& c, const fs::CurveMetrics& m) {
                table.row(c.engine, d, m.base_fog_density, m.speed_log10_h, m.iso_speed, m.gamma,
                          m.d_max);
                json j = metrics_json(m);
                j["diameter_um"] = d;
                m_results["grain_size"].push_back(j);
            });
    }

    // 4. Development time.
    Status development()
    {
        Csv curves(path("development_curves.csv"),
                   { "engine", "development_time_s", "log10_h_lxs", "density", "density_se" });
        Csv table(path("development.csv"),
                  { "engine", "development_time_s", "gamma", "gamma_se", "fog_density",
                    "fog_density_se", "model_fog_density", "speed_log10_h", "d_max" });
        std::vector<double> times, gammas, ses;
        const Status swept = paper_sweep(
            { 60.0, 120.0, 240.0, 480.0, 960.0 },
            [](Stock& stock, double t) { stock.development_time_s = t; }, -3.8, -0.8, 3000, 1.0,
            curves,
            [&](const Stock& stock, double t, const fs::Curve& c, const fs::CurveMetrics& m) {
                const fs::LayerCurve& l = c.layers[0];
                // MODEL.md 4: unexposed grains develop with f = 1 - exp(-t /
                // fog_tau), so the fog density is 0.434 n E[a] f (Boolean
                // model: -log10 of exp(-n E[a] f)) plus the base.
                const auto& pop = stock.layers[0].populations[0];
                const double model_fog
                    = filmgrain::kLog10E * pop.grains_per_um2 * filmgrain::mean_disc_area_um2(pop)
                          * filmgrain::Development(stock).fog_probability()
                      + stock.layer_base_density(0);
                table.row(c.engine, t, m.gamma, m.gamma_se, l.fog_density, l.fog_density_se,
                          model_fog, m.speed_log10_h, m.d_max);
                json j = metrics_json(m);
                j["development_time_s"] = t;
                j["model_fog_density"]  = model_fog;
                j["fog_density_se"]     = l.fog_density_se;
                m_results["development"]["times"].push_back(j);
                times.push_back(t);
                gammas.push_back(m.gamma);
                ses.push_back(std::max(m.gamma_se, 1e-3));
            });
        if (!swept)
            return swept;
        const fs::GammaTimeFit fit = fs::fit_gamma_vs_time(times, gammas, ses);
        m_results["development"]["fit"] = { { "gamma_inf", fit.gamma_inf },
                                             { "k_per_s", fit.k_per_s },
                                             { "rms_residual", fit.rms_residual } };
        return {};
    }

    /// Renders a granularity patch at the exposure the model predicts for
    /// `net_density` and reads it through `apertures`.
    struct GranularityCase {
        double target_net = 0.0, log10_h = 0.0;
        fs::PatchReading patch;
        std::vector<std::vector<double>> transmittance;
        filmgrain::BooleanLayer model;
    };
    Status granularity_patch(const Stock& stock, size_t layer, double target_net,
                             double side_um, double pitch_um, uint64_t seed,
                             GranularityCase& out)
    {
        out.target_net = target_net;
        const auto t0 = std::chrono::steady_clock::now();
        if (Status s = filmgrain::exposure_for_predicted_density(stock, layer, target_net, 1e-2,
                                                          std::log10(stock.exposure_at_grey_lxs),
                                                          out.log10_h);
            !s)
            return s;
        fs::PatchSpec p;
        p.exposure_lxs = std::pow(10.0, out.log10_h);
        p.shutter_s    = 1e-2;
        p.side_um      = side_um;
        p.pitch_um     = pitch_um;
        p.seed         = seed;
        const double t_solve = seconds_since(t0);
        if (Status s = fs::expose_patch(stock, p, m_settings, out.patch, &out.transmittance); !s)
            return s;
        const auto t1 = std::chrono::steady_clock::now();
        Status s = filmgrain::predict_layer(stock, layer, p.exposure_lxs, 1e-2, 3000, seed ^ 0xb001, out.model);
        std::cerr << "  " << stock.name << " net " << target_net << ": exposure " << t_solve
                  << " s, render " << out.patch.seconds << " s, prediction " << seconds_since(t1)
                  << " s\n";
        return s;
    }

    /// Measured and predicted sigma_D of one aperture on one case.
    json granularity_row(const Stock& stock, const GranularityCase& c, size_t layer,
                         double aperture_um, Csv* csv, const std::string& label)
    {
        const filmgrain::ApertureTemplate a = filmgrain::make_circular_aperture(aperture_um, c.patch.pitch_um);
        const int spacing = std::max(1, static_cast<int>(std::lround(aperture_um / 4.0 / c.patch.pitch_um)));
        const fs::GranularityReading g = fs::read_granularity(
            c.transmittance[layer], c.patch.side_px, a, spacing, stock.layer_base_density(layer));
        const double t          = c.model.mean_transmittance();
        const double boolean    = std::sqrt(filmgrain::aperture_transmittance_variance(c.model, a)) / t
                               / std::log(10.0);
        const double siedentopf = filmgrain::siedentopf_sigma_density(
            c.model.mean_developed_area_um2(), g.mean_density - stock.layer_base_density(layer),
            a.area_um2());
        const fs::LayerReading& r = c.patch.layers[layer];
        json j = { { "label", label },
                   { "layer", r.name },
                   { "aperture_um", aperture_um },
                   { "aperture_area_um2", g.aperture_area_um2 },
                   { "log10_h", c.log10_h },
                   { "macro_density", r.density },
                   { "macro_density_se", r.density_se },
                   { "nutting_density", c.model.net_density() + stock.layer_base_density(layer) },
                   { "mean_aperture_density", g.mean_density },
                   { "sigma_d", g.sigma_density },
                   { "sigma_d_se", g.sigma_density_se },
                   { "sigma_d_delta", g.relative_sigma_transmittance / std::log(10.0) },
                   { "sigma_d_delta_se", g.relative_sigma_transmittance_se / std::log(10.0) },
                   { "boolean_sigma_d", boolean },
                   { "siedentopf_sigma_d", siedentopf },
                   { "selwyn_g_um", g.selwyn_um() },
                   { "boolean_selwyn_g_um", boolean * std::sqrt(2.0 * g.aperture_area_um2) },
                   { "positions", g.positions },
                   { "patch_area_um2", std::pow(c.patch.side_px * c.patch.pitch_um, 2) },
                   { "pitch_um", c.patch.pitch_um } };
        if (csv)
            csv->row(filmgrain::name_of(m_settings.engine), label, r.name, aperture_um,
                     g.aperture_area_um2, c.log10_h, r.density, r.density_se,
                     c.model.net_density() + stock.layer_base_density(layer), g.mean_density,
                     g.sigma_density, g.sigma_density_se, j["sigma_d_delta"].get<double>(),
                     j["sigma_d_delta_se"].get<double>(), boolean, siedentopf, g.selwyn_um(),
                     j["boolean_selwyn_g_um"].get<double>());
        return j;
    }

    // 5. Granularity.
    Status granularity()
    {
        const std::vector<std::string> header
            = { "engine", "stock", "layer", "aperture_um", "aperture_area_um2", "log10_h_lxs",
                "macro_density", "macro_density_se", "nutting_density", "mean_aperture_density",
                "sigma_d", "sigma_d_se", "sigma_d_delta", "sigma_d_delta_se", "boolean_sigma_d",
                "siedentopf_sigma_d", "selwyn_g_um", "boolean_selwyn_g_um" };
        // Densities are read through the transmittance, so the scan's clamp
        // (a representation limit of the output, 10^-max_density) must not
        // touch the small pixels used here: the measurement copies of the
        // stocks use max_density 20 (nothing else changes).
        Stock paper, dense, neg;
        if (Status s = load("paper", paper); !s)
            return s;
        if (Status s = load("dense", dense); !s)
            return s;
        if (Status s = load("color-negative", neg); !s)
            return s;
        paper.max_density = dense.max_density = neg.max_density = 20.0;

        // sigma_D vs density through the 48 um aperture.
        Csv vs_d(path("granularity_vs_density.csv"), header);
        struct Series {
            const Stock& stock;
            const char* label;
            double side_um, pitch_um;
            std::vector<double> nets;
        };
        const Series series[] = {
            { paper, "paper", 1600.0, 4.0, { 0.1, 0.2, 0.35, 0.5, 0.7, 0.9, 1.1, 1.2 } },
            { dense, "dense", 1200.0, 3.0, { 0.1, 0.3, 0.6, 1.0, 1.5, 2.0, 2.5, 3.0 } },
        };
        uint64_t k = 0;
        for (const Series& sr : series)
            for (double net : sr.nets) {
                GranularityCase c;
                if (Status s = granularity_patch(sr.stock, 0, net, sr.side_um, sr.pitch_um,
                                                 fs::patch_seed(m_opt.seed, 4000 + k++), c);
                    !s)
                    return s;
                m_results["granularity"]["vs_density"].push_back(
                    granularity_row(sr.stock, c, 0, 48.0, &vs_d, sr.label));
            }
        // Selwyn: one large patch of the paper stock at gross density 1.0
        // (base 0: gross = net), read through apertures of 4 to 32 mean
        // grain diameters. Its 48 um reading is the datasheet number.
        Csv vs_a(path("granularity_vs_aperture.csv"), header);
        {
            GranularityCase c;
            if (Status s = granularity_patch(paper, 0, 1.0 - paper.layer_base_density(0), 4000.0, 4.0,
                                             fs::patch_seed(m_opt.seed, 4100), c);
                !s)
                return s;
            for (double ap : { 24.0, 48.0, 96.0, 144.0, 192.0 }) {
                json j = granularity_row(paper, c, 0, ap, &vs_a, "paper");
                if (ap == 48.0)
                    m_results["granularity"]["datasheet"]["paper"] = j;
                m_results["granularity"]["vs_aperture"].push_back(j);
            }
        }
        // The colour negative at a net density of 1.0 above base + fog
        // (colour datasheets quote net density; fog from the model: the
        // net density at zero exposure). Its three layers have the same
        // populations and sensitivities summing to 1: one patch, exposed
        // for the green layer, serves all three.
        {
            filmgrain::BooleanLayer fog_model;
            if (Status s = filmgrain::predict_layer(neg, 1, 0.0, 1e-2, 100, 5, fog_model); !s)
                return s;
            GranularityCase c;
            if (Status s = granularity_patch(neg, 1, 1.0 + fog_model.net_density(), 1000.0, 3.0,
                                             fs::patch_seed(m_opt.seed, 4200), c);
                !s)
                return s;
            for (size_t l = 0; l < neg.layers.size(); ++l) {
                json j = granularity_row(neg, c, l, 48.0, &vs_d, "color-negative");
                j["fog_density"] = fog_model.net_density() + neg.layer_base_density(l);
                m_results["granularity"]["datasheet"]["color-negative"][neg.layers[l].name] = j;
            }
        }
        return {};
    }

    // 6. The step wedge (the paper's Figure 1).
    Status wedge()
    {
        Stock stock;
        if (Status s = load("paper", stock); !s)
            return s;
        const filmgrain::WedgeSpec spec;
        const std::vector<float> input = filmgrain::make_step_wedge(spec);
        filmgrain::SceneSettings scene;
        scene.width_mm = spec.strip_width_mm;
        scene.seed           = m_opt.seed;
        scene.shutter_s      = 1e-2;
        filmgrain::RenderSettings rs;
        rs.engine   = m_settings.engine;
        rs.nthreads = m_settings.nthreads;
        const filmgrain::ImageView view { input.data(), spec.width_px(), spec.height_px, 1 };
        std::vector<float> density(static_cast<size_t>(spec.width_px() * spec.height_px));
        filmgrain::RenderStats stats;
        if (Status s = filmgrain::render_negative(stock, scene, view, rs, density.data(), &stats); !s)
            return s;
        {
            std::ofstream raw(path("wedge_paper.f32"), std::ios::binary);
            raw.write(reinterpret_cast<const char*>(density.data()),
                      static_cast<std::streamsize>(density.size() * sizeof(float)));
        }
        // Step densities from the mean transmittance of each step's interior
        // (8 px = 50 um from its edges: no grain straddles the exposure step).
        Csv csv(path("wedge_steps.csv"), { "engine", "step", "stops", "log10_h_lxs", "density" });
        const double pitch_um = spec.strip_width_mm * 1000.0 / spec.width_px();
        json steps = json::array();
        for (int i = 0; i < spec.steps; ++i) {
            double sum = 0.0, n = 0.0;
            for (int64_t y = 8; y < spec.height_px - 8; ++y)
                for (int64_t x = i * spec.step_width_px + 8; x < (i + 1) * spec.step_width_px - 8; ++x) {
                    sum += std::pow(10.0, -(density[static_cast<size_t>(y * spec.width_px() + x)]
                                           - stock.layer_base_density(0)));
                    n += 1.0;
                }
            const double d = fs::density_from_mean_transmittance(sum / n, stock.layer_base_density(0));
            const double h = stock.exposure_at_grey_lxs * std::exp2(spec.step_stops(i));
            csv.row(stats.engine, i, spec.step_stops(i), std::log10(h), d);
            steps.push_back(d);
        }
        m_results["wedge"] = { { "stock", "paper" },
                               { "width_px", spec.width_px() },
                               { "height_px", spec.height_px },
                               { "pitch_um", pitch_um },
                               { "steps", spec.steps },
                               { "first_stop", spec.first_stop },
                               { "stops_per_step", spec.stops_per_step },
                               { "step_width_px", spec.step_width_px },
                               { "exposure_at_grey_lxs", stock.exposure_at_grey_lxs },
                               { "step_density", steps },
                               { "engine", stats.engine },
                               { "simulate_seconds", stats.simulate_seconds } };
        return {};
    }

    Options m_opt;
    fs::MeasureSettings m_settings;
    json m_results;
    std::map<std::string, fs::Curve> m_curves;
};

}  // namespace

int main(int argc, char** argv)
{
    Options o;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const auto value = [&]() -> std::string {
            if (i + 1 >= argc) {
                std::cerr << "filmgrain-sensitometry: " << a << " needs a value\n";
                std::exit(2);
            }
            return argv[++i];
        };
        // A whole number in [lo, hi], or exit 2 naming the option.
        const auto integer = [&](uint64_t lo, uint64_t hi) {
            const std::string v = value();
            uint64_t x          = 0;
            std::string why;
            if (!filmgrain::parse_count(v, hi, x, why) || x < lo) {
                std::cerr << "filmgrain-sensitometry: " << a << " " << v
                          << ": must be a whole number in [" << lo << ", " << hi << "]\n";
                std::exit(2);
            }
            return x;
        };
        if (a == "--help" || a == "-h") {
            usage(std::cout);
            return 0;
        } else if (a == "--out") {
            o.out_dir = value();
        } else if (a == "--engine") {
            o.engine = value();
            filmgrain::Engine e;
            if (!filmgrain::parse_name(o.engine, e)) {
                std::cerr << "filmgrain-sensitometry: unknown engine '" << o.engine << "'\n";
                return 2;
            }
        } else if (a == "--threads") {
            o.nthreads = static_cast<int>(integer(0, 1024));
        } else if (a == "--seed") {
            o.seed = integer(0, std::numeric_limits<uint64_t>::max());
        } else if (a == "--only") {
            o.sections.clear();
            std::stringstream ss(value());
            for (std::string s; std::getline(ss, s, ',');) {
                if (std::find(kSections.begin(), kSections.end(), s) == kSections.end()) {
                    std::cerr << "filmgrain-sensitometry: unknown section '" << s << "'\n";
                    return 2;
                }
                o.sections.insert(s);
            }
        } else if (a == "--no-plot") {
            o.plot = false;
        } else if (a == "--python") {
            o.python = value();
        } else if (a == "--source") {
            o.source_dir = value();
        } else {
            std::cerr << "filmgrain-sensitometry: unknown option '" << a << "'\n";
            usage(std::cerr);
            return 2;
        }
    }
    if (o.out_dir.empty()) {
        usage(std::cerr);
        return 2;
    }
    std::error_code ec;
    std::filesystem::create_directories(o.out_dir, ec);
    if (ec) {
        std::cerr << "filmgrain-sensitometry: cannot create " << o.out_dir << ": " << ec.message()
                  << "\n";
        return 1;
    }
    return Tool(o).run();
}
