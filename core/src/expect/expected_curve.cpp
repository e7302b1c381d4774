// The expected characteristic curve of each layer (filmgrain/expected_curve.h):
// MODEL.md 5's Boolean-model mean transmittance over the layer's exposure
// value, assembled from the pieces the fast engine draws from (DevelopTable,
// DevelopCurve and its P(develop | mean photons), PopulationGrains' radius
// at each size quantile).
#include "filmgrain/expected_curve.h"
#include "expect/expected_curve_model.h"
#include "model/image_formation.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "expect/develop_curve.h"
#include "model/development.h"
#include "model/dye.h"
#include "model/exposure.h"
#include "model/geometry.h"
#include "model/inhibition.h"
#include "engine/kinetics_table.h"
#include "kernels/pixel_model.h"
#include "util/rng.h"
#include "util/sampling.h"

namespace filmgrain {

namespace {

/// The points of a curve: v = 0, then kPerOctave per octave from
/// 2^-kOctavesBelow to 2^kOctavesAbove times grey (the pixel model's
/// range and spacing).
constexpr int kOctavesBelow = 16, kOctavesAbove = 12, kPerOctave = 16;
/// E[T] of a uniform patch of one layer at exposure value v (MODEL.md 5
/// and 8: layer_mean_transmittance), with the pixel model's size
/// quadrature and P(develop | mean photons).
double mean_transmittance(const Layer& layer, const std::vector<PixelPopulation>& pops, double v)
{
    return layer_mean_transmittance(layer, population_covers(pops, v));
}

}  // namespace

ExpectedCurveReader::ExpectedCurveReader(const ExpectedCurve& curve)
    : m_curve(&curve)
    , m_min_transmittance(DensityFromTransmittance(curve.max_density, 0.0).min_transmittance())
{
    const std::vector<CurvePoint>& points = curve.points;
    if (points.size() >= 2) {
        m_log_first = std::log(points[1].value);
        m_log_last  = std::log(points.back().value);
    }
    if (points.size() >= 3)
        m_log_step = std::log(points[2].value / points[1].value);
}

double ExpectedCurveReader::transmittance_at(double value) const
{
    const std::vector<CurvePoint>& points = m_curve->points;
    if (!(value > 0.0) || points.size() < 2)
        return points.front().transmittance;
    const double lv = std::log(value);
    if (lv <= m_log_first)
        return points[1].transmittance;  // as the pixel model: its first node
    if (lv >= m_log_last)
        return points.back().transmittance;
    const double t = (lv - m_log_first) / m_log_step;
    const size_t i = std::min(static_cast<size_t>(t), points.size() - 3);
    const double f = t - static_cast<double>(i);
    return points[i + 1].transmittance
           + f * (points[i + 2].transmittance - points[i + 1].transmittance);
}

double ExpectedCurveReader::density_at(double value) const
{
    return clamped_density(transmittance_at(value), m_min_transmittance, m_curve->base_density);
}

double ExpectedCurveReader::transmittance_slope_at(double value) const
{
    const std::vector<CurvePoint>& points = m_curve->points;
    if (!(value > 0.0) || points.size() < 3)
        return 0.0;
    const double lv = std::log(value);
    if (lv <= m_log_first || lv >= m_log_last)
        return 0.0;
    const size_t i = std::min(static_cast<size_t>((lv - m_log_first) / m_log_step),
                              points.size() - 3);
    // T is linear in ln v between points: dT/dv = (dT / d ln v) / v.
    return (points[i + 2].transmittance - points[i + 1].transmittance) / m_log_step / value;
}

double ExpectedCurve::transmittance_at(double value) const
{
    return ExpectedCurveReader(*this).transmittance_at(value);
}

double ExpectedCurve::density_at(double value) const
{
    return ExpectedCurveReader(*this).density_at(value);
}

double ExpectedCurve::transmittance_slope_at(double value) const
{
    return ExpectedCurveReader(*this).transmittance_slope_at(value);
}

double ExpectedCurve::gamma_at(double value) const
{
    const double t = transmittance_at(value);
    if (!(value > 0.0) || !(t > 0.0))
        return 0.0;
    // D = -log10 T: dD/dlog10 v = -(v / T) dT/dv.
    return -value / t * transmittance_slope_at(value);
}

double ExpectedCurve::value_at_density(double density) const
{
    if (!std::isfinite(density) || points.size() < 2)
        return 0.0;
    // Non-increasing E[T] (running minimum from v = 0): the table's Monte
    // Carlo noise cannot fold the inverse.
    const double t_target = std::pow(10.0, -(density - base_density));
    double t_prev         = points.front().transmittance;
    if (t_target >= t_prev)
        return 0.0;
    double v_prev = 0.0;
    for (size_t i = 1; i < points.size(); ++i) {
        const double t = std::min(points[i].transmittance, t_prev);
        if (t <= t_target) {
            if (i == 1 || t_prev <= t)
                return points[i].value;
            // Linear in ln v between points i - 1 and i (as transmittance_at).
            const double f = (t_prev - t_target) / (t_prev - t);
            return std::exp(std::log(v_prev) + f * std::log(points[i].value / v_prev));
        }
        t_prev = t;
        v_prev = points[i].value;
    }
    return points.back().value;
}

DevelopModels::DevelopModels(const Stock& stock, const ExpectedCurveOptions& options)
    : m_development(stock), m_options(options)
{
}

const DevelopModel& DevelopModels::get(const Population& pop, double shutter_s)
{
    for (const auto& m : m_models)
        if (m->rates.k_pair_per_s == pop.k_pair_per_s && m->rates.k_join_per_s == pop.k_join_per_s
            && m->rates.k_loss_per_s == pop.k_loss_per_s && m->shutter_s == shutter_s)
            return *m;
    auto m       = std::make_unique<DevelopModel>();
    m->rates     = { pop.k_pair_per_s, pop.k_join_per_s, pop.k_loss_per_s };
    m->shutter_s = shutter_s;
    // fog_only reads P at 0 photons only (exact: the fog probability), so
    // its tables hold the minimum.
    const bool fog_only = m_options.fog_only;
    DevelopTable::Options o;
    o.max_photons           = fog_only ? 64 : m_options.max_photons;
    o.target_standard_error = fog_only ? 0.1 : m_options.target_standard_error;
    o.min_samples           = fog_only ? 32 : o.min_samples;
    o.stream_key            = hash_ids(0xe7c0ffee, m_models.size());
    o.nthreads              = m_options.nthreads;
    o.cancel                = m_options.cancel;
    m->table = shared_develop_table(m->rates, shutter_s, m_development, o);
    if (!m->table->complete()) {  // cancelled (options.cancel): no curve
        m_models.push_back(std::move(m));
        return *m_models.back();
    }
    m->curve = std::make_unique<DevelopCurve>(*m->table, fog_only ? 2 : 4096);
    m->probability_error = fog_only ? 0.0
                                    : 2.0 * m->table->max_standard_error()
                                          + m->table->max_interpolation_error()
                                          + m->curve->max_interpolation_error();
    m_models.push_back(std::move(m));
    return *m_models.back();
}

LayerModel::LayerModel(const Stock& stock, size_t l, const SceneSettings& scene,
                       DevelopModels& models)
    : m_lxs_per_value(exposure_lxs_per_unit_value(stock.exposure_at_grey_lxs, scene.exposure_stops))
{
    const Layer& layer = stock.layers[l];
    m_grains.reserve(layer.populations.size());  // m_pops points into it
    for (size_t p = 0; p < layer.populations.size(); ++p) {
        const Population& pop = layer.populations[p];
        const DevelopModel& s = models.get(pop, scene.shutter_s);
        m_grains.emplace_back(pop, 0, static_cast<uint32_t>(l), static_cast<uint32_t>(p));
        m_pops.push_back({ &pop, &m_grains.back(),
                           pop.quantum_efficiency * kPhotonsPerUm2PerLxs * m_lxs_per_value,
                           s.curve.get(), s.table.get() });
        // K = sum n E[a P]: an error e in P moves it by at most n E[a] e;
        // the grains beyond the quadrature (z > 9) hold at most the
        // share Phi(2 s - 9) of n E[a]; the trapezoid rule's own error
        // on this smooth, Gaussian-damped integrand is far below both.
        const double n_area = pop.grains_per_um2 * m_grains.back().mean_area_um2();
        m_coverage_error += n_area
                            * (s.probability_error
                               + normal_upper_tail(kSizeQuadratureZ - 2.0 * pop.diameter_log_sigma));
    }
}

ExpectedCurve expected_curve(const Stock& stock, size_t l, const LayerModel& model, bool fog_only)
{
    const std::vector<PixelPopulation>& pops = model.populations();
    const double lxs_per_value               = model.lxs_per_value();
    // The density error of a cover error e: at most cloud_area_factor e
    // (coupler-limited populations too: layer_mean_transmittance).
    const double cloud_factor                = cloud_area_factor(stock.layers[l]);
    ExpectedCurve curve;
    curve.layer        = stock.layers[l].name;
    curve.base_density = stock.layer_base_density(l);
    curve.max_density  = stock.max_density;
    const DensityFromTransmittance to_density(stock.max_density, curve.base_density);
    const auto point = [&](double v) {
        CurvePoint c;
        c.value         = v;
        c.exposure_lxs  = v * lxs_per_value;
        if (has_coupler_limit(stock.layers[l])) {
            c.covers        = population_covers(pops, v);
            c.transmittance = layer_mean_transmittance(stock.layers[l], c.covers);
        } else {
            c.transmittance = mean_transmittance(stock.layers[l], pops, v);
        }
        c.density       = to_density(c.transmittance);
        return c;
    };
    curve.points.push_back(point(0.0));
    double interpolation = 0.0;  // largest relative error of E[T] between points
    if (!fog_only) {
        const double grey   = kGreyValue;
        const double log_v0 = std::log(grey) - kOctavesBelow * std::log(2.0);
        const double step   = std::log(2.0) / kPerOctave;
        for (int i = 0; i <= (kOctavesBelow + kOctavesAbove) * kPerOctave; ++i) {
            curve.points.push_back(point(std::exp(log_v0 + i * step)));
            if (i == 0)
                continue;
            // Linear interpolation in ln v errs most half-way.
            const CurvePoint& a = curve.points[curve.points.size() - 2];
            const CurvePoint& b = curve.points.back();
            const double mid
                = mean_transmittance(stock.layers[l], pops, std::exp(log_v0 + (i - 0.5) * step));
            interpolation = std::max(
                interpolation, std::fabs(0.5 * (a.transmittance + b.transmittance) - mid) / mid);
        }
    }
    // d(-log10 T) = 0.434 dT / T, and dK = -dT / T.
    curve.density_error = kLog10E * (cloud_factor * model.coverage_error() + interpolation);
    return curve;
}

Status expected_curves(const Stock& stock, const SceneSettings& scene,
                       const ExpectedCurveOptions& options, std::vector<ExpectedCurve>& out)
{
    out.clear();
    if (Status s = stock.validate(); !s)
        return s;
    if (Status s = scene.validate(); !s)
        return s;
    if (!(options.target_standard_error > 0.0 && options.target_standard_error <= 0.1))
        return Status::errorf("expected curve: target_standard_error = ",
                              options.target_standard_error, " is outside (0, 0.1]");
    if (options.max_photons < 64 || options.max_photons > 65536)
        return Status::errorf("expected curve: max_photons = ", options.max_photons,
                              " is outside [64, 65536]");
    if (!options.fog_only)
        for (size_t l = 0; l < stock.layers.size(); ++l)
            for (size_t p = 0; p < stock.layers[l].populations.size(); ++p)
                if (stock.layers[l].populations[p].rate_area_exponent != 0.0)
                    return Status::errorf(
                        "expected curve: layers[", l, "].populations[", p,
                        "].rate_area_exponent = ",
                        stock.layers[l].populations[p].rate_area_exponent,
                        ": P(develop | N) then depends on the grain's size, so the layer has no "
                        "single tabulated curve (only 0 is supported)");

    DevelopModels models(stock, options);
    // Build every table first, in stock order (their streams are keyed by
    // that order).
    for (const Layer& layer : stock.layers)
        for (const Population& pop : layer.populations)
            if (!models.get(pop, scene.shutter_s).table->complete())
                return Status::error("cancelled");
    for (size_t l = 0; l < stock.layers.size(); ++l) {
        const LayerModel model(stock, l, scene, models);
        out.push_back(expected_curve(stock, l, model, options.fog_only));
    }
    apply_inhibition(stock, out);  // MODEL.md 10 (nothing without inhibition)
    return {};
}

}  // namespace filmgrain
