// Datasheet figures: the targets of a datasheet file and their analytic
// measurement on a stock (datasheet.h).
#include "datasheet.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "analysis.h"
#include "expect/boolean_model.h"
#include "expect/expected_curve_model.h"
#include "model/inhibition.h"
#include "model/image_formation.h"
#include "model/exposure.h"

namespace filmgrain::sensitometry {

namespace {

using Json = nlohmann::json;

/// Every key of `j` must be in `allowed`.
Status check_keys(const Json& j, const std::set<std::string>& allowed, const std::string& path)
{
    if (!j.is_object())
        return Status::errorf(path.empty() ? "the datasheet" : path, " must be a JSON object");
    for (auto it = j.begin(); it != j.end(); ++it)
        if (!allowed.count(it.key())) {
            std::string list;
            for (const auto& k : allowed)
                list += (list.empty() ? "" : ", ") + k;
            return Status::errorf("unknown key '", path, it.key(), "'; allowed here: ", list);
        }
    return {};
}

Status number(const Json& j, const std::string& path, double& out)
{
    if (!j.is_number())
        return Status::errorf(path, " must be a number, not ", j.dump());
    out = j.get<double>();
    if (!std::isfinite(out))
        return Status::errorf(path, " = ", out, ": must be finite");
    return {};
}

/// A time key of the reciprocity table ("0.0001", "1", ...), seconds.
Status time_key(const std::string& key, const std::string& path, double& out)
{
    char* end = nullptr;
    out       = std::strtod(key.c_str(), &end);
    if (end == key.c_str() || *end != '\0' || !(out > 0.0) || !std::isfinite(out))
        return Status::errorf(path, "'", key, "' is not a positive time in seconds");
    return {};
}

Status parse(const Json& j, Datasheet& d)
{
    if (Status s = check_keys(j, { "name", "kind", "sources", "speed", "layers", "reciprocity",
                                   "printing_density" },
                              "");
        !s)
        return s;
    if (!j.contains("name") || !j["name"].is_string())
        return Status::errorf("name must be a string");
    if (!j.contains("kind") || !j["kind"].is_string())
        return Status::errorf("kind must be a string (bw-negative or colour-negative)");
    d.name = j["name"].get<std::string>();
    d.kind = j["kind"].get<std::string>();
    if (d.kind != "bw-negative" && d.kind != "colour-negative")
        return Status::errorf("kind = '", d.kind, "': must be bw-negative or colour-negative");
    if (j.contains("speed")) {
        const Json& sp = j["speed"];
        if (Status s = check_keys(sp, { "value", "standard", "illuminant" }, "speed."); !s)
            return s;
        double v = 0.0;
        if (Status s = number(sp.value("value", Json()), "speed.value", v); !s)
            return s;
        if (!(v > 0.0))
            return Status::errorf("speed.value = ", v, ": must be > 0");
        d.speed          = v;
        d.speed_standard = sp.value("standard", d.kind == "bw-negative" ? "ISO 6" : "ISO 5800");
        if (d.speed_standard != "ISO 6" && d.speed_standard != "ISO 5800")
            return Status::errorf("speed.standard = '", d.speed_standard,
                                  "': must be ISO 6 or ISO 5800");
    }
    if (j.contains("layers")) {
        if (!j["layers"].is_array())
            return Status::errorf("layers must be an array");
        for (size_t i = 0; i < j["layers"].size(); ++i) {
            const Json& l    = j["layers"][i];
            const std::string p = "layers[" + std::to_string(i) + "].";
            if (Status s = check_keys(l, { "name", "d_min", "slope", "rms_granularity", "curve" },
                                      p);
                !s)
                return s;
            LayerTargets t;
            if (!l.contains("name") || !l["name"].is_string())
                return Status::errorf(p, "name must be a string");
            t.name = l["name"].get<std::string>();
            if (l.contains("d_min")) {
                double v = 0.0;
                if (Status s = number(l["d_min"], p + "d_min", v); !s)
                    return s;
                t.d_min = v;
            }
            if (l.contains("slope")) {
                const Json& sl = l["slope"];
                if (Status s = check_keys(sl, { "value", "log_h_range" }, p + "slope."); !s)
                    return s;
                double v = 0.0;
                if (Status s = number(sl.value("value", Json()), p + "slope.value", v); !s)
                    return s;
                const Json r = sl.value("log_h_range", Json());
                if (!r.is_array() || r.size() != 2)
                    return Status::errorf(p, "slope.log_h_range must be [a, b]");
                if (Status s = number(r[0], p + "slope.log_h_range[0]", t.slope_log10_h_lo); !s)
                    return s;
                if (Status s = number(r[1], p + "slope.log_h_range[1]", t.slope_log10_h_hi); !s)
                    return s;
                if (!(t.slope_log10_h_hi > t.slope_log10_h_lo))
                    return Status::errorf(p, "slope.log_h_range must increase");
                t.slope = v;
            }
            if (l.contains("rms_granularity")) {
                const Json& g = l["rms_granularity"];
                if (Status s = check_keys(g, { "net_density", "gross_density" },
                                          p + "rms_granularity.");
                    !s)
                    return s;
                for (const char* kind : { "net_density", "gross_density" }) {
                    if (!g.contains(kind))
                        continue;
                    const std::string gp = p + "rms_granularity." + kind + ".";
                    if (!g[kind].is_object())
                        return Status::errorf(gp, " must be an object {density: rms}");
                    for (auto it = g[kind].begin(); it != g[kind].end(); ++it) {
                        GranularityTarget gt;
                        gt.net = std::string(kind) == "net_density";
                        if (Status s = time_key(it.key(), gp, gt.density); !s)
                            return Status::errorf(gp, "'", it.key(), "' is not a density");
                        if (Status s = number(*it, gp + it.key(), gt.rms); !s)
                            return s;
                        if (!(gt.rms > 0.0))
                            return Status::errorf(gp, it.key(), " = ", gt.rms, ": must be > 0");
                        t.granularity.push_back(gt);
                    }
                }
                std::sort(t.granularity.begin(), t.granularity.end(),
                          [](const GranularityTarget& a, const GranularityTarget& b) {
                              return std::make_pair(!a.net, a.density)
                                     < std::make_pair(!b.net, b.density);
                          });
            }
            if (l.contains("curve")) {
                const Json& c = l["curve"];
                if (Status s = check_keys(c, { "log_h", "density" }, p + "curve."); !s)
                    return s;
                const Json h = c.value("log_h", Json()), dens = c.value("density", Json());
                if (!h.is_array() || !dens.is_array() || h.size() != dens.size() || h.size() < 2)
                    return Status::errorf(p, "curve must have arrays log_h and density of one "
                                             "length, at least 2");
                for (size_t k = 0; k < h.size(); ++k) {
                    std::pair<double, double> pt;
                    const std::string at = "[" + std::to_string(k) + "]";
                    if (Status s = number(h[k], p + "curve.log_h" + at, pt.first); !s)
                        return s;
                    if (Status s = number(dens[k], p + "curve.density" + at, pt.second); !s)
                        return s;
                    if (!t.curve.empty() && !(pt.first > t.curve.back().first))
                        return Status::errorf(p, "curve.log_h must increase (", pt.first,
                                              " after ", t.curve.back().first, ")");
                    t.curve.push_back(pt);
                }
            }
            d.layers.push_back(std::move(t));
        }
    }
    if (j.contains("reciprocity")) {
        const Json& r = j["reciprocity"];
        if (Status s = check_keys(r, { "reference_s", "none_between", "extra_stops" },
                                  "reciprocity.");
            !s)
            return s;
        d.has_reciprocity = true;
        if (r.contains("reference_s")) {
            if (Status s = number(r["reference_s"], "reciprocity.reference_s",
                                  d.reciprocity_reference_s);
                !s)
                return s;
            if (!(d.reciprocity_reference_s > 0.0))
                return Status::errorf("reciprocity.reference_s must be > 0");
        }
        if (r.contains("none_between")) {
            const Json& nb = r["none_between"];
            if (!nb.is_array() || nb.size() != 2)
                return Status::errorf("reciprocity.none_between must be [t1, t2]");
            std::pair<double, double> p;
            if (Status s = number(nb[0], "reciprocity.none_between[0]", p.first); !s)
                return s;
            if (Status s = number(nb[1], "reciprocity.none_between[1]", p.second); !s)
                return s;
            if (!(p.first > 0.0 && p.second > p.first))
                return Status::errorf("reciprocity.none_between must be increasing times > 0");
            d.none_between = p;
        }
        if (r.contains("extra_stops")) {
            if (!r["extra_stops"].is_object())
                return Status::errorf("reciprocity.extra_stops must be an object {time: stops}");
            for (auto it = r["extra_stops"].begin(); it != r["extra_stops"].end(); ++it) {
                std::pair<double, double> e;
                if (Status s = time_key(it.key(), "reciprocity.extra_stops.", e.first); !s)
                    return s;
                if (Status s = number(*it, "reciprocity.extra_stops." + it.key(), e.second); !s)
                    return s;
                d.extra_stops.push_back(e);
            }
            std::sort(d.extra_stops.begin(), d.extra_stops.end());
        }
    }
    if (j.contains("printing_density")) {
        // The stock files' key, read by the stock parser (one reader, one
        // set of rules): a stock of layers R, G, B that holds only it.
        const Json stock = { { "layers", { { { "name", "R" } }, { { "name", "G" } },
                                           { { "name", "B" } } } },
                             { "printing_density", j["printing_density"] } };
        Stock parsed;
        if (Status s = parse_stock_json(stock.dump(), "", parsed); !s)
            return Status::errorf(s.message().substr(s.message().find(": ") + 2));
        d.printing_density = parsed.status_m_to_apd;
    }
    return {};
}


/// The curve of every stock layer at `shutter_s` on a uniform neutral patch
/// (MODEL.md 10's inhibition included), with its LayerModel and the curves
/// without inhibition kept for granularity.
struct Curves {
    std::vector<std::unique_ptr<LayerModel>> models;
    std::vector<ExpectedCurve> curves;
    std::vector<ExpectedCurve> plain;  ///< without inhibition
};

Curves curves_at(const Stock& stock, double shutter_s, DevelopModels& models)
{
    SceneSettings scene;
    scene.shutter_s = shutter_s;
    Curves c;
    for (size_t l = 0; l < stock.layers.size(); ++l) {
        c.models.push_back(std::make_unique<LayerModel>(stock, l, scene, models));
        c.plain.push_back(expected_curve(stock, l, *c.models.back(), false));
    }
    c.curves = c.plain;
    apply_inhibition(stock, c.curves);
    return c;
}

/// The RMS granularity (1000 sigma_D, kGranularityApertureUm) of stock
/// layer l at gross `density` on `ref`'s curves, with its error bound;
/// false where the curve never reaches the density.
bool rms_granularity_at(const Stock& stock, const Curves& ref, size_t l, double density,
                        bool bound, Figure& out)
{
    const ExpectedCurve& c = ref.curves[l];
    const double v         = c.value_at_density(density);
    if (!(v > 0.0) || v >= c.points.back().value)
        return false;
    // MODEL.md 10: P -> P exp(-log_factor) for every grain.
    const double factor = std::exp(-neutral_log_factor(stock, ref.plain, l, v));
    const ImageOverlap image(stock.layers[l]);
    const auto rms_at = [&](double develop_factor, BooleanLayer& b) {
        b = boolean_layer_at(ref.models[l]->populations(), v, image, develop_factor);
        const double sigma_t
            = std::sqrt(disc_aperture_transmittance_variance(b, kGranularityApertureUm));
        return 1000.0 * kLog10E * sigma_t / b.mean_transmittance();
    };
    BooleanLayer b;
    const double rms = rms_at(factor, b);
    double rel       = 0.0;
    if (bound && !has_coupler_limit(stock.layers[l])) {
        // C(h) = T^2 (exp K(h) - 1) scales with K to first order: the
        // relative error of K bounds the relative error of the variance,
        // half that of sigma. (coverage_error bounds sum n E[a P]; a dye
        // image blocks cloud_area_factor times that.)
        rel = b.coverage() > 0.0 ? 0.5 * ref.models[l]->coverage_error()
                                       * cloud_area_factor(stock.layers[l]) / b.coverage()
                                 : 0.0;
    } else if (bound) {
        // Coupler-limited populations (docs/model.md): their noise does not
        // scale with their cover, so the figure is evaluated again with
        // every P raised by the relative error coverage_error / sum n E[a P]
        // and the change taken as the bound (first order, as above).
        const double cover = b.developed_per_um2() * b.mean_developed_area_um2();
        if (cover > 0.0) {
            BooleanLayer raised;
            const double e = ref.models[l]->coverage_error() / cover;
            rel            = std::fabs(rms_at(factor * (1.0 + e), raised) - rms) / rms;
        }
    }
    out = { rms, rms * rel };
    return true;
}

/// Index of the stock layer named `name`, or -1.
int find_layer(const Stock& stock, const std::string& name)
{
    for (size_t l = 0; l < stock.layers.size(); ++l)
        if (stock.layers[l].name == name)
            return static_cast<int>(l);
    return -1;
}

/// Bound on the error of log10 H read off a curve at v: the curve's density
/// error over its local gamma.
double log10_h_error(const ExpectedCurve& curve, double value)
{
    const double g = curve.gamma_at(value);
    return g > 0.0 ? curve.density_error / g : INFINITY;
}

}  // namespace

std::vector<double> Datasheet::reciprocity_times_s() const
{
    std::set<double> times;
    for (const auto& e : extra_stops)
        times.insert(e.first);
    if (none_between) {
        times.insert(none_between->first);
        times.insert(none_between->second);
        // And every decade inside (the failure need not be monotone).
        for (double t = std::pow(10.0, std::ceil(std::log10(none_between->first)));
             t < none_between->second; t *= 10.0)
            times.insert(t);
    }
    std::vector<double> out;
    for (double t : times)
        if (std::fabs(std::log10(t / reciprocity_reference_s)) > 1e-9)
            out.push_back(t);
    return out;
}

Status parse_datasheet_json(const std::string& text, const std::string& origin, Datasheet& out)
{
    Json j;
    try {
        j = Json::parse(text);
    } catch (const std::exception& e) {
        return Status::errorf(origin, ": not valid JSON: ", e.what());
    }
    Datasheet d;
    if (Status s = parse(j, d); !s)
        return Status::errorf(origin, ": ", s.message());
    out = std::move(d);
    return {};
}

Status load_datasheet(const std::string& path, Datasheet& out)
{
    std::ifstream in(path, std::ios::binary);
    if (!in)
        return Status::errorf("datasheet '", path, "': cannot be read");
    std::ostringstream text;
    text << in.rdbuf();
    return parse_datasheet_json(text.str(), path, out);
}

double log10_exposure_at_density(const ExpectedCurve& curve, double sensitivity_sum,
                                 double density)
{
    const double v = curve.value_at_density(density);
    if (!(v > 0.0) || v >= curve.points.back().value)
        return NAN;
    // Between points 1 and 2 the exposure scale is the same for every v.
    const double lxs_per_value = curve.points[1].exposure_lxs / curve.points[1].value;
    return std::log10(v * lxs_per_value / sensitivity_sum);
}

Status measure_datasheet_figures(const Stock& stock, const Datasheet& sheet,
                                 DevelopModels& models, const FigureOptions& options,
                                 DatasheetFigures& out)
{
    out = DatasheetFigures();
    if (Status s = stock.validate(); !s)
        return s;
    for (const Layer& l : stock.layers)
        for (const Population& p : l.populations)
            if (p.rate_area_exponent != 0.0)
                return Status::errorf("layer ", l.name, ": rate_area_exponent = ",
                                      p.rate_area_exponent,
                                      ": the analytic figures need 0 (one P(develop | N) per "
                                      "population)");
    // MODEL.md 9 on a uniform patch: halation adds its fraction of the
    // light (Layer::neutral_weight counts it), scatter moves light within
    // the patch (no change).
    std::vector<int> index;
    for (const LayerTargets& t : sheet.layers) {
        const int l = find_layer(stock, t.name);
        if (l < 0)
            return Status::errorf("the datasheet's layer '", t.name, "' is not in stock '",
                                  stock.name, "'");
        index.push_back(l);
    }
    const bool iso5800    = sheet.speed_standard == "ISO 5800";
    const double crit_net = iso5800 ? kIso5800SpeedNetDensity : kIso6SpeedNetDensity;

    const Curves ref = curves_at(stock, kDatasheetShutterS, models);
    // Speed points of every stock layer (ISO 5800 needs the slowest).
    std::vector<double> speed_h(stock.layers.size()), speed_h_err(stock.layers.size());
    for (size_t l = 0; l < stock.layers.size(); ++l) {
        const ExpectedCurve& c = ref.curves[l];
        const double sens      = stock.layers[l].neutral_weight();
        speed_h[l] = log10_exposure_at_density(c, sens, c.min_density() + crit_net);
        if (!std::isfinite(speed_h[l])) {
            if (options.unreached_is_error)
                return Status::errorf("layer ", stock.layers[l].name,
                                      ": the curve never reaches its speed point (", crit_net,
                                      " above D-min)");
            speed_h[l] = std::numeric_limits<double>::quiet_NaN();  // never reached
        }
        speed_h_err[l] = log10_h_error(c, c.value_at_density(c.min_density() + crit_net));
    }
    if (iso5800) {
        const int g = find_layer(stock, "G");
        if (g < 0)
            return Status::errorf("ISO 5800 needs a layer named G (green) in stock '",
                                  stock.name, "'");
        size_t slow = 0;
        for (size_t l = 0; l < speed_h.size(); ++l)
            if (speed_h[l] > speed_h[slow])
                slow = l;
        out.speed_log10_h.value = 0.5 * (speed_h[static_cast<size_t>(g)] + speed_h[slow]);
        out.speed_log10_h.error = 0.5 * (speed_h_err[static_cast<size_t>(g)] + speed_h_err[slow]);
        out.speed.value = iso5800_speed(std::pow(10.0, speed_h[static_cast<size_t>(g)]),
                                        std::pow(10.0, speed_h[slow]));
    } else {
        out.speed_log10_h.value = speed_h[0];
        out.speed_log10_h.error = speed_h_err[0];
        out.speed.value         = iso6_speed(std::pow(10.0, speed_h[0]));
    }
    out.speed.error = out.speed.value * std::log(10.0) * out.speed_log10_h.error;

    for (size_t i = 0; i < sheet.layers.size(); ++i) {
        const LayerTargets& t  = sheet.layers[i];
        const size_t l         = static_cast<size_t>(index[i]);
        const ExpectedCurve& c = ref.curves[l];
        const double sens      = stock.layers[l].neutral_weight();
        const double lxs_per_value = ref.models[l]->lxs_per_value();
        DatasheetFigures::Layer f;
        f.name          = t.name;
        f.d_min         = { c.min_density(), c.density_error };
        f.speed_log10_h = { speed_h[l], speed_h_err[l] };
        const auto d_at = [&](double log10_h) {
            return c.density_at(std::pow(10.0, log10_h) * sens / lxs_per_value);
        };
        if (t.slope) {
            const double span = t.slope_log10_h_hi - t.slope_log10_h_lo;
            f.slope = { (d_at(t.slope_log10_h_hi) - d_at(t.slope_log10_h_lo)) / span,
                        2.0 * c.density_error / span };
            const double mid  = t.slope_log10_h_mid();
            f.slope_halves[0] = { (d_at(mid) - d_at(t.slope_log10_h_lo)) / (0.5 * span),
                                  4.0 * c.density_error / span };
            f.slope_halves[1] = { (d_at(t.slope_log10_h_hi) - d_at(mid)) / (0.5 * span),
                                  4.0 * c.density_error / span };
        }
        for (const auto& point : t.curve)
            f.curve.push_back({ d_at(point.first), c.density_error });
        if (options.granularity)
            for (const GranularityTarget& g : t.granularity) {
                const double density = g.net ? c.min_density() + g.density : g.density;
                Figure rms;
                if (!rms_granularity_at(stock, ref, l, density, options.granularity_bounds, rms)) {
                    if (options.unreached_is_error)
                        return Status::errorf("layer ", t.name, ": density ", density,
                                              " (granularity target) is never reached");
                    rms = { std::numeric_limits<double>::quiet_NaN(),
                            std::numeric_limits<double>::quiet_NaN() };
                }
                f.granularity.push_back(rms);
            }
        out.layers.push_back(std::move(f));
    }

    if (options.reciprocity && sheet.has_reciprocity) {
        const std::vector<double> times = sheet.reciprocity_times_s();
        // The reference time's speed points (not necessarily 1/100 s).
        std::vector<double> h0 = speed_h, h0_err = speed_h_err;
        if (std::fabs(sheet.reciprocity_reference_s - kDatasheetShutterS) > 0.0) {
            const Curves c0 = curves_at(stock, sheet.reciprocity_reference_s, models);
            for (size_t l = 0; l < stock.layers.size(); ++l) {
                const ExpectedCurve& c = c0.curves[l];
                h0[l]     = log10_exposure_at_density(c, stock.layers[l].neutral_weight(),
                                                      c.min_density() + crit_net);
                h0_err[l] = log10_h_error(c, c.value_at_density(c.min_density() + crit_net));
            }
        }
        for (double t : times) {
            const Curves ct = curves_at(stock, t, models);
            Figure worst;
            std::vector<double> per_layer;
            for (size_t l = 0; l < stock.layers.size(); ++l) {
                const ExpectedCurve& c = ct.curves[l];
                const double v  = c.value_at_density(c.min_density() + crit_net);
                const double h  = log10_exposure_at_density(c, stock.layers[l].neutral_weight(),
                                                            c.min_density() + crit_net);
                const double stops = std::isfinite(h) ? kStopsPerDecade * (h - h0[l]) : INFINITY;
                per_layer.push_back(stops);
                if (l == 0 || std::fabs(stops) > std::fabs(worst.value))
                    worst = { stops, kStopsPerDecade * (log10_h_error(c, v) + h0_err[l]) };
            }
            out.reciprocity.emplace_back(t, worst);
            out.reciprocity_layer_stops.push_back(std::move(per_layer));
        }
    }
    return {};
}

Status granularity_against_density(const Stock& stock, const Datasheet& sheet,
                                   DevelopModels& models, const std::vector<double>& net_densities,
                                   std::vector<std::vector<std::pair<double, Figure>>>& out)
{
    out.clear();
    const Curves ref = curves_at(stock, kDatasheetShutterS, models);
    for (const LayerTargets& t : sheet.layers) {
        const int l = find_layer(stock, t.name);
        if (l < 0)
            return Status::errorf("the datasheet's layer '", t.name, "' is not in stock '",
                                  stock.name, "'");
        const double d_min = ref.curves[static_cast<size_t>(l)].min_density();
        out.emplace_back();
        for (double net : net_densities) {
            Figure rms;
            if (rms_granularity_at(stock, ref, static_cast<size_t>(l), d_min + net, true, rms))
                out.back().emplace_back(net, rms);
        }
    }
    return {};
}

double density_shortfall(const Stock& stock, const Datasheet& sheet, DevelopModels& models)
{
    const bool iso5800    = sheet.speed_standard == "ISO 5800";
    const double crit_net = iso5800 ? kIso5800SpeedNetDensity : kIso6SpeedNetDensity;
    const Curves ref      = curves_at(stock, kDatasheetShutterS, models);
    double shortfall      = 0.0;
    for (const LayerTargets& t : sheet.layers) {
        const int l = find_layer(stock, t.name);
        if (l < 0)
            continue;
        const ExpectedCurve& c = ref.curves[static_cast<size_t>(l)];
        double largest = c.min_density();
        for (const CurvePoint& p : c.points)
            largest = std::max(largest, p.density);
        double needed = c.min_density() + crit_net;
        for (const GranularityTarget& g : t.granularity)
            needed = std::max(needed, g.net ? c.min_density() + g.density : g.density);
        // The curve's points above the datasheet's D-min (the base is
        // fitted afterwards).
        for (const auto& point : t.curve)
            needed = std::max(needed, c.min_density() + point.second - t.curve_d_min());
        shortfall = std::max(shortfall, needed - largest);
    }
    return std::max(0.0, shortfall);
}

std::vector<Comparison> compare_figures(const Datasheet& sheet, const DatasheetFigures& fig,
                                        const Tolerances& tol)
{
    std::vector<Comparison> out;
    const auto fmt = [](double x) {
        std::ostringstream o;
        o << x;
        return o.str();
    };
    if (sheet.speed) {
        Comparison c;
        c.figure    = "speed (" + sheet.speed_standard + ")";
        c.target    = *sheet.speed;
        c.achieved  = fig.speed.value;
        c.error     = fig.speed.error;
        c.miss      = std::fabs(std::log2(fig.speed.value / *sheet.speed));
        c.tolerance = tol.speed_stops;
        c.unit      = "stops";
        out.push_back(c);
    }
    for (size_t i = 0; i < sheet.layers.size() && i < fig.layers.size(); ++i) {
        const LayerTargets& t             = sheet.layers[i];
        const DatasheetFigures::Layer& f  = fig.layers[i];
        if (t.d_min)
            out.push_back({ t.name + " D-min", *t.d_min, f.d_min.value, f.d_min.error,
                            std::fabs(f.d_min.value - *t.d_min), tol.d_min, "density" });
        if (t.slope) {
            out.push_back({ t.name + " slope [" + fmt(t.slope_log10_h_lo) + ", "
                                + fmt(t.slope_log10_h_hi) + "]",
                            *t.slope, f.slope.value, f.slope.error,
                            std::fabs(f.slope.value - *t.slope), tol.slope, "gamma" });
            const double ends[3] = { t.slope_log10_h_lo, t.slope_log10_h_mid(),
                                     t.slope_log10_h_hi };
            for (int h = 0; h < 2; ++h)
                out.push_back({ t.name + " slope [" + fmt(ends[h]) + ", " + fmt(ends[h + 1]) + "]",
                                *t.slope, f.slope_halves[h].value, f.slope_halves[h].error,
                                std::fabs(f.slope_halves[h].value - *t.slope), tol.slope_half,
                                "gamma" });
        }
        for (size_t g = 0; g < t.granularity.size() && g < f.granularity.size(); ++g) {
            const GranularityTarget& gt = t.granularity[g];
            out.push_back({ t.name + " RMS at " + (gt.net ? "net " : "gross ") + fmt(gt.density),
                            gt.rms, f.granularity[g].value, f.granularity[g].error,
                            std::fabs(f.granularity[g].value / gt.rms - 1.0),
                            tol.granularity_rel, "relative" });
        }
        for (size_t k = 0; k < t.curve.size() && k < f.curve.size(); ++k)
            out.push_back({ t.name + " D at log H " + fmt(t.curve[k].first), t.curve[k].second,
                            f.curve[k].value, f.curve[k].error,
                            std::fabs(f.curve[k].value - t.curve[k].second), tol.curve_density,
                            "density" });
    }
    const std::vector<double> times = sheet.reciprocity_times_s();
    for (size_t k = 0; k < fig.reciprocity.size() && k < times.size(); ++k) {
        const double t = fig.reciprocity[k].first;
        double target  = 0.0;
        bool tabulated = false;
        for (const auto& e : sheet.extra_stops)
            if (e.first == t) {
                target    = e.second;
                tabulated = true;
            }
        const bool inside = sheet.none_between && t >= sheet.none_between->first
                            && t <= sheet.none_between->second;
        Comparison c;
        c.figure    = "reciprocity " + fmt(t) + " s" + (tabulated ? "" : " (none)");
        c.target    = target;
        c.achieved  = fig.reciprocity[k].second.value;
        c.error     = fig.reciprocity[k].second.error;
        c.miss      = std::fabs(c.achieved - target);
        c.tolerance = (inside && !tabulated) ? tol.none_between_stops : tol.reciprocity_stops;
        c.unit      = "stops";
        out.push_back(c);
    }
    // A figure the stock never reaches (measured as NaN) misses by
    // everything.
    for (Comparison& c : out)
        if (std::isnan(c.achieved) || std::isnan(c.miss))
            c.miss = std::numeric_limits<double>::infinity();
    return out;
}

}  // namespace filmgrain::sensitometry
