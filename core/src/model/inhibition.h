// filmgrain: MODEL.md section 10, development inhibitors: developing grains
// release inhibitors that diffuse and hold back development nearby, in
// their own layer (adjacency effects) and in the others (interimage
// effects). Modelled through the expected developed density, so grains stay
// independent given the exposure.
#pragma once

#include <atomic>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "model/exposure.h"
#include "model/light_spread.h"
#include "filmgrain/expected_curve.h"
#include "filmgrain/render.h"
#include "filmgrain/status.h"
#include "filmgrain/stock.h"

namespace filmgrain {

/// The develop uniform of a grain under inhibition: MODEL.md 10's
/// P -> P exp(-log_factor). A grain develops iff u >= 1 - P (Development);
/// with u' = 1 - (1 - u) exp(log_factor), u' >= 1 - P iff
/// u >= 1 - P exp(-log_factor), so every engine's decision (the chain's n4,
/// the table, the curve, their early exits) applies unchanged to u'.
inline double inhibited_uniform(double u, double log_factor)
{
    return 1.0 - (1.0 - u) * std::exp(log_factor);
}

/// A value per input pixel over the whole frame, read box-reconstructed
/// (the pixel holding a point; beyond the frame the nearest edge pixel's
/// with `clamp_edge`, the scene continued (MODEL.md 2), else 0).
struct FramePlane {
    std::vector<float> values;  ///< row by row
    int64_t width = 0, height = 0;
    double pitch_um = 1.0;
    bool clamp_edge = false;

    double at(double x_um, double y_um) const
    {
        double fx = std::floor(x_um / pitch_um), fy = std::floor(y_um / pitch_um);
        if (!(fx >= 0.0 && fy >= 0.0 && fx < static_cast<double>(width)
              && fy < static_cast<double>(height))) {
            if (!clamp_edge || std::isnan(fx) || std::isnan(fy))
                return 0.0;
            fx = std::clamp(fx, 0.0, static_cast<double>(width - 1));
            fy = std::clamp(fy, 0.0, static_cast<double>(height - 1));
        }
        return values[static_cast<size_t>(static_cast<int64_t>(fy) * width
                                          + static_cast<int64_t>(fx))];
    }
};

/// MODEL.md 10 for a render: per layer k, the plane of
/// log_factor_k = sum_j inhibition[k][j] Dbar_j, where Dbar_j is layer j's
/// expected developed density (its expected curve without inhibition, less
/// the base density) at each input pixel's exposure value, blurred by the
/// normalised Gaussian of standard deviation inhibitor_diffusion_um
/// (spread_frame: exact pixel means, over the whole frame; beyond the frame
/// the scene continues (MODEL.md 2, scene.edge clamp: each point the
/// density of the nearest edge pixel), or (gate) the film is unexposed and
/// its density the fog's). `exposures[j]`
/// gives layer j's exposure value (after its light spread) over the whole
/// frame. A layer whose row is all zero gets no plane (null).
struct InhibitionPlan {
    std::vector<std::shared_ptr<const FramePlane>> log_factor;
    /// Bound on |log_factor - the model's|: sum_j inhibition[k][j] times the
    /// expected curves' density error, largest over k.
    double error = 0.0;
    /// Per layer, an upper bound on its log factor anywhere, from the stock
    /// and scene alone: sum_j inhibition[k][j] times the largest density
    /// above base of layer j's curve (a blur cannot exceed it). 0 for a
    /// layer without inhibition.
    std::vector<double> max_log_factor;
};
/// `cancel` (optional), set by another thread: the plan stops within a
/// table batch or a frame row and returns the error "render cancelled".
Status plan_inhibition(const Stock& stock, const SceneSettings& scene,
                       const std::vector<const LayerExposure*>& exposures, int64_t frame_width,
                       int64_t frame_height, double pitch_um, int nthreads, InhibitionPlan& out,
                       const std::atomic<bool>* cancel = nullptr,
                       SpreadMethod method = SpreadMethod::fft);

/// MODEL.md 10 on a large uniform neutral patch: layer k's log factor
/// sum_j inhibition[k][j] Dbar_j where layer k has exposure value `value`
/// (each layer j then has value * w_j / w_k, w the sensitivity sums), Dbar_j
/// from `plain`, the curves without inhibition. 0 without inhibition.
double neutral_log_factor(const Stock& stock, const std::vector<ExpectedCurve>& plain, size_t k,
                          double value);

/// MODEL.md 10 on expected curves: the curves of a large uniform neutral
/// patch (a grey scale, as datasheets measure it) once inhibition acts.
/// `curves` are the stock's curves without inhibition (expected_curves of
/// the stock with its inhibition cleared); on a neutral patch of grey value
/// y each layer j has v_j = y * sum(sensitivity_j), Dbar_j is uniform (the
/// blur keeps it), so E[T_k] becomes E[T_k]^exp(-sum_j inhibition[k][j]
/// Dbar_j). Their density_error grows by the inhibition's error.
void apply_inhibition(const Stock& stock, std::vector<ExpectedCurve>& curves);

}  // namespace filmgrain
