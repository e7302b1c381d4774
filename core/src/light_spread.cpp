// MODEL.md section 9: scatter and halation.
#include "light_spread.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <memory>
#include <mutex>
#include <new>
#include <stdexcept>

#include <fftw3.h>

namespace filmgrain {

namespace {

/// 8-point Gauss-Legendre rule on [-1, 1] (nodes in +- pairs).
constexpr double kGlNodes[4]   = { 0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                                   0.9602898564975363 };
constexpr double kGlWeights[4] = { 0.3626837833783620, 0.3137066458778873, 0.2223810344533745,
                                   0.1012285362903763 };

/// Psi(t) = integral of the Gaussian CDF up to t, for standard deviation
/// sigma: t Phi(t / sigma) + sigma phi(t / sigma), so Psi'' = the density.
double gaussian_cdf_integral(double t, double sigma)
{
    const double z = t / sigma;
    return t * 0.5 * std::erfc(-z / M_SQRT2) + sigma * std::exp(-0.5 * z * z) / std::sqrt(2.0 * M_PI);
}

void normalise(std::vector<double>& w)
{
    double sum = 0.0;
    for (double v : w)
        sum += v;
    for (double& v : w)
        v /= sum;
}

/// Largest transform spread_frame makes: 2^28 values (2 GiB of doubles,
/// twice that with a halation kernel's), beyond an 8K frame with a 5 mm
/// halo at 6 um pixels.
constexpr double kMaxTransformCells = 268435456.0;

/// FFTW's planner is not thread-safe (its execute is): plans are made and
/// destroyed under this lock.
std::mutex& planner_mutex()
{
    static std::mutex m;
    return m;
}

/// A real array laid out for FFTW's in-place 2-D r2c transform: ny rows of
/// 2 (nx / 2 + 1) doubles (the last one or two of each row are padding in
/// the real layout), aligned by fftw_alloc.
class FftGrid {
public:
    FftGrid(int64_t nx, int64_t ny)
        : m_nx(nx)
        , m_ny(ny)
        , m_row(2 * (nx / 2 + 1))
    {
        m_data = fftw_alloc_real(static_cast<size_t>(m_row * ny));
        if (!m_data)
            throw std::bad_alloc();
        std::fill(m_data, m_data + m_row * ny, 0.0);
    }
    ~FftGrid() { fftw_free(m_data); }
    FftGrid(const FftGrid&)            = delete;
    FftGrid& operator=(const FftGrid&) = delete;

    double& real(int64_t x, int64_t y) { return m_data[y * m_row + x]; }
    std::complex<double>* spectrum_row(int64_t ky)
    {
        return reinterpret_cast<std::complex<double>*>(m_data + ky * m_row);
    }
    int64_t spectrum_width() const { return m_nx / 2 + 1; }

    /// In-place transform: forward (real to spectrum) or backward
    /// (spectrum to real, unnormalised).
    void transform(bool forward)
    {
        fftw_plan plan;
        {
            std::lock_guard<std::mutex> lock(planner_mutex());
            auto* spectrum = reinterpret_cast<fftw_complex*>(m_data);
            plan = forward ? fftw_plan_dft_r2c_2d(static_cast<int>(m_ny), static_cast<int>(m_nx),
                                                  m_data, spectrum, FFTW_ESTIMATE)
                           : fftw_plan_dft_c2r_2d(static_cast<int>(m_ny), static_cast<int>(m_nx),
                                                  spectrum, m_data, FFTW_ESTIMATE);
        }
        if (!plan)
            throw std::runtime_error("FFTW could not plan a transform");
        fftw_execute(plan);
        std::lock_guard<std::mutex> lock(planner_mutex());
        fftw_destroy_plan(plan);
    }

private:
    int64_t m_nx, m_ny, m_row;
    double* m_data = nullptr;
};

/// The transform of a symmetric 1-D kernel (w[-m] = w[m]) of period n at
/// frequencies 0..count-1: real, w[0] + 2 sum_m w[m] cos(2 pi k m / n).
std::vector<double> symmetric_spectrum(const PixelKernel& g, int64_t n, int64_t count)
{
    std::vector<double> out(static_cast<size_t>(count));
    const double* w = g.weights.data() + g.reach;  // w[0]
    for (int64_t k = 0; k < count; ++k) {
        double s = w[0];
        for (int64_t m = 1; m <= g.reach; ++m)
            s += 2.0 * w[m] * std::cos(2.0 * M_PI * static_cast<double>((k * m) % n) / n);
        out[static_cast<size_t>(k)] = s;
    }
    return out;
}

}  // namespace

int64_t fft_size_at_least(int64_t n)
{
    for (int64_t m = std::max<int64_t>(n, 1);; ++m) {
        int64_t r = m;
        for (int64_t f : { 2, 3, 5, 7 })
            while (r % f == 0)
                r /= f;
        if (r == 1)
            return m;
    }
}

PixelKernel gaussian_pixel_kernel(double sigma_um, double pitch_um)
{
    PixelKernel k;
    const double p = pitch_um;
    k.reach = static_cast<int64_t>(std::ceil(6.0 * sigma_um / p)) + 1;
    k.weights.resize(static_cast<size_t>(2 * k.reach + 1));
    for (int64_t m = 0; m <= k.reach; ++m) {
        const double c = static_cast<double>(m) * p;
        const double w = (gaussian_cdf_integral(c + p, sigma_um)
                          - 2.0 * gaussian_cdf_integral(c, sigma_um)
                          + gaussian_cdf_integral(c - p, sigma_um))
                         / p;
        k.weights[static_cast<size_t>(k.reach + m)] = k.weights[static_cast<size_t>(k.reach - m)]
            = std::max(0.0, w);
    }
    normalise(k.weights);
    return k;
}

PixelKernel halation_pixel_kernel(HalationKernel kernel, double radius_um, double pitch_um)
{
    const double p     = pitch_um;
    const double outer = radius_um;
    const double inner = kernel == HalationKernel::ring ? kRingInnerFraction * radius_um : 0.0;
    PixelKernel k;
    if (outer < 1e-6 * p) {
        // Far below a pixel the kernel is a point: its pixel weights are
        // the identity (and the shape's area would underflow).
        k.weights = { 1.0 };
        return k;
    }
    k.reach        = static_cast<int64_t>(std::ceil(outer / p)) + 1;
    const int64_t n = 2 * k.reach + 1;
    k.weights.assign(static_cast<size_t>(n * n), 0.0);
    const double area   = M_PI * (outer * outer - inner * inner);
    const double inside = p * p / area;  // a cell wholly inside the shape
    // |offset| between a point of the output pixel and one of the input
    // pixel m cells away lies in [lo(m), hi(m)] along one axis.
    const auto lo = [&](int64_t m) { return std::max<int64_t>(0, std::abs(m) - 1) * p; };
    const auto hi = [&](int64_t m) { return static_cast<double>(std::abs(m) + 1) * p; };
    // The shape and the rule are symmetric in both axes: the quadrant
    // i, j >= 0 is computed and mirrored (exactly symmetric weights).
    for (int64_t j = 0; j <= k.reach; ++j)
        for (int64_t i = 0; i <= k.reach; ++i) {
            const double dmin = std::hypot(lo(i), lo(j)), dmax = std::hypot(hi(i), hi(j));
            double w;
            if (dmin >= outer || dmax <= inner) {
                w = 0.0;
            } else if (dmax <= outer && dmin >= inner) {
                w = inside;
            } else {
                // The output pixel is [0, p]^2, the input pixel (i, j) is
                // [i p, i p + p] x [j p, j p + p]; average over the output
                // pixel the shape's area (centred there) over the input one:
                // the rule on each quarter of the output pixel (the area
                // has kinks where the shape's edge crosses a corner).
                const double x0 = i * p, y0 = j * p;
                double sum = 0.0;
                for (int q = 0; q < 4; ++q)
                    for (int a = 0; a < 8; ++a) {
                        const double xa
                            = 0.25 * p * (2 * (q % 2) + 1 + (a < 4 ? -kGlNodes[a] : kGlNodes[a - 4]));
                        const double wa = kGlWeights[a < 4 ? a : a - 4];
                        for (int b = 0; b < 8; ++b) {
                            const double yb = 0.25 * p
                                              * (2 * (q / 2) + 1
                                                 + (b < 4 ? -kGlNodes[b] : kGlNodes[b - 4]));
                            const double wb = kGlWeights[b < 4 ? b : b - 4];
                            double a_um2
                                = disc_rect_area_um2(xa, yb, outer, x0, y0, x0 + p, y0 + p);
                            if (inner > 0.0)
                                a_um2 -= disc_rect_area_um2(xa, yb, inner, x0, y0, x0 + p, y0 + p);
                            sum += wa * wb * a_um2;
                        }
                    }
                w = sum / 16.0 / area;  // the rule's weights sum to 2 per axis and quarter
            }
            for (int64_t sj : { -j, j })
                for (int64_t si : { -i, i })
                    k.weights[static_cast<size_t>((sj + k.reach) * n + (si + k.reach))]
                        = std::max(0.0, w);
        }
    normalise(k.weights);
    return k;
}

std::vector<double> spread_frame(const std::vector<double>& values, int64_t frame_width,
                                 int64_t frame_height, double pitch_um, double scatter,
                                 double scatter_sigma_um, double halation,
                                 double halation_radius_um, HalationKernel halation_kernel,
                                 FrameEdge edge)
{
    const int64_t w = frame_width, h = frame_height;
    const bool scattering = scatter > 0.0 && scatter_sigma_um > 0.0;
    const bool haloing    = halation > 0.0 && halation_radius_um > 0.0;
    const double s        = scattering ? scatter : 0.0;
    // The transform's size, checked before anything is built: a kernel far
    // wider than the frame's pixels (a tiny pitch) must not exhaust memory.
    const double reach_px = (scattering ? 6.0 * scatter_sigma_um / pitch_um + 2.0 : 0.0)
                            + (haloing ? halation_radius_um / pitch_um + 2.0 : 0.0);
    const double margin_px = (edge == FrameEdge::clamp ? 2.0 : 1.0) * reach_px;
    const double cells = (static_cast<double>(w) + margin_px) * (static_cast<double>(h) + margin_px);
    if (!(cells <= kMaxTransformCells))
        throw std::runtime_error(
            "light spread: the kernels reach " + std::to_string(reach_px) + " input pixels of "
            + std::to_string(pitch_um) + " um beyond a " + std::to_string(w) + "x"
            + std::to_string(h) + " frame, a transform of " + std::to_string(cells)
            + " values, above the limit of " + std::to_string(kMaxTransformCells)
            + ": lower scatter_sigma_um, halation_radius_um or inhibitor_diffusion_um, or "
              "render a coarser input");
    PixelKernel g, k;
    if (scattering)
        g = gaussian_pixel_kernel(scatter_sigma_um, pitch_um);
    if (haloing)
        k = halation_pixel_kernel(halation_kernel, halation_radius_um, pitch_um);
    // A period of at least the frame plus the kernels' reach: the circular
    // convolution then wraps only zeros into the frame (gate). With the
    // scene continued beyond the frame (clamp, MODEL.md 2), the frame sits
    // `pad` = reach pixels in, the margin holding the nearest edge pixel's
    // value, and the period takes the margins on both sides: what the
    // kernels read around the frame is the margin, never a wrap.
    const int64_t reach = g.reach + k.reach;
    const int64_t pad   = edge == FrameEdge::clamp ? reach : 0;
    const int64_t nx = fft_size_at_least(w + reach + pad), ny = fft_size_at_least(h + reach + pad);

    FftGrid v(nx, ny);
    if (pad == 0) {
        for (int64_t y = 0; y < h; ++y)
            for (int64_t x = 0; x < w; ++x)
                v.real(x, y) = values[static_cast<size_t>(y * w + x)];
    } else {
        for (int64_t y = -pad; y < h + pad; ++y)
            for (int64_t x = -pad; x < w + pad; ++x)
                v.real(x + pad, y + pad)
                    = values[static_cast<size_t>(std::clamp<int64_t>(y, 0, h - 1) * w
                                                 + std::clamp<int64_t>(x, 0, w - 1))];
    }
    v.transform(true);

    const int64_t kw = v.spectrum_width();
    std::vector<double> gx, gy;
    if (scattering) {
        gx = symmetric_spectrum(g, nx, kw);
        gy = symmetric_spectrum(g, ny, ny);
    }
    std::unique_ptr<FftGrid> kernel;
    if (haloing) {
        // The kernel at its offsets modulo the period; symmetric in both
        // axes, so its transform is real (the imaginary part is round-off).
        kernel = std::make_unique<FftGrid>(nx, ny);
        const int64_t n = 2 * k.reach + 1;
        for (int64_t j = -k.reach; j <= k.reach; ++j)
            for (int64_t i = -k.reach; i <= k.reach; ++i)
                kernel->real((i + nx) % nx, (j + ny) % ny)
                    = k.weights[static_cast<size_t>((j + k.reach) * n + (i + k.reach))];
        kernel->transform(true);
    }

    // The spread part: [((1 - s) + s G)(1 + h K) - (1 - s)] * values.
    const double scale = 1.0 / (static_cast<double>(nx) * static_cast<double>(ny));
    for (int64_t ky = 0; ky < ny; ++ky) {
        std::complex<double>* row = v.spectrum_row(ky);
        const std::complex<double>* krow = kernel ? kernel->spectrum_row(ky) : nullptr;
        for (int64_t kx = 0; kx < kw; ++kx) {
            const double gs = scattering ? (1.0 - s) + s * gx[static_cast<size_t>(kx)]
                                                           * gy[static_cast<size_t>(ky)]
                                         : 1.0;
            const double hk = haloing ? 1.0 + halation * krow[kx].real() : 1.0;
            row[kx] *= (gs * hk - (1.0 - s)) * scale;
        }
    }
    kernel.reset();
    v.transform(false);

    // The part that stays, exactly, plus the spread part (its round-off
    // clamped at 0: no negative light).
    std::vector<double> out(static_cast<size_t>(w * h));
    for (int64_t y = 0; y < h; ++y)
        for (int64_t x = 0; x < w; ++x) {
            const size_t i = static_cast<size_t>(y * w + x);
            out[i]         = (1.0 - s) * values[i] + std::max(0.0, v.real(x + pad, y + pad));
        }
    return out;
}

std::vector<float> spread_exposure(const Layer& layer, const LayerExposure& exposure,
                                   int64_t frame_width, int64_t frame_height, double pitch_um)
{
    std::vector<double> values(static_cast<size_t>(frame_width * frame_height));
    for (int64_t y = 0; y < frame_height; ++y)
        for (int64_t x = 0; x < frame_width; ++x)
            values[static_cast<size_t>(y * frame_width + x)] = exposure.value(x, y);
    const std::vector<double> spread
        = spread_frame(values, frame_width, frame_height, pitch_um, layer.scatter,
                       layer.scatter_sigma_um, layer.halation, layer.halation_radius_um,
                       layer.halation_kernel, exposure.edge());
    std::vector<float> out(spread.size());
    for (size_t i = 0; i < spread.size(); ++i)
        out[i] = static_cast<float>(std::min<double>(spread[i], std::numeric_limits<float>::max()));
    return out;
}

}  // namespace filmgrain
