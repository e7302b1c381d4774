// filmgrain: MODEL.md section 8, dye layers: each developed grain leaves a
// cloud of dye whose density adds to its neighbours' (Beer-Lambert), instead
// of an opaque disc.
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "filmgrain/stock.h"
#include "model/image_formation.h"

namespace filmgrain {

/// Where a gaussian cloud is cut off, in cloud radii: its density there is
/// exp(-2 * 3^2) = 1.5e-8 of its peak (the error this adds to a pixel's
/// density is below 1.5e-8 * cloud_density per overlapping cloud).
inline constexpr double kGaussianCloudReach = 3.0;

/// How far a developed grain's image reaches, in grain radii: 1 for silver
/// (the disc), cloud_diameter_ratio for disc clouds, kGaussianCloudReach
/// times that for gaussian ones.
double image_reach_factor(const Layer& layer);

/// The area a developed grain of area a blocks in the Boolean model, over a:
/// a uniformly exposed patch has E[T] = exp(-sum over populations of
/// grains_per_um2 E[a P] * factor) (MODEL.md 5 and 8). 1 for silver; for
/// dye, integral over the plane of (1 - 10^-D_1(x)) over a: disc clouds
/// ratio^2 (1 - 10^-cloud_density); gaussian clouds ratio^2 Ein(k) / 2
/// with k = cloud_density ln 10 and Ein(k) = integral_0^k (1 - e^-t) / t dt
/// (the per-point clamp at max_density is not in this expectation).
double cloud_area_factor(const Layer& layer);

/// A coupler-limited population's image (Population::max_dye_density,
/// docs/model.md): the union of its developed grains' cloud discs, of
/// density max_dye_density wherever one lies. A Boolean model of discs of
/// radius cloud_diameter_ratio times the grain's, with opacity
/// o = 1 - 10^-max_dye_density; over a uniformly exposed patch, with m the
/// mean number of its clouds over a point and s(h) the mean number over
/// both of two points h apart (the silver disc statistics at the cloud's
/// radius: n E[P pi R^2] and n E[P lens(R, h)]), and q = e^-m:
///   E[T_p] = 1 - o (1 - q),
///   E[T_p(x) T_p(x + h)] - E[T_p]^2 = o^2 q^2 (e^s(h) - 1).
/// The populations of a layer are independent, so the layer's mean and
/// two-point moment are the products of its populations'.
struct FilledImage {
    double opacity    = 0.0;  ///< o
    double area_ratio = 1.0;  ///< cloud area over grain area: cloud_diameter_ratio^2

    /// E[T_p] at cloud cover m.
    double mean(double m) const { return 1.0 + opacity * std::expm1(-m); }
    /// ln(E[T_p(x) T_p(x + h)] / E[T_p]^2) at cloud cover m and shared
    /// cover s; `expm1_s` is e^s - 1 (the caller's, computed once).
    double log_pair_ratio(double m, double expm1_s) const
    {
        const double oq = opacity * std::exp(-m), t = mean(m);
        return std::log1p(oq * oq * expm1_s / (t * t));
    }
};

/// The population's FilledImage; its opacity is 0 (and the population's
/// clouds add, MODEL.md 8) unless it is coupler-limited.
FilledImage filled_image(double cloud_diameter_ratio, const Population& pop);

/// The mean transmittance of a uniformly exposed patch of a layer (MODEL.md
/// 5 and 8, with coupler-limited populations: FilledImage) from each
/// population's grain cover n E[P a] (a the grain's area: the population's
/// term of coverage_exponent), in the layer's population order: the
/// populations whose images add block cloud_area_factor times their cover
/// together, exp(-factor sum cover); each coupler-limited one multiplies
/// that by FilledImage::mean(ratio^2 cover). The one implementation of
/// this expectation (expected curves and the pixel scale's mean).
/// A coupler-limited population moves -ln E[T] by o ratio^2 q / E[T_p] <=
/// o ratio^2 <= cloud_area_factor per unit of cover, so error bounds that
/// scale a cover error by cloud_area_factor hold for it too.
double layer_mean_transmittance(const Layer& layer, const std::vector<double>& cover);

/// Whether any population of the layer is coupler-limited.
bool has_coupler_limit(const Layer& layer);

/// The second-order statistics of one developed grain's image, for the
/// Boolean model of a uniformly exposed layer (MODEL.md 5 and 8). With
/// a_r(x) = 10^-D_1(x) the transmittance of one grain's image (0 inside a
/// silver disc), a grain of radius r blocks b(r) = integral (1 - a_r(x)) dx
/// and two points h apart share k(r, h) = integral (1 - a_r(x))
/// (1 - a_r(x + h)) dx, so that a Poisson field of them (n per um^2,
/// developing with P) has E[T] = exp(-n E[P b]) and Cov(T(x), T(x + h)) =
/// E[T]^2 (exp(n E[P k(h)]) - 1). Silver: b = pi r^2, k = the lens area.
/// Disc clouds of radius R = ratio r: (1 - 10^-c) and (1 - 10^-c)^2 times
/// the silver values at R. Gaussian clouds: R^2 times a function of h / R,
/// the autocorrelation of 1 - 10^(-c exp(-2 t^2)) (cut at 3 R as the
/// render cuts it) summed on a grid of step R / 32 once per cloud density
/// (shared by every instance: a few milliseconds, then a lookup) and
/// interpolated linearly. The per-point clamp at max_density is not in
/// these statistics (as in cloud_area_factor). Thread safety: const.
class ImageOverlap {
public:
    /// Opaque silver discs.
    ImageOverlap() = default;
    explicit ImageOverlap(const Layer& layer);

    /// b(r), square micrometres: pi r^2 cloud_area_factor.
    double blocking_um2(double r_um) const;
    /// For a coupler-limited population (FilledImage): the overlap of two
    /// of its cloud discs h apart, lens(R, h) at R = cloud_diameter_ratio r.
    double cloud_lens_um2(double r_um, double h_um) const;
    /// The FilledImage of one of the layer's populations.
    FilledImage filled(const Population& pop) const;
    /// k(r, h), square micrometres; k(r, 0) <= b(r), equal for silver.
    double overlap_um2(double r_um, double h_um) const;
    /// The distance from which k(r, h) is 0: twice the image's reach.
    double overlap_range_um(double r_um) const;
    /// The distance beyond which k(r, h) stays below 1e-3 of k(r, 0): how
    /// far one grain's image correlates pixels (the pixel scale's cheap
    /// check before it tabulates a layer's correlations). Silver and disc
    /// clouds: overlap_range_um (k reaches 0 there); gaussian clouds 2.6
    /// cloud radii when faint (k falls like exp(-(h / R)^2)) to 3.2 at
    /// density 5, well inside their 6-radius overlap range.
    double correlation_range_um(double r_um) const;

private:
    LayerImage m_image     = LayerImage::silver;
    CloudProfile m_profile = CloudProfile::disc;
    double m_ratio         = 1.0;
    double m_area_factor   = 1.0;  ///< cloud_area_factor
    double m_disc_factor   = 1.0;  ///< (1 - 10^-c)^2 for disc clouds
    /// Gaussian clouds: k at h = i R / kGaussianOverlapSteps, over R^2.
    std::shared_ptr<const std::vector<double>> m_gaussian;
    /// Gaussian clouds: correlation_range_um over the cloud radius.
    double m_gaussian_correlation_radii = 0.0;
};

/// Scratch space for dye_transmittance, reused between calls.
struct DyeScratch {
    std::vector<size_t> offsets, fill, members;
    std::vector<uint8_t> population;  ///< each grain's, for coupler limits
    std::vector<int64_t> density;  ///< fixed point, 2^-32 density units
    std::vector<std::pair<double, int>> enters, leaves;
    std::vector<size_t> by_x;  ///< a pixel row's clouds, by centre
    /// Per sample row of a pixel row: the clouds it crosses, by centre.
    std::vector<std::vector<size_t>> crossing;
    std::vector<std::pair<uint64_t, double>> memo;  ///< coupler-limited transmittances
    std::vector<double> level, factor;
};

/// MODEL.md 8's image of a dye layer: the mean of 10^-min(D(x), max_density)
/// over each pixel of the block [x0, x1) x [y0, y1) (px x py micrometre
/// pixels), D(x) the sum of the clouds of the developed grains `grains`
/// (their centres and grain radii). Disc clouds: exact along `samples`
/// rows per pixel (D is a whole number of clouds between chord ends), the
/// midpoint rule across them. Gaussian clouds: sampled at `samples` x
/// `samples` points per pixel (the centres of its sub-pixels), densities
/// summed in fixed point (2^-32 units, each cloud's share rounded once) so
/// that the sum does not depend on the grains' order. Either way the result
/// depends only on the grains and absolute pixel coordinates: the same for
/// any tiling. Grains whose cloud does not reach the block may be passed.
/// `population_end[p]`: one past the index in `grains` of population p's
/// last grain (the grains in population order); read only when a
/// population is coupler-limited (disc clouds: D counts each such
/// population's covering clouds as max_dye_density if any, FilledImage).
/// Writes (x1-x0)*(y1-y0) transmittances row-major. `samples`: [1, 256].
void dye_transmittance(const std::vector<Disc>& grains, const std::vector<size_t>& population_end,
                       const Layer& layer, double max_density, int64_t x0, int64_t y0,
                       int64_t x1, int64_t y1, double px_um, double py_um, int samples,
                       DyeScratch& scratch, double* transmittance);

}  // namespace filmgrain
