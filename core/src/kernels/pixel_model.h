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
// transmittance (its mean over the pixel) then has mean mu, and covariance
// with the pixel (i, j) away
//   Cov(i, j) = (1/A^2) int C(|h|) T_x(h_x - i px) T_y(h_y - j py) d^2h,
// T_x(t) = max(0, px - |t|) the overlap of two pixel rows t apart; V =
// Cov(0, 0). PixelModel tabulates these over the exposure value v, to
// kMaxLag pixels each way, and the pixel kernel draws each pixel from a
// skewed law (two Gamma laws, skewed_draw) with that mean and variance
// through a Gaussian copula:
// the normal (f * z), z i.i.d. standard normals keyed by absolute pixel
// (deterministic for any tiling), f the symmetric filter whose
// autocorrelation is the normals' correlation that skewed_draw turns into
// the model's (copula_normal_correlation, copula_filter); or, for a layer
// whose pixels hold few developed grains, from the law's shape sampled
// from the model (pixel_shape.h). Exact in mean and variance; the shape
// and the correlations beyond the lags kept are approximations, measured
// (the second by the model itself, the first against the per-grain kernel
// in docs/performance); the planner uses the two-moment law only where
// grains are many per pixel, the sampled one where a pixel's exposure
// develops enough of them.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "expect/develop_curve.h"
#include "model/dye.h"
#include "model/geometry.h"
#include "expect/grain_counts.h"
#include "filmgrain/stock.h"
#include "kernels/pixel_shape.h"

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

/// Calls f(node, r_um, a_um2, probability) for every node of the
/// population's size_quadrature at exposure value v: the disc's radius and
/// area there and pixel_develop_probability at its mean photons. The one
/// walk over sizes of the pixel scale's integrals and samples.
template <typename F>
void for_each_size_probability(const PixelPopulation& pp, double v, F&& f)
{
    for (const SizeNode& node : size_quadrature(*pp.population)) {
        const double r_um  = pp.grains->radius_at_z_um(node.z);
        const double a_um2 = M_PI * r_um * r_um;
        f(node, r_um, a_um2,
          pixel_develop_probability(pp, pp.photons_per_value_um2 * v * a_um2));
    }
}

/// size_quadrature (grain_counts.h): the size nodes of every pixel-scale
/// integral.

/// One population's grain cover at exposure value v (MODEL.md 5):
/// grains_per_um2 E[a P(develop | lambda(a))], over size_quadrature.
double population_cover(const PixelPopulation& population, double v);

/// The Boolean model's coverage exponent of a layer at exposure value v:
/// the sum of its populations' population_cover. A uniform patch of silver
/// has expected transmittance exp(-coverage_exponent); of any layer,
/// layer_mean_transmittance (dye.h) of the populations' covers.
double coverage_exponent(const std::vector<PixelPopulation>& populations, double v);

/// Each population's population_cover at v, in order.
std::vector<double> population_covers(const std::vector<PixelPopulation>& populations, double v);

/// The largest lag (in pixels, each axis) whose correlation the pixel scale
/// keeps: a layer whose correlations reach further (grains or clouds larger
/// than about a pixel, more than 1% of the correlation summed over all lags
/// beyond it) is not drawn at pixel scale.
inline constexpr int kMaxLag = 4;
/// Lags (i, j) with 0 <= i, j <= kMaxLag, stored at [j * (kMaxLag + 1) + i]:
/// the pixel field is symmetric in each axis, so these are all of them.
inline constexpr int kLagSide  = kMaxLag + 1;
inline constexpr int kLagCount = kLagSide * kLagSide;
using LagArray = std::array<double, kLagCount>;

/// The lags of the copula filter for a correlation kept to `lags`: one more
/// (a cut square root of a spectrum has tails; one lag more cuts its
/// correlation error about tenfold), at most kMaxLag.
inline int filter_lags(int lags) { return lags < kMaxLag ? lags + 1 : kMaxLag; }

/// The symmetric filter f on lags |i|, |j| <= filter_lags(lags)
/// (quarter-stored like LagArray, sum of f^2 over all its taps 1) whose
/// autocorrelation is the correlation `rho` (LagArray) on lags |i|, |j| <=
/// `lags` and 0 beyond: the spectral square root on a 32x32 periodic grid
/// (negative power clamped to 0), cut to its support. Returns the largest
/// difference between the cut filter's autocorrelation and `rho` (beyond
/// `lags`: `rho` where it has the lag, else 0) at any lag it reaches.
double copula_filter(const LagArray& rho, int lags, LagArray& f);

class PixelModel {
public:
    struct Moments {
        double mean = 0.0;      ///< mu: mean transmittance
        double variance = 0.0;  ///< V: variance of a pixel's transmittance
        /// Correlation with the pixel (i, j) away (LagArray; [0] = 1).
        LagArray correlation {};
        /// The correlation summed over every lag (all signs, to infinity):
        /// the integral of C over the plane / (A V); a large aperture's
        /// variance is about V times this.
        double correlation_sum = 0.0;
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
    /// The lags kept (lags()) are the fewest that leave at most
    /// kDroppedCorrelation of correlation_sum out at every node. Nodes are
    /// computed on `nthreads` threads (0: all; the table is the same for
    /// any count). `max_density`: the stock's clamp of -log10 T (MODEL.md
    /// 5); the interpolation errors count only where it does not clamp
    /// (the table itself is the same whatever it is).
    /// `shape`: where given, the law's shape is sampled (pixel_shape.h)
    /// for that layer, its dye image on `samples` rows or points a pixel,
    /// at every kShapeStride-th exposure node of every kShapeRowStride-th
    /// log-factor row (a node whose mean and variance lie within
    /// kShapeReuse of the last sampled node's in its row takes that
    /// node's shape), and interpolated between: pixels are then drawn as
    /// mean + sd S(z) instead of skewed_draw.
    struct ShapeSampling {
        const Layer* layer = nullptr;
        int samples        = 0;
    };
    PixelModel(const std::vector<PixelPopulation>& populations, double px_um, double py_um,
               const ImageOverlap& image = ImageOverlap(), double max_log_factor = 0.0,
               int nthreads = 1,
               double max_density = std::numeric_limits<double>::infinity(),
               const ShapeSampling* shape = nullptr);
    /// Exposure nodes (16 an octave) between sampled shapes: 2 an octave.
    static constexpr int kShapeStride = 8;
    /// Log-factor rows between sampled shapes: every 0.25.
    static constexpr int kShapeRowStride = 5;
    /// Relative change of mean and variance below which a node reuses the
    /// last sampled shape of its row (the toe below fog, the shoulder).
    static constexpr double kShapeReuse = 0.01;
    /// Whether the law's shape is sampled (else skewed_draw's).
    bool shaped() const { return !m_shapes.empty(); }
    /// Shapes sampled (not reused) when the model was built.
    int shapes_sampled() const { return m_shapes_sampled; }

    /// Step of the log-factor axis: the thinning exp(-L) is interpolated
    /// linearly between nodes 0.05 apart (relative error <= 3e-4, measured
    /// with the rest in max_mean_error and max_sd_error).
    static constexpr double kLogFactorStep = 0.05;
    /// The share of correlation_sum the lags kept may leave out (the
    /// relative error of a large aperture's variance it allows).
    static constexpr double kDroppedCorrelation = 0.01;

    /// Moments at exposure value v (linear interpolation in log v; v beyond
    /// the table: its last node) and log factor L (linear in L, clamped to
    /// the table's range; 0 for a layer without inhibition); the mean and
    /// variance are interpolated in their logarithms.
    Moments at(double v, double log_factor = 0.0) const;
    /// at(v, log_factor).developed_per_pixel alone (per pixel: no moments).
    double developed_per_pixel_at(double v, double log_factor = 0.0) const;

    /// What the pixel kernel draws a pixel from: its mean, variance and
    /// copula filter (LagArray; taps on lags 0 to K = filter_lags(lags())
    /// each way, the rest left as they were), interpolated like at().
    struct Draw {
        double mean = 0.0, variance = 0.0;
        LagArray taps {};
        /// A shaped model's: the four nodes' shapes and their weights.
        const PixelShape* shape[4] = {};
        double shape_weight[4] = {};
    };
    template <int K>
    void draw_at(double v, double log_factor, Draw& out) const;

    /// Moments computed directly (no table): for tests and the table.
    /// `distance_nodes` > 0: the covariance integral on that many distance
    /// cells instead of the table's (tests of its convergence).
    static Moments compute(const std::vector<PixelPopulation>& populations, double px_um,
                           double py_um, double v, const ImageOverlap& image = ImageOverlap(),
                           double log_factor = 0.0, int distance_nodes = 0);

    /// Lags kept each way (0 to kMaxLag), or -1 where even kMaxLag leaves
    /// more than kDroppedCorrelation out (the pixel scale cannot draw it).
    int lags() const { return m_lags; }
    /// Largest share of correlation_sum the lags kept leave out, at the
    /// worst node (with lags() = -1: at kMaxLag).
    double max_dropped_correlation() const { return m_max_dropped; }
    /// Largest error of the copula filters' correlation (copula_filter) at
    /// any node.
    double max_copula_error() const { return m_max_copula_error; }

    /// Largest relative error of the table's interpolation found at node
    /// midpoints (in v, and in L at every v node), in the mean and in the
    /// standard deviation; the mean's as |ln| of the ratio of the two means,
    /// each first raised to the density clamp's floor 10^-max_density (a
    /// mean below it is drawn as clamped pixels: its error does not show),
    /// and midpoints where both lie below the floor count no sd error.
    double max_mean_error() const { return m_max_mean_error; }
    double max_sd_error() const { return m_max_sd_error; }

    /// The whole table as bytes (this machine's representation: for the
    /// on-disk cache, read back by a build of the same code only), and a
    /// model from them, equal to the one serialized in every value; null
    /// where the bytes are not a whole model.
    std::string serialize() const;
    static std::shared_ptr<const PixelModel> deserialize(const std::string& bytes);

private:
    PixelModel() = default;

    /// A node as drawn: the logarithms of its mean and variance (the
    /// table interpolates them), its filter.
    struct Node {
        double log_mean = 0.0, log_variance = 0.0;
        LagArray taps {};
    };
    /// Where (v, L) falls in the table: rows r0, r1 (weight tr on r1),
    /// exposure nodes i0, i1 (weight ti on i1).
    struct Position {
        size_t r0 = 0, r1 = 0, i0 = 0, i1 = 0;
        double tr = 0.0, ti = 0.0;
    };
    Position position(double v, double log_factor) const;
    /// The constructor's shape sampling (ShapeSampling), its nodes
    /// computed through `each` (count, body), in parallel.
    void sample_shapes(const std::vector<PixelPopulation>& populations, double px_um,
                       double py_um, double max_density, const ShapeSampling& sampling,
                       const std::function<void(size_t, const std::function<void(size_t)>&)>& each);

    double m_log_v0 = 0.0, m_inv_step = 0.0;
    /// One row of exposure nodes (node 0: v = 0) per log-factor node.
    std::vector<std::vector<Moments>> m_rows;
    std::vector<std::vector<Node>> m_nodes;  // the same nodes, as drawn
    /// A shaped model's shape at every node (else empty).
    std::vector<std::vector<PixelShape>> m_shapes;
    int m_shapes_sampled = 0;
    int m_lags = 0;
    double m_max_dropped = 0.0, m_max_copula_error = 0.0;
    double m_max_mean_error = 0.0, m_max_sd_error = 0.0;
};

/// A pixel's transmittance from its mean and variance and its normal z, in
/// [0, 1]: (1 - mean) times a Gamma law of its open part plus mean times
/// one minus a Gamma law of its covered part (each by the Wilson-Hilferty
/// cube of z, with the pixel's mean and variance), scaled about the mean to
/// the variance: skewed like a few covering images where mostly open, like
/// a few holes where mostly covered, and continuously in between.
double skewed_draw(double mean, double variance, double z);
/// skewed_draw of n pixels: out[i] = skewed_draw(mean[i], variance[i], z[i]).
void skewed_draws(const double* mean, const double* variance, const double* z, double* out,
                  size_t n);

/// The correlation two standard normals need for their skewed_draw's (same
/// mean and variance) to have correlation `rho` in [0, 1]: skewed_draw is
/// a cubic in z (but for its clamps: a cube's root, 0 and 1), c0 + c1 He1
/// + c2 He2 + c3 He3 in Hermite polynomials, so the draws' correlation at
/// normal correlation r is (c1^2 r + 2 c2^2 r^2 + 6 c3^2 r^3) / (c1^2 +
/// 2 c2^2 + 6 c3^2), solved here for r. Skewed pixels (few grains, or few
/// holes) need r > rho: their law bends the normals' correlation down.
double copula_normal_correlation(double mean, double variance, double rho);

/// Writes the transmittance of the pixels [x0, x1) x [y0, y1) of one layer,
/// row-major into `transmittance`, given each pixel's exposure value in `v`
/// and (inhibited layers; else null) its log factor in `log_factor` (same
/// layout). Normals are keyed by (key, absolute pixel), so any tiling gives
/// the same values.
void sample_pixel_transmittance(const PixelModel& model, uint64_t key, int64_t x0, int64_t y0,
                                int64_t x1, int64_t y1, const double* v,
                                const double* log_factor, double* transmittance);

}  // namespace filmgrain
