// filmgrain: MODEL.md section 5 at pixel scale: the Boolean model's pixel
// statistics, for grains far below the pixel.
//
// Where every pixel holds many developed grains, the positions of single
// grains are invisible: only each pixel's transmittance and its correlation
// with its neighbours are. For a uniformly exposed region the developed
// discs of a layer are a Boolean model (independent populations, each a
// Poisson field thinned by P(develop | lambda)), whose point transmittance
// has mean  mu = exp(-sum_p n_p E[a P])  and covariance at distance h
//   C(h) = mu^2 (exp(sum_p n_p E[P K(h; r)]) - 1),
// K(h; r) the area shared by two discs of radius r at distance h. A pixel's
// transmittance (its mean over the pixel) then has mean mu, variance
//   V = (1/A^2) int C(|h|) (px - |hx|)(py - |hy|) d^2h
// and covariance with its horizontal, vertical and diagonal neighbours from
// the same integral with the shifted overlap. PixelModel tabulates these over
// the exposure value v, and the pixel kernel draws each pixel from a Gamma
// law with that mean and variance (skewed_draw) through a Gaussian copula:
// the normal (k * z), z i.i.d. standard normals keyed by absolute pixel
// (deterministic for any tiling), k a separable 3x3 kernel with the model's
// neighbour correlations. Exact in mean and variance; the shape and the
// copula's correlation are approximations, measured against the per-grain
// kernel in docs/performance; the planner uses it only where grains are
// many per pixel.
#pragma once

#include <cstdint>
#include <vector>

#include "develop_curve.h"
#include "dye.h"
#include "geometry.h"
#include "filmgrain/stock.h"

namespace filmgrain {

/// One population as the pixel model sees it.
struct PixelPopulation {
    const Population* population = nullptr;
    /// Its grain process (the disc radius at each size quantile).
    const PopulationGrains* grains = nullptr;
    /// Mean absorbed photons per (value x square micrometre).
    double photons_per_value_um2 = 0.0;
    /// P(develop | mean photons) and its table (for means beyond the curve).
    const DevelopCurve* curve = nullptr;
    const DevelopTable* table = nullptr;
};

/// P(develop | mean photons) over every mean, as the pixel model uses it:
/// the curve where it reaches, beyond it the table at the mean (the Poisson
/// spread is small there and P(N) flat: the shoulder), beyond the table its
/// last node.
double pixel_develop_probability(const PixelPopulation& p, double lambda);

/// The grain sizes of a population as every pixel-scale integral takes
/// them: trapezoid nodes z (the normal score of ln d) on [-9, 9], step
/// 1/8, weights phi(z) dz (the mass beyond is 2e-19, left out). Not
/// narrower: in the toe P(develop) grows like a^4, so the largest grains
/// carry E[a P] (a cut at |z| = 4 lost 1.1% of the paper stock's net
/// density at -6 stops). A population without spread: z = 0, weight 1.
inline constexpr double kSizeQuadratureZ = 9.0;
struct SizeNode {
    double z      = 0.0;
    double weight = 0.0;
};
const std::vector<SizeNode>& size_quadrature(const Population& population);

/// The Boolean model's coverage exponent of a layer at exposure value v
/// (MODEL.md 5): sum over populations of grains_per_um2 E[a P(develop |
/// lambda(a))], over size_quadrature. A uniform patch's expected
/// transmittance is exp(-coverage_exponent).
double coverage_exponent(const std::vector<PixelPopulation>& populations, double v);

class PixelModel {
public:
    struct Moments {
        double mean = 0.0;      ///< mu: mean transmittance
        double variance = 0.0;  ///< V: variance of a pixel's transmittance
        double rho_x = 0.0;     ///< correlation with the horizontal neighbour
        double rho_y = 0.0;     ///< with the vertical neighbour
        double rho_xy = 0.0;    ///< with a diagonal neighbour
        double developed_per_pixel = 0.0;  ///< expected developed grain centres
    };

    /// Tabulates the moments of one layer's pixels (pitch px x py um) over
    /// exposure values: v = 0, then 16 nodes per octave from 2^-16 to 2^12
    /// times grey (0.18); a property of the scene, never of the pixels.
    /// `image`: what each developed grain leaves (MODEL.md 5 or 8): with
    /// b and k its blocking area and overlap, mu = exp(-sum n E[P b]) and
    /// C(h) = mu^2 (exp(sum n E[P k(h)]) - 1) (for silver, the disc area and
    /// the lens K above).
    /// `max_log_factor` > 0: the layer is inhibited (MODEL.md 10: every P
    /// times exp(-log_factor)), and the table gains a second axis, the log
    /// factor, from 0 to max_log_factor in steps of kLogFactorStep.
    PixelModel(const std::vector<PixelPopulation>& populations, double px_um, double py_um,
               const ImageOverlap& image = ImageOverlap(), double max_log_factor = 0.0);

    /// Step of the log-factor axis: the thinning exp(-L) is interpolated
    /// linearly between nodes 0.05 apart (relative error <= 3e-4, measured
    /// with the rest in max_mean_error and max_sd_error).
    static constexpr double kLogFactorStep = 0.05;

    /// Moments at exposure value v (linear interpolation in log v; v beyond
    /// the table: its last node) and log factor L (linear in L, clamped to
    /// the table's range; 0 for a layer without inhibition).
    Moments at(double v, double log_factor = 0.0) const;

    /// Moments computed directly (no table): for tests and the table.
    static Moments compute(const std::vector<PixelPopulation>& populations, double px_um,
                           double py_um, double v, const ImageOverlap& image = ImageOverlap(),
                           double log_factor = 0.0);

    /// Largest relative error of the table's interpolation found at node
    /// midpoints (in v, and in L at every v node), in the mean and in the
    /// standard deviation.
    double max_mean_error() const { return m_max_mean_error; }
    double max_sd_error() const { return m_max_sd_error; }

private:
    Moments row_at(const std::vector<Moments>& row, double v) const;

    double m_log_v0 = 0.0, m_inv_step = 0.0;
    /// One row of exposure nodes (node 0: v = 0) per log-factor node.
    std::vector<std::vector<Moments>> m_rows;
    double m_max_mean_error = 0.0, m_max_sd_error = 0.0;
};

/// The weights [beta, 1, beta] / sqrt(1 + 2 beta^2) of a 3-tap moving
/// average whose neighbour correlation is rho (|rho| <= 1/sqrt(2); larger
/// values are clamped there).
void moving_average_taps(double rho, double taps[3]);

/// A pixel's transmittance from its mean and variance and its normal z:
/// Gamma distributed in its covered part where the mean is at least 1/2,
/// in its open part below (Wilson-Hilferty), in [0, 1].
double skewed_draw(double mean, double variance, double z);

/// Writes the transmittance of the pixels [x0, x1) x [y0, y1) of one layer,
/// row-major into `transmittance`, given each pixel's exposure value in `v`
/// and (inhibited layers; else null) its log factor in `log_factor` (same
/// layout). Normals are keyed by (key, absolute pixel), so any tiling gives
/// the same values.
void sample_pixel_transmittance(const PixelModel& model, uint64_t key, int64_t x0, int64_t y0,
                                int64_t x1, int64_t y1, const double* v,
                                const double* log_factor, double* transmittance);

}  // namespace filmgrain
