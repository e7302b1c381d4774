// filmgrain sensitometry: one step of a virtual test strip, exposed with the
// real engine (render_negative) and read like a densitometer.
//
// A patch is a uniformly exposed square of film. It is rendered on a frame
// slightly larger than the square (a margin wider than any grain that
// matters, so every measured grain sees the uniform exposure) and only the
// square is measured. Macro density is read from the mean transmittance,
// D = -log10(mean over pixels of 10^-(D_pixel - base)) + base: the engine
// computes the exact covered fraction of every pixel, so this is the exact
// transmittance of the square for any pixel size, as long as no pixel hits
// the max_density clamp (clamped pixels are counted and reported).
#pragma once

#include <optional>

#include <cstdint>
#include <string>
#include <vector>

#include "filmgrain/render.h"
#include "filmgrain/stock.h"

namespace filmgrain::sensitometry {

/// How measurements are rendered: the engine and the worker threads.
struct MeasureSettings {
    /// The engine that simulates the grains (its name goes into every output).
    Engine engine = Engine::exact;
    /// Kinetics override (with engine auto or fast). early_stop with disc
    /// exposure and exact coverage renders the exact engine's images bit for
    /// bit, faster (core/src/engine/render_test.cpp checks it).
    std::optional<KineticsMethod> kinetics;
    /// Worker threads of each render; 0: all hardware threads.
    int nthreads = 0;
};

/// One uniformly exposed patch.
struct PatchSpec {
    /// Exposure of a neutral (grey) patch, lux-seconds; a layer receives
    /// sum(sensitivity) times this (exactly this for the built-in stocks,
    /// whose sensitivities sum to 1). 0: unexposed (base + fog). [0, 1e12].
    double exposure_lxs = 0.01;
    /// Time the shutter is open, seconds. (0, 1e7].
    double shutter_s = 1e-2;
    /// Side of the measured square, micrometres. > 0.
    double side_um = 1000.0;
    /// Scan pixel side, micrometres (rounded so that the square holds a
    /// whole number of pixels). > 0.
    double pitch_um = 25.0;
    /// Grain pattern; patches with different seeds are independent.
    uint64_t seed = 1;
    /// Blocks per side for the batch-means standard error of the density
    /// (the square is cut into blocks x blocks sub-squares). [2, 64].
    int blocks = 4;
};

/// What the densitometer reads from one layer of a patch.
struct LayerReading {
    std::string name;
    /// Exposure the layer received, lux-seconds.
    double exposure_lxs = 0.0;
    /// Macro density from the mean transmittance, base included.
    double density = 0.0;
    /// Standard error of `density` by batch means: the scatter of the mean
    /// transmittance of the blocks (each far wider than a grain, hence
    /// nearly independent), through the delta method (0.434 sigma_T / T).
    double density_se = 0.0;
    /// Mean transmittance of the square (base excluded).
    double mean_transmittance = 0.0;
    /// Grains with centres in the rendered region, developed ones, and the
    /// photons they absorbed (from the engine's statistics).
    uint64_t grains           = 0;
    uint64_t developed        = 0;
    uint64_t absorbed_photons = 0;
    /// Pixels at the max_density clamp: their transmittance reads as
    /// 10^-max_density instead of their true value in [0, 10^-max_density].
    uint64_t clamped_pixels = 0;
    /// Bound on the error this causes in `density`:
    /// 0.434 * clamped * 10^-max_density / (pixels * mean transmittance).
    double clamp_density_bound = 0.0;
};

/// A patch as read.
struct PatchReading {
    std::vector<LayerReading> layers;
    /// Engine name as reported by the render.
    std::string engine;
    /// Pixels per side of the measured square and their actual pitch.
    int64_t side_px = 0;
    double pitch_um = 0.0;
    /// Wall-clock seconds of the render.
    double seconds = 0.0;
};

/// Margin around the measured square, micrometres: the radius of a grain
/// at z = 6 of the largest population's log-normal (a grain in 1e9 is
/// larger), plus patch_spread_reach_um, plus one input pixel of pitch_um.
double patch_margin_um(const Stock& stock, double pitch_um);

/// Most input pixels a side of a patch whose stock spreads light or
/// inhibits development (expose_patch: then coarser than the scan's).
inline constexpr int64_t kMaxPatchInputPx = 2048;

/// How far the stock's light spread and inhibitor blur (MODEL.md 9, 10)
/// carry a point's light or density, micrometres (0 for a stock with
/// neither): the square's pixels then see what a uniform field gives them.
double patch_spread_reach_um(const Stock& stock);

/// Exposes and reads one patch with render_negative. `transmittance`, if
/// not null, receives per layer the side_px x side_px pixel transmittances
/// (row-major, base excluded) for granularity measurements.
Status expose_patch(const Stock& stock, const PatchSpec& spec, const MeasureSettings& settings,
                    PatchReading& out,
                    std::vector<std::vector<double>>* transmittance = nullptr);

/// Density from a mean transmittance: -log10(T) + base.
double density_from_mean_transmittance(double mean_transmittance, double base_density);

}  // namespace filmgrain::sensitometry
