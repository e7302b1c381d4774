// filmgrain sensitometry: reciprocity: the exposure that gives a chosen
// density above fog, as a function of the shutter time.
#pragma once

#include <vector>

#include "analysis.h"
#include "strip.h"

namespace filmgrain::sensitometry {

/// The exposure found for one shutter time.
struct ReciprocityPoint {
    double shutter_s     = 0.0;
    double log10_h       = 0.0;  ///< log10 H (lux-seconds) giving the density
    double log10_h_se    = 0.0;  ///< statistical error (from the patch errors)
    int patches          = 0;
    double seconds       = 0.0;
    /// The patches read: log10 H and net density (mean over layers).
    std::vector<double> patch_log10_h, patch_net_density, patch_net_density_se;
};

/// Finds log10 H at which the net density (density minus base + fog,
/// averaged over the layers; `fog_density` holds each layer's base + fog)
/// reaches `net_density`, at shutter `shutter_s`:
///  1. from `guess_log10_h`, patches 0.3 log10 H apart until the target is
///     bracketed;
///  2. two patches inside the bracket (4 points 0.1 apart);
///  3. a weighted line through them gives a first root; one more patch at
///     that root and a line through the three points nearest it give the
///     answer (curvature over +-0.1 log10 H then shifts it by far less
///     than its statistical error).
/// Every patch has its own seed: patches are independent.
Status exposure_for_net_density(const Stock& stock, double shutter_s, double net_density,
                                const std::vector<double>& fog_density, double guess_log10_h,
                                const PatchBudget& budget, const MeasureSettings& settings,
                                uint64_t seed, ReciprocityPoint& out);

/// Schwarzschild's law fitted at long times: log10 H = (1 - p) log10 t + c
/// over the points with shutter_s >= t_min_s (weighted by 1 / se^2).
struct SchwarzschildFit {
    double p = 0.0, p_se = 0.0;
    double intercept = 0.0;
    int points       = 0;
};
SchwarzschildFit fit_schwarzschild(const std::vector<ReciprocityPoint>& points, double t_min_s);

}  // namespace filmgrain::sensitometry
