// filmgrain sensitometry: what a sensitometrist derives from measured
// curves. Pure functions of the data (no rendering), unit-testable.
#pragma once

#include <vector>

#include "strip.h"

namespace filmgrain::sensitometry {

/// Slope of the weighted least-squares line through the points with
/// |x - x[i]| <= half_window, for every i (weights 1 / se^2; se may be
/// empty for equal weights). Points with fewer than 3 neighbours get the
/// slope of their 3 nearest points.
std::vector<double> local_slopes(const std::vector<double>& x, const std::vector<double>& y,
                                 const std::vector<double>& se, double half_window);

/// Straight line fit with standard errors.
struct LineFit {
    double slope = 0.0, intercept = 0.0;
    double slope_se = 0.0, intercept_se = 0.0;
    /// Covariance of slope and intercept.
    double covariance = 0.0;
};
/// Weighted least squares (weights 1 / se^2, or equal if se is empty).
LineFit fit_line(const std::vector<double>& x, const std::vector<double>& y,
                 const std::vector<double>& se);

/// x where the piecewise-linear curve first reaches y_target going up
/// (NaN if it never does).
double first_crossing(const std::vector<double>& x, const std::vector<double>& y,
                      double y_target);
/// Piecewise-linear interpolation of y at x0 (clamped at the ends).
double interpolate(const std::vector<double>& x, const std::vector<double>& y, double x0);

/// ISO 6 (black-and-white negative): the speed point is the exposure H_m
/// (lux-seconds) at which the density is this much above base + fog.
inline constexpr double kIso6SpeedNetDensity = 0.10;
/// ISO 6 arithmetic speed S = 0.8 / H_m.
double iso6_speed(double h_m_lxs);
/// ISO 5800 (colour negative): H_G and H_slow are the exposures at which
/// the green and the slowest layer reach this much above their D-min.
inline constexpr double kIso5800SpeedNetDensity = 0.15;
/// ISO 5800 arithmetic speed S = sqrt(2) / H_M, H_M = sqrt(H_G H_slow).
double iso5800_speed(double h_green_lxs, double h_slowest_lxs);

/// Operational definitions of the ISO 6 / classical sensitometric numbers.
struct CurveMetrics {
    double base_fog_density = 0.0;  ///< unexposed patch
    double d_max            = 0.0;  ///< highest density measured
    /// Speed point: log10 H_m where D = base + fog + 0.10 (ISO 6).
    double speed_log10_h = 0.0;
    /// ISO 6 arithmetic speed S = 0.8 / H_m (H_m in lux-seconds).
    double iso_speed = 0.0;
    /// Gamma: slope of the steepest straight part, the weighted regression
    /// over a window of 0.6 log10 H (the largest such slope).
    double gamma = 0.0;
    double gamma_se = 0.0;  ///< standard error of that regression slope
    double gamma_log10_h_centre = 0.0;
    /// ISO 6 contrast check: D at log10 H_m + 1.30 minus D at H_m (the
    /// standard's development gives 0.80), and the mean gradient over it.
    double iso_delta_density   = 0.0;
    double iso_mean_gradient   = 0.0;
    /// Local slopes (regression over +-0.2 log10 H) at the lowest and
    /// highest exposure: the toe and the shoulder are present when each is
    /// below 0.3 gamma.
    double toe_slope      = 0.0;
    double shoulder_slope = 0.0;
    /// The straight part: the contiguous range around the gamma window
    /// where the local slope stays within 20% of gamma.
    double straight_log10_h_lo = 0.0;
    double straight_log10_h_hi = 0.0;
    /// Latitude: the contiguous range around the gamma window where the
    /// local slope is at least 0.3 gamma (Jones's fractional-gradient
    /// criterion applied at both ends), in stops.
    double latitude_log10_h_lo = 0.0;
    double latitude_log10_h_hi = 0.0;
    double latitude_stops      = 0.0;
    /// Local slopes used above (same length as the curve).
    std::vector<double> slopes;
};

/// Derives the metrics of one layer's curve.
CurveMetrics analyse_curve(const LayerCurve& curve);

/// Fit of gamma(t) = gamma_inf (1 - exp(-k t)) by weighted least squares
/// (weights 1 / se^2): a one-dimensional search on k, gamma_inf in closed
/// form for each k.
struct GammaTimeFit {
    double gamma_inf = 0.0;
    double k_per_s   = 0.0;
    double rms_residual = 0.0;
};
GammaTimeFit fit_gamma_vs_time(const std::vector<double>& time_s, const std::vector<double>& gamma,
                               const std::vector<double>& gamma_se);

}  // namespace filmgrain::sensitometry
