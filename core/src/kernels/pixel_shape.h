// filmgrain: MODEL.md sections 5 and 8 at pixel scale where few developed
// grains fall in a pixel: the shape of a pixel's transmittance law, sampled
// from the model itself.
//
// PixelModel's moments fix a pixel's mean and variance exactly; where a
// pixel holds many developed grains a two-moment law (skewed_draw) is
// close enough, but where it holds a few (a sparse dye layer in fine
// pixels: VISION3 500T's blue in 3 um pixels) the shape of the law decides
// the spread of pixel densities (D = -log10 T weighs the dense tail), and
// no two-moment family gets it right there (docs/performance: 1.3-2.3x the
// grains' spread of D). So the shape is sampled: the developed grains of a
// uniformly exposed window of kShapeWindow^2 pixels, drawn as the model
// has them (per population a Poisson field of grains of the lognormal
// sizes, each kept with P(develop | mean photons) exp(-log factor): the
// pixel model's own thinning), imaged as the per-grain render images them
// (dye_transmittance), give the empirical quantile function of a pixel's
// transmittance; standardised, it is the law's shape S(z) at standard
// normal scores z, and a pixel is drawn as mean + sd S(z) with the
// moments' exact mean and variance and the copula's correlated normal z.
// Deterministic: each shape's grains are keyed by the node it samples.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace filmgrain {

struct Layer;
struct PixelPopulation;

/// The standard normal scores a shape is kept at: -kShapeZMax to
/// kShapeZMax in kShapeNodes steps (linear between, the end values
/// beyond: a window's extreme order statistics).
inline constexpr int kShapeNodes     = 33;
inline constexpr double kShapeZMax   = 4.0;
inline constexpr double kShapeZStep  = 2.0 * kShapeZMax / (kShapeNodes - 1);
/// S(z_j) = (Q(Phi(z_j)) - mean) / sd, Q the quantile function of a
/// pixel's transmittance; standardised so that S(Z), Z standard normal and
/// S linear between nodes, has mean 0 and variance 1 exactly.
using PixelShape = std::array<double, kShapeNodes>;

/// Pixels a side of the window a shape is sampled on (4096 pixels: a
/// quantile's standard error about 0.03 sd at the 5% and 95% points).
inline constexpr int kShapeWindow = 64;
/// Grain sizes drawn: size nodes within this many standard deviations of
/// ln d (the count beyond is 7e-6 of the grains; it bounds the window's
/// margin).
inline constexpr double kShapeSizeZ = 4.5;

/// Whether a layer's pixel law can be sampled: a dye layer (MODEL.md 8;
/// silver layers keep the two-moment law).
bool can_sample_pixel_shape(const Layer& layer);

/// The window's own mean and variance of a pixel's transmittance (what
/// the shape was standardised from; tests hold them to the moments).
struct ShapeWindow {
    double mean = 0.0, variance = 0.0;
};

/// The sampled shape of one layer's pixel law at exposure value v and log
/// factor L (px x py um pixels, the dye image on `samples` rows or points a
/// pixel as the per-grain render takes it, the density clamp max_density),
/// its grains keyed by `key`. A window whose pixels all have one value
/// (nothing developed, or all of it covered) gives S = 0. `window`, where
/// given, receives the window's mean and variance.
PixelShape sample_pixel_shape(const std::vector<PixelPopulation>& populations,
                              const Layer& layer, double px_um, double py_um, int samples,
                              double max_density, double v, double log_factor, uint64_t key,
                              ShapeWindow* window = nullptr);

/// S(z): linear between nodes, the end values beyond.
double shape_value(const PixelShape& shape, double z);

/// Rescales `shape` so that S(Z) has mean 0 and variance 1 (quadrature on
/// steps of 1/32 over |z| <= 8); a shape without variance becomes 0.
void standardise_shape(PixelShape& shape);

/// The correlation two standard normals need for their shaped draws
/// S(Z1), S(Z2) to have correlation `rho` in [0, 1]: with S = sum c_k He_k
/// (Hermite coefficients to the sixth, by the same quadrature) the draws'
/// correlation at normal correlation r is sum k! c_k^2 r^k / sum k! c_k^2,
/// solved for r (bisection).
double shape_normal_correlation(const PixelShape& shape, double rho);

}  // namespace filmgrain
