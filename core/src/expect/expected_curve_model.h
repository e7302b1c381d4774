// filmgrain: the pieces expected_curves (filmgrain/expected_curve.h) is
// assembled from, for the project's own tools (filmgrain-fit, the
// sensitometry library) that evaluate many stocks sharing the same
// latent-image rates: the P(develop | N) tables depend only on the rates,
// the shutter and the development (MODEL.md 3-4), never on the grain
// sizes or counts (MODEL.md 1), so they are built once and reused.
#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include "expect/develop_curve.h"
#include "model/development.h"
#include "filmgrain/expected_curve.h"
#include "model/geometry.h"
#include "engine/kinetics_table.h"
#include "kernels/pixel_model.h"

namespace filmgrain {

/// P(develop | N) (the exact chain, tabulated) and P(develop | mean
/// photons) of one set of rates at one shutter.
struct DevelopModel {
    KineticsRates rates;
    double shutter_s = 0.0;
    std::shared_ptr<const DevelopTable> table;  ///< shared_develop_table's
    std::unique_ptr<DevelopCurve> curve;
    /// Bound on the error of P read from it: 2 standard errors of the
    /// table's nodes plus the table's and the curve's interpolation (0 for
    /// fog-only tables, which are read at 0 photons: exact).
    double probability_error = 0.0;
};

/// The tables of one development (the stock's development_time_s,
/// development_tau_s and fog_tau_s), one per distinct (rates, shutter),
/// built on first use in the order asked for; the i-th table's Monte Carlo
/// streams are keyed by i (expected_curves asks in stock order, so its
/// results do not depend on this cache). Deterministic. Not thread safe
/// (get() inserts); the tables themselves are const and shareable.
class DevelopModels {
public:
    DevelopModels(const Stock& stock, const ExpectedCurveOptions& options);
    /// The table of `pop`'s rates at `shutter_s` (built if new). A build
    /// cancelled (ExpectedCurveOptions::cancel) leaves an incomplete table
    /// and no curve: check table->complete() before using it.
    const DevelopModel& get(const Population& pop, double shutter_s);
    size_t size() const { return m_models.size(); }
    const Development& development() const { return m_development; }

private:
    Development m_development;
    ExpectedCurveOptions m_options;
    std::vector<std::unique_ptr<DevelopModel>> m_models;
};

/// One layer of a stock as the Boolean model sees it under a scene: its
/// grain processes and its PixelPopulations (for coverage_exponent,
/// PixelModel, size_quadrature). Holds pointers into `stock` and `models`:
/// both must outlive it. Not copyable.
class LayerModel {
public:
    /// `models` must have been made for this stock's development.
    LayerModel(const Stock& stock, size_t layer, const SceneSettings& scene,
               DevelopModels& models);
    LayerModel(const LayerModel&)            = delete;
    LayerModel& operator=(const LayerModel&) = delete;

    const std::vector<PixelPopulation>& populations() const { return m_pops; }
    /// Lux-seconds per unit of exposure value (MODEL.md 2) at this scene.
    double lxs_per_value() const { return m_lxs_per_value; }
    /// Bound on the error of the coverage exponent K = sum n E[a P]: the
    /// tables' error times n E[a], plus the size quadrature's truncation.
    double coverage_error() const { return m_coverage_error; }

private:
    std::vector<PopulationGrains> m_grains;
    std::vector<PixelPopulation> m_pops;
    double m_lxs_per_value  = 0.0;
    double m_coverage_error = 0.0;
};

/// The expected curve of `stock.layers[layer]` (the points and error bound
/// documented at ExpectedCurve) from its LayerModel; only the v = 0 point
/// when fog_only.
ExpectedCurve expected_curve(const Stock& stock, size_t layer, const LayerModel& model,
                             bool fog_only);

}  // namespace filmgrain
