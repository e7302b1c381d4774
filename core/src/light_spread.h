// filmgrain: MODEL.md section 9, light spread in the film: scatter and
// halation act on a layer's exposure before photons are counted, with
// kernels in micrometres on the film.
#pragma once

#include <cstdint>
#include <vector>

#include "exposure.h"
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
/// Deterministic: a pure function of the layer, the exposure and the
/// frame's size (one FFTW_ESTIMATE plan for a size, aligned buffers, one
/// thread), never of the ROI or the thread count.
std::vector<float> spread_exposure(const Layer& layer, const LayerExposure& exposure,
                                   int64_t frame_width, int64_t frame_height, double pitch_um);

/// The convolution itself, on any frame of values (w x h, row by row;
/// beyond the frame the nearest edge value (`edge` clamp) or 0 (gate)):
/// (1 - scatter) V + scatter (G * V), then + halation (K * that), with the
/// pixel kernels above. spread_exposure applies it to a layer's
/// exposure; MODEL.md 10 blurs expected densities with it (scatter 1, no
/// halation: the Gaussian alone). Deterministic as spread_exposure. Throws
/// std::runtime_error (naming the keys to lower) when the frame plus the
/// kernels' reach would need a transform of more than 2^28 values.
std::vector<double> spread_frame(const std::vector<double>& values, int64_t frame_width,
                                 int64_t frame_height, double pitch_um, double scatter,
                                 double scatter_sigma_um, double halation,
                                 double halation_radius_um, HalationKernel halation_kernel,
                                 FrameEdge edge);

/// A transform length >= n with no prime factor above 7 (FFTW is fast on
/// those).
int64_t fft_size_at_least(int64_t n);

}  // namespace filmgrain
