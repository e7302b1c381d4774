// filmgrain sensitometry: test strips (a series of patches over log H) and
// how big each patch is made so that a whole strip stays cheap.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "patch.h"

namespace filmgrain::sensitometry {

/// How large a patch is: as large as `max_area_um2` allows, but no more
/// than the estimated simulation cost `max_cost_s` permits (photon counts
/// grow linearly with exposure, and density noise is low on the shoulder
/// anyway), and never below `min_area_um2`.
struct PatchBudget {
    double max_area_um2 = 2.0e6;
    double min_area_um2 = 2.5e4;
    /// Estimated single-thread seconds per patch (see estimated_cost_s).
    double max_cost_s = 0.4;
    /// Scan pixel side, um; 0: automatic (3.5 times the largest mean grain
    /// diameter, within [6, 25] um: large enough that few pixels hit the
    /// max_density clamp, small enough that the exact coverage of a pixel,
    /// quadratic in the discs touching it, stays cheap).
    double pitch_um = 0.0;
};

/// Estimated single-thread seconds to simulate one square micrometre of
/// the stock at exposure H: about 0.5 us per grain and 120 ns per absorbed
/// photon (240 ns below 1e-4 s, where every photon meets many electrons),
/// as measured with the exact engine.
double estimated_cost_s_per_um2(const Stock& stock, double exposure_lxs, double shutter_s);

/// The patch the budget allows at exposure H.
PatchSpec plan_patch(const Stock& stock, double exposure_lxs, double shutter_s,
                     const PatchBudget& budget, uint64_t seed);

/// A seed for patch `index` of a series started from `seed` (independent
/// grain patterns for every patch).
uint64_t patch_seed(uint64_t seed, uint64_t index);

/// A test strip: patches from 10^log10_h_min to 10^log10_h_max lux-seconds
/// in steps of log10_h_step, at one shutter time, plus an unexposed patch
/// for base + fog.
struct StripSpec {
    double log10_h_min  = -6.0;
    double log10_h_max  = 0.0;
    double log10_h_step = 0.1;
    double shutter_s    = 1e-2;
    PatchBudget budget;
    /// Area of the unexposed (base + fog) patch, um^2.
    double fog_area_um2 = 4.0e6;
    uint64_t seed       = 1;
};

/// The characteristic curve of one layer as measured.
struct LayerCurve {
    std::string name;
    double fog_density    = 0.0;  ///< base + fog (unexposed patch)
    double fog_density_se = 0.0;
    std::vector<double> log10_h;     ///< exposure the layer received
    std::vector<double> density;     ///< macro density, base included
    std::vector<double> density_se;  ///< batch-means standard error
};

/// A measured strip.
struct Curve {
    std::string engine;
    double shutter_s = 0.0;
    std::vector<LayerCurve> layers;
    std::vector<double> area_um2;  ///< measured area of each patch
    double seconds          = 0.0; ///< wall-clock time of the renders
    uint64_t clamped_pixels = 0;   ///< summed over patches and layers
    /// Largest bound on a density error from the clamp (LayerReading).
    double clamp_density_bound = 0.0;
};

/// Exposes and reads a strip.
Status expose_strip(const Stock& stock, const StripSpec& spec, const MeasureSettings& settings,
                    Curve& out);

}  // namespace filmgrain::sensitometry
