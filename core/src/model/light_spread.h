// filmgrain: MODEL.md section 9, light spread in the film: scatter and
// halation act on a layer's exposure before photons are counted, with
// kernels in micrometres on the film.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "model/exposure.h"
#include "filmgrain/render.h"
#include "filmgrain/status.h"
#include "filmgrain/stock.h"

namespace filmgrain {

/// Weights of a kernel on the input pixel grid, for a box-reconstructed
/// input (MODEL.md 2): w[m, n] is the mean over an output pixel of the
/// kernel convolved with the input pixel (m, n) pixels away, i.e. the
/// kernel averaged against the tent of two pixel boxes. Convolving the
/// input's pixel values with them gives the exact mean of the convolved
/// exposure over every input pixel. Offsets run over [-reach, reach] in
/// both axes; normalised to sum 1 (the kernel moves light, it does not
/// make it).
struct PixelKernel {
    int64_t reach = 0;
    /// (2 reach + 1)^2 weights, row by row (n, then m), or for a separable
    /// kernel 2 reach + 1 weights of one axis.
    std::vector<double> weights;
};

/// MODEL.md 9's scatter Gaussian (standard deviation sigma_um), one axis of
/// its separable pixel weights: closed form (second differences of the
/// Gaussian's twice-integrated CDF), truncated at 6 sigma (mass beyond it
/// about 2e-9, renormalised).
PixelKernel gaussian_pixel_kernel(double sigma_um, double pitch_um);

/// MODEL.md 9's halation kernel (`disc` or `ring`, stock.h) of radius
/// radius_um: 2-D pixel weights. Cells wholly inside or outside the kernel's
/// support are exact; the others are the exact area of the kernel's shape
/// over the input pixel (disc_rect_area_um2), averaged over the output
/// pixel by an 8x8 Gauss-Legendre rule on each quarter of it, then all
/// renormalised to sum 1.
PixelKernel halation_pixel_kernel(HalationKernel kernel, double radius_um, double pitch_um);

/// The fraction of the `base` halation kernel's light beyond its reach,
/// cut off and given back to the rest by renormalising (docs/model.md,
/// "Halation from the base"). Its tail falls only as r^-2 in encircled
/// light, so the cut sets the transform's size: at 1e-2 the reach of a
/// 125 um base is 2.5 mm (remjet) or 3.3 mm (bare), 3.2x shorter than at
/// 1e-3, and what moves is 1% of the halated light (a uniform field still
/// gets exactly 1 + halation): 0.0025 of the exposure near a highlight of
/// no-remjet's red (halation 0.25), about 0.0006 D at its gamma.
inline constexpr double kBaseHalationTail = 1e-2;

/// The `base` halation kernel's radial profile (docs/model.md, "Halation
/// from the base"): light diffuse in the emulsion enters a base of
/// thickness t and refractive index n with a Lambertian distribution
/// (2 sin(theta) cos(theta) dtheta), the rear face reflects the fraction
/// R(theta) of it, and it comes back into the emulsion r = 2 t tan(theta)
/// from where it left. Then
///   K(r) = R(theta) cos^4(theta) / (4 pi t^2 Rbar),  tan(theta) = r / 2t,
///   Rbar = integral over [0, pi/2] of R(theta) 2 sin(theta) cos(theta),
/// normalised to 1 over the plane. Pure, immutable, thread-safe.
class BaseHalation {
public:
    /// thickness_um > 0, refractive_index in [1.3, 2] (Stock::validate).
    BaseHalation(double thickness_um, double refractive_index, RearFace rear_face);
    /// The stock's film base.
    explicit BaseHalation(const Stock& stock);

    /// R(theta) for light meeting the rear face at cos(theta) inside the
    /// base. `bare`: unpolarised Fresnel reflectance (mean of s and p) from
    /// n into air below the critical angle, 1 (total internal reflection)
    /// above it. `remjet`: 1 at every angle: the backing, index-matched,
    /// absorbs what crosses into it whatever the angle, so only the
    /// profile's shape is meant (the level is the layer's `halation`).
    double reflectance(double cos_theta) const;
    /// Rbar: the fraction of the light entering the base that the rear
    /// face returns (for `remjet` 1, the shape's, as above).
    double returned_fraction() const { return m_returned; }
    /// K(r), per square micrometre, untruncated (integral 1).
    double density_per_um2(double r_um) const;
    /// The same at r^2 (square micrometres): no square root beyond the
    /// critical angle.
    double density_at_r2(double r2_um2) const;
    /// The fraction of K's light beyond r (1 at r = 0, falling to 0).
    double light_beyond(double r_um) const;
    /// 2 t tan(theta_c): where total internal reflection begins, the
    /// bright ring of a bare base (infinite for remjet: no critical angle).
    double critical_radius_um() const;
    /// The radius beyond which kBaseHalationTail of K's light lies: the
    /// kernel is cut there and renormalised. Beyond the critical angle
    /// R = 1 for both faces, so light_beyond = cos^2(theta) / Rbar and
    /// reach = 2 t sqrt(1 / (kBaseHalationTail Rbar) - 1).
    double reach_um() const { return m_reach_um; }
    double thickness_um() const { return m_thickness_um; }

private:
    /// The integral of R over u = sin^2(theta) from u to u_c = 1 / n^2
    /// (bare, u < u_c), by Gauss-Legendre in v = cos(theta_t) where the
    /// integrand is smooth.
    double subcritical_integral(double u) const;

    double m_thickness_um;
    double m_n;
    RearFace m_rear_face;
    double m_returned = 1.0;
    double m_reach_um = 0.0;
    double m_inv_4t2 = 0.0;       ///< 1 / (2 t)^2, per square micrometre
    double m_norm_per_um2 = 0.0;  ///< 1 / (4 pi t^2 Rbar)
    double m_ring2_um2 = 0.0;     ///< (2 t tan(theta_c))^2; 0 for remjet
};

/// The `base` kernel's pixel weights (the same definition as above: the
/// kernel cut at reach_um(), averaged against the tent of two pixel
/// boxes), offsets up to min(reach in pixels, max_reach) (a frame of w
/// pixels needs no offset beyond w - 1 and what other kernels add).
/// Each pixel square of a quadrant is integrated once against the tent's
/// four bilinear pieces: Gauss-Legendre where K is smooth, polar
/// coordinates split at the critical circle (a kink in K) and at the cut
/// where they cross it. The weights are divided by the cut kernel's exact
/// integral, 1 - kBaseHalationTail, so they sum to 1 to the quadrature's
/// error (5e-11 at most, light_spread_test) however few offsets are kept.
/// Exactly symmetric in both axes and the diagonal. Pure, deterministic.
PixelKernel base_halation_pixel_kernel(const BaseHalation& base, double pitch_um,
                                       int64_t max_reach);

/// A layer's halation as spread_frame applies it (MODEL.md 9): its
/// fraction, its kernel and that kernel's size (disc and ring: the
/// layer's radius; base: the stock's film base).
struct HalationSpec {
    double fraction = 0.0;
    HalationKernel kernel = HalationKernel::disc;
    double radius_um = 0.0;  ///< disc and ring
    double base_thickness_um = 0.0;  ///< base, and the two below
    double base_refractive_index = 1.5;
    RearFace rear_face = RearFace::bare;

    /// Whether there is a halo at all (Layer::halates).
    bool on() const;
    /// How far the kernel carries light, micrometres: the radius, or the
    /// base kernel's reach_um(); 0 without a halo.
    double reach_um() const;
};

/// Layer `layer` of `stock`'s halation.
HalationSpec layer_halation(const Stock& stock, const Layer& layer);

/// How spread_frame convolves. fft: the reference (the exact engine's):
/// one FFTW transform of the frame and its margin. direct: for the
/// Gaussian alone (no halo): a separable convolution with the same pixel
/// weights, along rows then columns, each sum taken in tap order: the
/// same values to rounding (the largest difference is measured in
/// light_spread_test), several times cheaper on a large frame; with a halo
/// spread_frame takes the fft whatever is asked.
enum class SpreadMethod { fft, direct };
/// What spread_frame runs for these settings: direct only where asked and
/// there is no halo.
SpreadMethod spread_method(SpreadMethod asked, bool halo);

/// The halation kernels' transforms spread_frame makes, kept for the next
/// frame of the same size, pitch and edge with the same kernel (the
/// stock's film base for the `base` kernel, the Gaussian's reach): the
/// layers of a stock share their base, so a frame transforms it once, and
/// the layers' frames never hold a copy each. Thread-safe: a layer asking
/// for a transform another is making waits for it. Holds each transform
/// until destroyed (a 4K frame's with a 2.5 mm halo: 80 MB).
class HaloTransforms {
public:
    HaloTransforms();
    ~HaloTransforms();
    HaloTransforms(const HaloTransforms&)            = delete;
    HaloTransforms& operator=(const HaloTransforms&) = delete;

    struct Impl;
    Impl& impl() { return *m_impl; }

private:
    std::unique_ptr<Impl> m_impl;
};

/// The exposure value of a layer after its scatter and halation
/// (MODEL.md 9): H_s = (1 - scatter) H + scatter (G * H), then
/// H' = H_s + halation (K * H_s), over the whole input frame
/// (frame_width x frame_height pixels of `pitch_um`; beyond the frame the
/// nearest edge pixel's value or 0, as `exposure`'s edge() says, MODEL.md
/// 2). `exposure` gives the unspread value of every pixel and must view the
/// whole frame. The result, row by row, is the exact mean of H' over each
/// input pixel to rounding (the kernels' pixel weights above, an FFT
/// convolution in double precision whose round-off is clamped at 0), stored
/// as float; the renderer reads it box-reconstructed like an input, which
/// is where this differs from MODEL.md's reference: H' varies within a
/// pixel, its mean does not.
///
/// Deterministic: a pure function of the layer (with the stock's film base
/// for the `base` kernel), the exposure and the frame's size (one
/// FFTW_ESTIMATE plan for a size, aligned buffers, one thread), never of
/// the ROI or the thread count, nor of `shared` (where the halo's
/// transform is taken from; null: made here). The exposure is read as it
/// is needed: no copy of it is held.
std::vector<float> spread_exposure(const Stock& stock, const Layer& layer,
                                   const LayerExposure& exposure, int64_t frame_width,
                                   int64_t frame_height, double pitch_um,
                                   SpreadMethod method = SpreadMethod::fft,
                                   HaloTransforms* shared = nullptr);

/// The convolution itself, on any frame of values (w x h, row by row;
/// beyond the frame the nearest edge value (`edge` clamp) or 0 (gate)):
/// (1 - scatter) V + scatter (G * V), then + halation (K * that), with the
/// pixel kernels above. spread_exposure applies it to a layer's
/// exposure; MODEL.md 10 blurs expected densities with it (scatter 1, no
/// halation: the Gaussian alone). Deterministic as spread_exposure. Throws
/// std::runtime_error (naming the keys to lower) when the frame plus the
/// kernels' reach would need a transform of more than 2^28 values. The
/// result takes the place of `values` (move them in: a frame is not held
/// twice; the direct convolution holds a few rows more, the transform its
/// grid).
std::vector<double> spread_frame(std::vector<double> values, int64_t frame_width,
                                 int64_t frame_height, double pitch_um, double scatter,
                                 double scatter_sigma_um, const HalationSpec& halation,
                                 FrameEdge edge, SpreadMethod method = SpreadMethod::fft,
                                 HaloTransforms* shared = nullptr);

/// A transform length >= n with no prime factor above 7 (FFTW is fast on
/// those).
int64_t fft_size_at_least(int64_t n);

}  // namespace filmgrain
