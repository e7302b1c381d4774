// filmgrain: the expected characteristic curve of each layer (MODEL.md 2-5):
// the density of a large uniformly exposed patch as a function of the
// layer's exposure value, at one scene's shutter and exposure offset.
//
// D(v) = base_density - log10 E[T](v), E[T](v) = exp(-sum over populations
// of grains_per_um2 E[a P(develop | lambda(a, v))]) (the Boolean model of
// MODEL.md 5), with P(develop | lambda) the Poisson mixture of P(develop |
// N) (MODEL.md 3-4). Computed, not fitted, from the core's own pieces: a
// DevelopTable of P(develop | N) per set of rates (the exact chain, Monte
// Carlo) and the DevelopCurve folded from it (P(develop | mean photons), as
// the fast engine draws it), integrated over the lognormal size law
// (trapezoid rule on |z| <= 9 of ln d). Used by the CLI's outputs (ADX
// D-min, regrain) and by tests.
#pragma once

#include <atomic>
#include <string>
#include <vector>

#include "filmgrain/render.h"
#include "filmgrain/status.h"
#include "filmgrain/stock.h"

namespace filmgrain {

/// One point of a layer's expected curve.
struct CurvePoint {
    /// The layer's exposure value v = dot(sensitivity, rgb), scene-linear
    /// (MODEL.md 2), as the grains receive it: after MODEL.md 9's spread,
    /// which on a uniform field of value v gives v * uniform_field_gain()
    /// (Layer); the grey card 0.18 gets exposure_at_grey_lxs.
    double value = 0.0;
    /// H = v / 0.18 * exposure_at_grey_lxs * 2^exposure_stops, lux-seconds.
    double exposure_lxs = 0.0;
    /// E[T]: mean transmittance of a large uniform patch, (0, 1].
    double transmittance = 1.0;
    /// base_density - log10(max(E[T], 10^-max_density)) (MODEL.md 5).
    double density = 0.0;
    /// A layer with coupler-limited populations (docs/model.md): each
    /// population's grain cover n E[a P] at v (empty for other layers).
    /// Inhibition (MODEL.md 10) scales every cover by the same factor, and
    /// such a layer's E[T] is not a power of its uninhibited one.
    std::vector<double> covers;
};

/// A layer's expected curve: v = 0 first (the film's D-min: base plus fog),
/// then 16 points per octave of v from 2^-16 to 2^12 times grey (0.18),
/// increasing. Between points E[T] is linear in ln v; below the first
/// point above 0 it is that point's (2^-16 grey is fog for any stock that
/// has a latitude), beyond the last point it is the last point's.
/// Thread safety: a value type; const members may be called concurrently.
struct ExpectedCurve {
    std::string layer;  ///< the layer's name (its output channel)
    double base_density = 0.0;
    double max_density  = 0.0;  ///< the stock's clamp of -log10 T
    std::vector<CurvePoint> points;
    /// Bound on |density - the model's exact expected density| at every
    /// point, density units: the P(develop | N) table's node errors (at 2
    /// standard errors, taken as if they all leaned one way) and
    /// interpolation, the curve's interpolation, the size quadrature's
    /// truncation at |z| = 9 and the interpolation between points (the
    /// largest found half-way between them).
    double density_error = 0.0;

    /// D-min: the density at v = 0 (base plus fog).
    double min_density() const { return points.front().density; }
    /// E[T] at v (v <= 0 or not finite: the v = 0 point).
    double transmittance_at(double value) const;
    /// The density of transmittance_at(v).
    double density_at(double value) const;
    /// dE[T]/dv at v > 0 (the slope of the interpolated curve; <= 0 where
    /// the curve is monotone); 0 for v <= 0 and beyond the last point.
    double transmittance_slope_at(double value) const;
    /// Local gamma dD/dlog10(v) at v > 0 (0 elsewhere).
    double gamma_at(double value) const;
    /// The inverse: the smallest v whose expected density reaches
    /// `density` (E[T] is made non-increasing first, so that noise in the
    /// table cannot fold the curve). Density at or below D-min: 0; above
    /// the last point's density: the last point's v. Not finite: 0.
    double value_at_density(double density) const;
};

/// One curve read at many values (a frame's pixels): ExpectedCurve's
/// transmittance_at, density_at and transmittance_slope_at, with the
/// logarithms of the curve's own points and its density clamp taken once
/// instead of at every call (the members use it: the same arithmetic, the
/// same results). Holds a pointer to the curve, which must outlive it and not change.
class ExpectedCurveReader {
public:
    explicit ExpectedCurveReader(const ExpectedCurve& curve);
    double transmittance_at(double value) const;
    double density_at(double value) const;
    double transmittance_slope_at(double value) const;

private:
    const ExpectedCurve* m_curve;
    double m_min_transmittance;  ///< 10^-max_density: the density clamp
    double m_log_first = 0.0;  ///< ln v of the first point above v = 0
    double m_log_last  = 0.0;  ///< ln v of the last point
    double m_log_step  = 0.0;  ///< ln v between points (0 with fewer than 3)
};

/// Options of expected_curves.
struct ExpectedCurveOptions {
    /// Target standard error of each P(develop | N) node of the tables
    /// (DevelopTable::Options::target_standard_error). (0, 0.1].
    double target_standard_error = 1e-3;
    /// Largest photon count tabulated; larger means read the last node
    /// (P(develop | N) is flat there: the shoulder). [64, 65536].
    uint64_t max_photons = 4096;
    /// Only the v = 0 point (D-min): P(develop | 0 photons) is the fog
    /// probability, exact, and no chain is run. Then every population's
    /// rate_area_exponent is allowed.
    bool fog_only = false;
    /// Worker threads for the tables (0: all).
    int nthreads = 0;
    /// Optional: set by another thread to stop the tables' builds;
    /// expected_curves then returns an error ("cancelled").
    const std::atomic<bool>* cancel = nullptr;
};

/// The expected curve of every layer of `stock` (stock order) for the
/// scene's shutter_s and exposure_stops (the seed does not matter: the
/// tables' Monte Carlo streams have their own fixed key, so the result is
/// deterministic). Populations with the same rates share one table.
/// Errors: an invalid stock or scene (the validate() messages); a
/// population with rate_area_exponent != 0 (P(develop | N) then depends on
/// the grain's size and no single curve exists; fog_only excepted); options
/// out of range. Cost: about 3 s per distinct set of rates at the default
/// options on one core (the chain runs of the table).
/// Thread safety: reentrant.
Status expected_curves(const Stock& stock, const SceneSettings& scene,
                       const ExpectedCurveOptions& options, std::vector<ExpectedCurve>& out);

}  // namespace filmgrain
