// filmgrain: what the model predicts for a uniformly exposed layer,
// computed without rendering (MODEL.md 1-5 and 8): development resolved by
// grain size, the Boolean model of overlapping opaque discs (mean
// transmittance, covariance), the variance of a densitometer aperture, and
// the classical low-density laws (Nutting, Siedentopf).
#pragma once

#include <cstdint>
#include <vector>

#include "model/dye.h"
#include "filmgrain/stock.h"
#include "filmgrain/status.h"

namespace filmgrain {

struct PixelPopulation;

/// One node of the diameter quadrature: a diameter, its probability weight
/// and the probability that a grain of that diameter develops.
struct DevelopedSize {
    double diameter_um         = 0.0;
    double weight              = 0.0;  ///< quadrature weight (sums to 1)
    double develop_probability = 0.0;  ///< P(develop | d), fog included
};

/// Development of one population under a uniform exposure, resolved by
/// grain size: P(develop | d) = sum over N of Poisson(N; q 4.09e3 H pi d^2/4)
/// P(develop | N), with P(develop | N) from independent runs of the exact
/// latent-image chain (expectations.h: DevelopGivenPhotons).
struct PopulationDevelopment {
    double grains_per_um2 = 0.0;
    std::vector<DevelopedSize> nodes;
    double develop_fraction   = 0.0;  ///< E[P]
    double area_developed_um2 = 0.0;  ///< E[a P]
    double area2_developed_um4 = 0.0; ///< E[a^2 P]
    /// Monte Carlo standard error of E[a P] (from the P(develop | N) runs).
    double area_developed_se_um2 = 0.0;
    /// A coupler-limited population's image (core/src/model/dye.h FilledImage;
    /// opacity 0: its images add).
    FilledImage filled;
};

/// Size-resolved development of `pop` at exposure `exposure_lxs` (the
/// exposure the layer receives) and shutter `shutter_s`, with the stock's
/// development. max_samples: chain runs for the most important photon
/// counts (others get runs in proportion to their weight, at least
/// min_samples).
/// Requires rate_area_exponent = 0 (P(develop | N) then does not depend on
/// the grain size); otherwise an error. Deterministic given `seed`.
Status develop_by_size(const Stock& stock, const Population& pop, double exposure_lxs,
                       double shutter_s, int max_samples, uint64_t seed,
                       PopulationDevelopment& out, int min_samples = 16);

/// The Boolean model of one layer (MODEL.md 5 and 8): developed grains are
/// a Poisson process of images, opaque discs (silver) or dye clouds. With
/// B = sum over populations of n E[P(d) b(d/2)] and K(h) = sum of
/// n E[P(d) k(d/2, h)] (b, k: ImageOverlap, core/src/model/dye.h; for silver
/// the disc area and the lens, the overlap area of two discs of radius r
/// whose centres are h apart, so B = K(0)), the mean transmittance is
/// T = exp(-B) and the covariance of the point transmittance at distance h
/// is C(h) = T^2 (exp(K(h)) - 1). K is tabulated on a fine grid of h.
/// Coupler-limited populations (FilledImage) are not in B and K: each keeps
/// its cloud cover m and shared cover s(h), and multiplies T by
/// FilledImage::mean(m) and 1 + C(h) / T^2 by exp(log_pair_ratio).
/// Thread safety: const, shareable.
class BooleanLayer {
public:
    BooleanLayer() = default;
    explicit BooleanLayer(const std::vector<PopulationDevelopment>& populations,
                          const ImageOverlap& image = ImageOverlap(), double h_step_um = 0.02);

    /// B = sum n E[b P] over the populations whose images add (silver:
    /// sum n E[a P] = K(0)): without coupler-limited populations the
    /// density is 0.434 B (Nutting, exact in the mean for overlapping discs).
    double coverage() const { return m_blocking; }
    /// T = exp(-B) times each coupler-limited population's mean.
    double mean_transmittance() const;
    /// Net density predicted for the layer, -log10(T).
    double net_density() const;
    /// Developed grains per square micrometre, sum n E[P].
    double developed_per_um2() const { return m_developed_per_um2; }
    /// Mean area of a developed grain, sum n E[a P] / sum n E[P].
    double mean_developed_area_um2() const;
    /// K(h), linear interpolation of the table; 0 beyond range_um().
    double overlap(double h_um) const;
    /// C(h) = T^2 (exp(K(h)) - 1).
    double covariance(double h_um) const;
    /// Distance beyond which K(h) is below 1e-9 K(0) (treated as 0).
    double range_um() const { return m_range_um; }

private:
    std::vector<double> m_k;  ///< K at h = i * m_step_um
    double m_step_um           = 0.02;
    double m_range_um          = 0.0;
    double m_developed_per_um2 = 0.0;
    double m_area_developed    = 0.0;
    double m_blocking          = 0.0;  ///< B
    struct Filled {
        FilledImage image;
        double cover = 0.0;       ///< m
        std::vector<double> k;    ///< s(h) at h = i * m_step_um
    };
    std::vector<Filled> m_filled;
};

/// The Boolean layer of `stock.layers[layer]` for a neutral exposure
/// `exposure_lxs` (the layer receives sum(sensitivity) times it), composed
/// from develop_by_size of each of its populations.
Status predict_layer(const Stock& stock, size_t layer, double exposure_lxs, double shutter_s,
                     int max_samples, uint64_t seed, BooleanLayer& out, int min_samples = 16);

/// The Boolean layer of one layer at exposure value v, from the pieces the
/// core's expected curve is made of (core/src/expect/expected_curve_model.h:
/// LayerModel::populations()): the one size quadrature (size_quadrature,
/// |z| <= 9) and P(develop | mean photons) of the tabulated chain
/// (pixel_develop_probability). No chain runs: for evaluating many
/// exposures and stocks against tables built once (filmgrain-fit). Its
/// coverage() is coverage_exponent(populations, v) term for term.
/// `develop_factor` scales every P(develop) (MODEL.md 10's inhibition on a
/// uniform patch: exp(-log_factor)).
BooleanLayer boolean_layer_at(const std::vector<PixelPopulation>& populations, double value,
                              const ImageOverlap& image = ImageOverlap(),
                              double develop_factor = 1.0, double h_step_um = 0.02);

/// log10 of the neutral exposure at which the predicted net density of
/// `layer` (fog included, base excluded) equals `net_density`: steps of 0.5
/// from `log10_h_guess` until bracketed, then bisection to 0.002, with
/// cheap predictions (50 chain runs for the heaviest count, 2 at least). An error if the target
/// is not reached within 6 decades of the guess.
Status exposure_for_predicted_density(const Stock& stock, size_t layer, double net_density,
                                      double shutter_s, double log10_h_guess, double& log10_h);

/// A measuring aperture sampled on the scan's pixel grid: weight of pixel
/// (i, j) relative to the aperture centre's pixel = area of the pixel
/// inside the aperture / pixel area (exact, so the weights sum to the
/// aperture area in pixels). The centre lies on a pixel centre.
struct ApertureTemplate {
    double diameter_um = 0.0;
    double pitch_um    = 0.0;
    int radius_px      = 0;  ///< weights cover [-radius_px, radius_px]^2
    std::vector<double> weights;  ///< (2 radius_px + 1)^2, row-major
    /// Sum of the weights times pixel area: the aperture area, um^2.
    double area_um2() const;
    double weight(int dx, int dy) const
    {
        const int side = 2 * radius_px + 1;
        return weights[static_cast<size_t>((dy + radius_px) * side + (dx + radius_px))];
    }
};

/// The circular aperture of `diameter_um` on a grid of `pitch_um` pixels.
ApertureTemplate make_circular_aperture(double diameter_um, double pitch_um);

/// Variance of the aperture's mean transmittance under the Boolean model:
/// Var = (1/W^2) sum over pixel lags L of R(L) Cpix(L), where R is the
/// discrete autocorrelation of the weights, W their sum (pixel units) and
/// Cpix(L) = (1/p^4) integral of C(h) (p - |h_x - L_x p|)(p - |h_y - L_y p|)
/// over the square where both are positive: the exact covariance of two
/// pixel means L apart. This is the exact variance of the estimator the
/// densitometer uses (pixel-grid aperture), not of an ideal disc.
double aperture_transmittance_variance(const BooleanLayer& layer,
                                       const ApertureTemplate& aperture);

/// Variance of the mean transmittance through an ideal circular aperture
/// of `diameter_um` (a densitometer's, not sampled on pixels) under the
/// Boolean model: Var = (1/A^2) integral of C(|h|) g(|h|) d^2h, with
/// g(h) = lens_area_um2(R, h) the aperture's set covariance (the area it
/// shares with itself shifted by h) and A = pi R^2; radial midpoint rule
/// on the layer's own h grid out to range_um(). Exact for any grain size.
double disc_aperture_transmittance_variance(const BooleanLayer& layer, double diameter_um);

/// Variance of the mean transmittance of a square of side_px x side_px
/// pixels of side pitch_um under the Boolean model (uniform weights; same
/// method as aperture_transmittance_variance): what a patch's macro
/// density reading scatters by, known before rendering.
double square_transmittance_variance(const BooleanLayer& layer, int64_t side_px, double pitch_um);

/// Siedentopf's low-density granularity: sigma_D^2 = 0.434 a D / A, with a
/// the mean developed grain area (um^2), D the density the grains make and
/// A the aperture area (um^2). Returns sigma_D.
double siedentopf_sigma_density(double mean_grain_area_um2, double net_density,
                                double aperture_area_um2);

/// Area of the intersection of two discs of radius r_um whose centres are
/// h_um apart (the "lens"), um^2: the core's (dye.h).
using filmgrain::lens_area_um2;

}  // namespace filmgrain
