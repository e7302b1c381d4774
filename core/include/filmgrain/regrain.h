// filmgrain: regrain, the film's grain carried onto the scene-linear input
// (output=regrain). Each layer's expected curve (filmgrain/expected_curve.h)
// is inverted, linearised at the pixel: the departure of the pixel's
// transmittance from the curve's mean, divided by the curve's slope, is the
// layer's grain in exposure; the inverse of the layers' sensitivity matrix
// (MODEL.md 2) carries it back to R, G, B and adds it to the input.
// Plain buffers; the CLI and the Python module call it through the
// plugin's output transform.
#pragma once

#include <array>
#include <vector>

#include "filmgrain/expected_curve.h"
#include "filmgrain/status.h"
#include "filmgrain/stock.h"

namespace filmgrain {

/// Where the curve is flatter than this fraction of its steepest gamma, the
/// regrain gain is that of this gamma (the grain of a flat toe or shoulder
/// would otherwise grow without bound: there the density says almost
/// nothing about the exposure).
inline constexpr double kRegrainMinGammaFraction = 0.1;

/// What regrain needs of the stock, prepared once.
/// Thread safety: const after make_regrain_model; shareable.
struct RegrainModel {
    std::vector<ExpectedCurve> curves;               ///< per layer (stock order)
    std::vector<std::array<double, 3>> sensitivity;  ///< per layer
    /// Per layer, Layer::uniform_field_gain: the curves' value is the
    /// exposure the grains get, after MODEL.md 9's spread, which on the
    /// local mean a pixel stands for is the input's value times this.
    std::vector<double> uniform_field_gain;
    std::vector<double> min_gamma;  ///< per layer
    /// M^-1 (3 layers) or, for one layer, each row (1 / sum of weights).
    std::array<std::array<double, 3>, 3> to_rgb {};
};

/// Checks the stock (one or three layers, an invertible sensitivity
/// matrix) and takes its curves (expected_curves, stock order).
Status make_regrain_model(const Stock& stock, std::vector<ExpectedCurve> curves,
                          RegrainModel& out);

/// One pixel: rgb_in (scene-linear, 3 floats), its layers' densities
/// (nlayers floats) -> rgb_out (3 floats, may alias rgb_in). A non-finite
/// input or density leaves rgb_out = rgb_in.
void regrain_pixel(const RegrainModel& model, const float* rgb_in, const float* density,
                   float* rgb_out);

/// The layer's exposure value v = dot(sensitivity, rgb) as the core reads it
/// (MODEL.md 2): 0 when not finite or negative.
double layer_value(const std::array<double, 3>& sensitivity, const float* rgb);

}  // namespace filmgrain
