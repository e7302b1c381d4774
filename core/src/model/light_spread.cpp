// MODEL.md section 9: scatter and halation.
#include "model/light_spread.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <limits>
#include <utility>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <new>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

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

/// n-point Gauss-Legendre nodes and weights on [0, 1]: Newton's method on
/// the Legendre polynomial from Chebyshev's guesses, to rounding.
struct GaussRule {
    std::vector<double> x, w;
};
GaussRule gauss_legendre_01(int n)
{
    GaussRule g { std::vector<double>(static_cast<size_t>(n)),
                  std::vector<double>(static_cast<size_t>(n)) };
    for (int i = 0; i < n; ++i) {
        double z = std::cos(M_PI * (i + 0.75) / (n + 0.5)), dp = 1.0;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1.0, p1 = 0.0;
            for (int j = 1; j <= n; ++j) {
                const double p2 = p1;
                p1              = p0;
                p0              = ((2.0 * j - 1.0) * z * p1 - (j - 1.0) * p2) / j;
            }
            dp              = n * (z * p0 - p1) / (z * z - 1.0);
            const double dz = p0 / dp;
            z -= dz;
            if (std::fabs(dz) < 1e-16)
                break;
        }
        g.x[static_cast<size_t>(i)] = 0.5 * (1.0 - z);
        g.w[static_cast<size_t>(i)] = 1.0 / ((1.0 - z * z) * dp * dp);  // (2 / ...) / 2
    }
    return g;
}

/// The base kernel's pixel-square quadrature (base_halation_pixel_kernel):
/// a 3-point Gauss-Legendre rule on [0, 1] per axis of a square where K is
/// smooth.
constexpr double kGl3Nodes[3]   = { 0.1127016653792583, 0.5, 0.8872983346207417 };
constexpr double kGl3Weights[3] = { 5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0 };
/// Largest square one rule covers, as a fraction of the larger of the
/// base's thickness and the square's distance from the centre (K varies on
/// the scale 2 t near it and as r^-4 far out): squares are halved until
/// they are that small.
constexpr double kBaseLeafOfScale = 1.0 / 16.0;
/// Squares within this many of their sides inside the critical circle are
/// integrated as those it crosses.
constexpr double kKinkSquares = 4.0;

/// The integrals of the base kernel K (cut at its reach) against the four
/// corner functions of a pixel square, over squares inside it:
/// m[0] = (1 - xi)(1 - eta), m[1] = xi (1 - eta), m[2] = (1 - xi) eta,
/// m[3] = xi eta, (xi, eta) the pixel square's local coordinates in
/// [0, 1]^2. Where K is smooth over the square, a 3x3 Gauss-Legendre rule.
/// Where the critical circle (bare: R(theta) rises as 1 - c sqrt(theta_c -
/// theta) just inside it, a kink) or the cut (a step) crosses the square,
/// polar coordinates instead: the angle split where the square's entry or
/// exit edge changes and where a circle meets its edges, each piece by a
/// 16-point rule (at the cut too: with the cut at 1e-2 a 4-point rule
/// there missed the sum by up to 4.7e-9 at 389 um pixels) in a smoothstep
/// of the angle (the inner integral behaves as a power 3/2 at
/// the pieces' ends); the radius split at the critical circle, the part
/// inside it in q = sqrt(r_c - r), where K is smooth. The weights built
/// from them sum to 1 within 5e-11 (light_spread_test).
class SquareMoments {
public:
    SquareMoments(const BaseHalation& base, double pitch_um)
        : m_base(base)
        , m_pitch_um(pitch_um)
        , m_ring_um(base.critical_radius_um())
        , m_cut_um(base.reach_um())
        , m_rule(gauss_legendre_01(16))
    {
    }

    /// Adds to m the moments over [x0, x0 + h] x [y0, y0 + h] (x0, y0 >= 0)
    /// of the pixel square whose corner is (ax, ay); every length in um,
    /// from the kernel's centre.
    void add(double ax, double ay, double x0, double y0, double h, std::array<double, 4>& m) const
    {
        const double dmin = std::sqrt(x0 * x0 + y0 * y0);
        const double dmax = std::sqrt((x0 + h) * (x0 + h) + (y0 + h) * (y0 + h));
        if (dmin >= m_cut_um)
            return;
        if (h > kBaseLeafOfScale * std::max(m_base.thickness_um(), dmin)) {
            const double q = 0.5 * h;
            for (int c = 0; c < 4; ++c)
                add(ax, ay, x0 + q * (c % 2), y0 + q * (c / 2), q, m);
            return;
        }
        // Inside the critical circle R's slope grows without bound towards
        // it: squares near it from inside take the polar rule too.
        const bool kink = dmin < m_ring_um && m_ring_um < dmax + kKinkSquares * h;
        if (kink || m_cut_um < dmax) {
            polar(ax, ay, x0, y0, h, m_rule, m);
            return;
        }
        for (int a = 0; a < 3; ++a) {
            const double x = x0 + h * kGl3Nodes[a];
            for (int b = 0; b < 3; ++b) {
                const double y = y0 + h * kGl3Nodes[b];
                accumulate(ax, ay, x, y, kGl3Weights[a] * kGl3Weights[b] * h * h
                                              * m_base.density_at_r2(x * x + y * y),
                           m);
            }
        }
    }

private:
    void accumulate(double ax, double ay, double x, double y, double f,
                    std::array<double, 4>& m) const
    {
        const double xi = (x - ax) / m_pitch_um, eta = (y - ay) / m_pitch_um;
        m[0] += f * (1.0 - xi) * (1.0 - eta);
        m[1] += f * xi * (1.0 - eta);
        m[2] += f * (1.0 - xi) * eta;
        m[3] += f * xi * eta;
    }

    void polar(double ax, double ay, double x0, double y0, double h, const GaussRule& rule,
               std::array<double, 4>& m) const
    {
        const double x1 = x0 + h, y1 = y0 + h;
        const double lo = std::atan2(y0, x1), hi = std::atan2(y1, x0);
        std::vector<double> at { lo, hi, std::atan2(y1, x1) };
        if (x0 > 0.0 || y0 > 0.0)
            at.push_back(std::atan2(y0, x0));
        for (double rho : { m_ring_um, m_cut_um }) {
            if (!std::isfinite(rho))
                continue;
            for (double x : { x0, x1 })
                if (x < rho) {
                    const double y = std::sqrt(rho * rho - x * x);
                    if (y > y0 && y < y1)
                        at.push_back(std::atan2(y, x));
                }
            for (double y : { y0, y1 })
                if (y < rho) {
                    const double x = std::sqrt(rho * rho - y * y);
                    if (x > x0 && x < x1)
                        at.push_back(std::atan2(y, x));
                }
        }
        std::sort(at.begin(), at.end());
        for (size_t piece = 0; piece + 1 < at.size(); ++piece) {
            const double a = std::max(at[piece], lo), b = std::min(at[piece + 1], hi);
            if (!(b > a))
                continue;
            for (size_t k = 0; k < rule.x.size(); ++k) {
                // phi = a + (b - a) (3 t^2 - 2 t^3), dphi = (b - a) 6 t (1 - t) dt.
                const double t    = rule.x[k];
                const double phi  = a + (b - a) * t * t * (3.0 - 2.0 * t);
                const double wphi = rule.w[k] * (b - a) * 6.0 * t * (1.0 - t);
                const double c = std::cos(phi), s = std::sin(phi);
                const double r_in  = std::max(x0 > 0.0 ? x0 / c : 0.0, y0 > 0.0 ? y0 / s : 0.0);
                const double r_out = std::min({ x1 / c, y1 / s, m_cut_um });
                if (!(r_out > r_in))
                    continue;
                // r dr dphi: the area element.
                const auto at_r = [&](double r, double weight) {
                    accumulate(ax, ay, r * c, r * s, weight * r * m_base.density_per_um2(r), m);
                };
                const double split
                    = std::isfinite(m_ring_um) ? std::clamp(m_ring_um, r_in, r_out) : r_out;
                if (split > r_in) {
                    if (std::isfinite(m_ring_um)) {
                        // r = r_c - q^2 on [r_in, split]: dr = 2 q dq.
                        const double q0 = std::sqrt(m_ring_um - split);
                        const double q1 = std::sqrt(m_ring_um - r_in);
                        for (size_t i = 0; i < rule.x.size(); ++i) {
                            const double q = q0 + (q1 - q0) * rule.x[i];
                            at_r(m_ring_um - q * q, wphi * rule.w[i] * (q1 - q0) * 2.0 * q);
                        }
                    } else {
                        for (size_t i = 0; i < rule.x.size(); ++i)
                            at_r(r_in + (split - r_in) * rule.x[i],
                                 wphi * rule.w[i] * (split - r_in));
                    }
                }
                if (r_out > split)
                    for (size_t i = 0; i < rule.x.size(); ++i)
                        at_r(split + (r_out - split) * rule.x[i],
                             wphi * rule.w[i] * (r_out - split));
            }
        }
    }

    const BaseHalation& m_base;
    double m_pitch_um, m_ring_um, m_cut_um;
    GaussRule m_rule;
};

}  // namespace

BaseHalation::BaseHalation(double thickness_um, double refractive_index, RearFace rear_face)
    : m_thickness_um(thickness_um)
    , m_n(refractive_index)
    , m_rear_face(rear_face)
{
    // Rbar = integral of R over u = sin^2(theta) in [0, 1] (the Lambertian
    // 2 sin cos dtheta is du): below u_c = 1 / n^2 Fresnel's, above it 1.
    if (m_rear_face == RearFace::bare) {
        const double uc = 1.0 / (m_n * m_n);
        m_returned      = subcritical_integral(0.0) + (1.0 - uc);
    }
    // Beyond the critical angle R = 1 for both faces: the light beyond
    // theta is cos^2(theta) / Rbar (docs/model.md), which is far below the
    // subcritical share at kBaseHalationTail (n >= 1.3: cos^2(theta_c) >=
    // 0.4), so the cut lies there.
    const double cos2 = kBaseHalationTail * m_returned;
    m_reach_um        = 2.0 * m_thickness_um * std::sqrt(1.0 / cos2 - 1.0);
    m_inv_4t2         = 1.0 / (4.0 * m_thickness_um * m_thickness_um);
    m_norm_per_um2    = 1.0 / (4.0 * M_PI * m_thickness_um * m_thickness_um * m_returned);
    const double ring = critical_radius_um();
    m_ring2_um2       = std::isfinite(ring) ? ring * ring : 0.0;  // remjet: R = 1 everywhere
}

BaseHalation::BaseHalation(const Stock& stock)
    : BaseHalation(stock.base_thickness_um, stock.base_refractive_index, stock.rear_face)
{
}

double BaseHalation::reflectance(double cos_theta) const
{
    if (m_rear_face == RearFace::remjet)
        return 1.0;
    const double c = cos_theta;
    // Snell: sin(theta_t) = n sin(theta); at or past 1, total reflection.
    const double st2 = m_n * m_n * (1.0 - c * c);
    if (st2 >= 1.0)
        return 1.0;
    const double ct = std::sqrt(1.0 - st2);
    const double rs = (m_n * c - ct) / (m_n * c + ct);  // s: n cos(i) vs cos(t)
    const double rp = (c - m_n * ct) / (c + m_n * ct);  // p: cos(i) vs n cos(t)
    return 0.5 * (rs * rs + rp * rp);
}

double BaseHalation::subcritical_integral(double u) const
{
    // With v = cos(theta_t) = sqrt(1 - n^2 u), u = (1 - v^2) / n^2 and
    // du = -2 v / n^2 dv: the integral of R(v) 2 v / n^2 over [0, v(u)],
    // smooth in v (the square-root kink of R at the critical angle is
    // gone). 8 panels of the 8-point rule: exact to rounding.
    const double n2 = m_n * m_n;
    const double v1 = std::sqrt(std::max(0.0, 1.0 - n2 * u));
    double sum      = 0.0;
    const int panels = 8;
    for (int k = 0; k < panels; ++k) {
        const double a = v1 * k / panels, b = v1 * (k + 1) / panels;
        for (int i = 0; i < 8; ++i) {
            const double x = i < 4 ? -kGlNodes[i] : kGlNodes[i - 4];
            const double v = 0.5 * (a + b) + 0.5 * (b - a) * x;
            const double c = std::sqrt((n2 - 1.0 + v * v) / n2);  // cos(theta)
            sum += kGlWeights[i < 4 ? i : i - 4] * 0.5 * (b - a) * reflectance(c) * 2.0 * v / n2;
        }
    }
    return sum;
}

double BaseHalation::density_per_um2(double r_um) const { return density_at_r2(r_um * r_um); }

double BaseHalation::density_at_r2(double r2_um2) const
{
    // tan(theta) = r / 2t; the Lambertian 2 sin cos dtheta mapped to r by
    // dr = 2t / cos^2(theta) dtheta over the ring 2 pi r dr.
    const double cos2 = 1.0 / (1.0 + r2_um2 * m_inv_4t2);
    const double r    = r2_um2 >= m_ring2_um2 ? 1.0 : reflectance(std::sqrt(cos2));
    return r * cos2 * cos2 * m_norm_per_um2;
}

double BaseHalation::light_beyond(double r_um) const
{
    const double x    = r_um / (2.0 * m_thickness_um);
    const double cos2 = 1.0 / (1.0 + x * x);
    const double u    = 1.0 - cos2;  // sin^2(theta)
    if (m_rear_face == RearFace::remjet)
        return cos2;
    const double uc = 1.0 / (m_n * m_n);
    if (u >= uc)
        return cos2 / m_returned;
    return (subcritical_integral(u) + (1.0 - uc)) / m_returned;
}

double BaseHalation::critical_radius_um() const
{
    if (m_rear_face == RearFace::remjet)
        return std::numeric_limits<double>::infinity();
    // tan(theta_c) = 1 / sqrt(n^2 - 1).
    return 2.0 * m_thickness_um / std::sqrt(m_n * m_n - 1.0);
}

bool HalationSpec::on() const
{
    return fraction > 0.0 && (kernel == HalationKernel::base ? base_thickness_um > 0.0
                                                              : radius_um > 0.0);
}

double HalationSpec::reach_um() const
{
    if (!on())
        return 0.0;
    if (kernel != HalationKernel::base)
        return radius_um;
    return BaseHalation(base_thickness_um, base_refractive_index, rear_face).reach_um();
}

HalationSpec layer_halation(const Stock& stock, const Layer& layer)
{
    HalationSpec h;
    h.fraction  = layer.halation;
    h.kernel    = layer.halation_kernel;
    h.radius_um = layer.halation_radius_um;
    if (layer.halation_kernel == HalationKernel::base) {
        h.base_thickness_um     = stock.base_thickness_um;
        h.base_refractive_index = stock.base_refractive_index;
        h.rear_face             = stock.rear_face;
    }
    return h;
}

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

PixelKernel base_halation_pixel_kernel(const BaseHalation& base, double pitch_um,
                                       int64_t max_reach)
{
    const double p      = pitch_um;
    const double cut_um = base.reach_um();
    PixelKernel k;
    k.reach = std::min<int64_t>(static_cast<int64_t>(std::ceil(cut_um / p)) + 1,
                                std::max<int64_t>(max_reach, 0));
    const int64_t R = k.reach, n = 2 * R + 1;
    // The weight of offset (i, j) is the integral of K against the tent
    // (1 - |x - i p| / p)(1 - |y - j p| / p): over each of the four pixel
    // squares around (i p, j p) a bilinear function. So each pixel square
    // [a p, a p + p] x [b p, b p + p] (a, b >= 0; K is radial, the other
    // quadrants mirror it) is integrated once against the four corner
    // functions of its local (xi, eta) in [0, 1]^2 (SquareMoments).
    const int64_t side = R + 1;
    const SquareMoments integrate(base, p);
    std::vector<std::array<double, 4>> moments(static_cast<size_t>(side * side));
    for (int64_t b = 0; b < side; ++b)
        for (int64_t a = b; a < side; ++a) {  // a >= b; the others by symmetry
            std::array<double, 4> m { 0.0, 0.0, 0.0, 0.0 };
            integrate.add(a * p, b * p, a * p, b * p, p, m);
            moments[static_cast<size_t>(b * side + a)] = m;
            // The square mirrored in the diagonal swaps xi and eta.
            moments[static_cast<size_t>(a * side + b)] = { m[0], m[2], m[1], m[3] };
        }
    // Offset i's tent covers square i with (1 - xi) and square i - 1 with
    // xi; at i = 0, square 0 and its mirror image, both with (1 - xi).
    struct Part {
        int64_t square;
        int corner;  ///< 0: (1 - xi), 1: xi
        double times;
    };
    const auto parts = [](int64_t i, Part out[2]) {
        if (i == 0) {
            out[0] = { 0, 0, 2.0 };
            return 1;
        }
        out[0] = { i, 0, 1.0 };
        out[1] = { i - 1, 1, 1.0 };
        return 2;
    };
    // The quadrant's weights (i, j >= 0), each pair (i, j), (j, i) computed
    // once (exactly symmetric), then mirrored into the four quadrants row by
    // row.
    std::vector<double> quadrant(static_cast<size_t>(side * side));
    const double scale = 1.0 / (1.0 - kBaseHalationTail);  // the cut kernel's integral
    for (int64_t j = 0; j <= R; ++j)
        for (int64_t i = j; i <= R; ++i) {
            Part px[2], py[2];
            const int nx = parts(i, px), ny = parts(j, py);
            double w = 0.0;
            for (int u = 0; u < nx; ++u)
                for (int v = 0; v < ny; ++v) {
                    if (px[u].square >= side || py[v].square >= side)
                        continue;
                    const auto& m
                        = moments[static_cast<size_t>(py[v].square * side + px[u].square)];
                    w += px[u].times * py[v].times
                         * m[static_cast<size_t>(px[u].corner + 2 * py[v].corner)];
                }
            quadrant[static_cast<size_t>(j * side + i)] = w * scale;
            quadrant[static_cast<size_t>(i * side + j)] = w * scale;
        }
    moments = {};
    k.weights.resize(static_cast<size_t>(n * n));
    for (int64_t y = -R; y <= R; ++y) {
        const double* row = quadrant.data() + std::abs(y) * side;
        double* out       = k.weights.data() + (y + R) * n;
        for (int64_t x = -R; x <= R; ++x)
            out[x + R] = row[std::abs(x)];
    }
    return k;
}

SpreadMethod spread_method(SpreadMethod asked, bool halo)
{
    return halo ? SpreadMethod::fft : asked;
}

namespace {

/// G * V by the separable, symmetric pixel weights `g` of one axis
/// (w[-m] = w[m]), along rows then columns, handed out a row at a time:
/// out_row(y, row) with row[x] = (G * V)(x, y), y from 0 up. value_at(x, y)
/// reads V (x in [0, w), y in [0, h)); beyond the frame the nearest edge
/// value (clamp) or nothing (gate). Each output adds w[m] times the sum of
/// its two values m away, m from the reach down to 0, a row at a time (so
/// the compiler may vectorise across the row without reordering a sum).
/// The rows convolved along x live in a ring of the 2 reach + 1 that a row
/// of the output reads, and row y of V is read before row y of the output
/// is handed out and never after: a caller may write the output over V.
/// The memory is a few rows'.
template <class ValueAt, class OutRow>
void separable_convolution(const ValueAt& value_at, int64_t w, int64_t h, const PixelKernel& g,
                           FrameEdge edge, const OutRow& out_row)
{
    const int64_t r = g.reach, taps = 2 * r + 1;
    const double* k = g.weights.data() + r;  // k[m] = w[m] = w[-m]
    std::vector<double> ring(static_cast<size_t>(taps * w));
    std::vector<double> line(static_cast<size_t>(w + 2 * r));
    std::vector<double> o(static_cast<size_t>(w));
    const std::vector<double> zeros(static_cast<size_t>(w), 0.0);
    // Row yy of the frame convolved along x, into its ring slot.
    const auto convolve_row = [&](int64_t yy) {
        for (int64_t x = -r; x < w + r; ++x)
            line[static_cast<size_t>(x + r)]
                = x >= 0 && x < w ? value_at(x, yy)
                  : edge == FrameEdge::clamp ? value_at(std::clamp<int64_t>(x, 0, w - 1), yy)
                                             : 0.0;
        double* out        = ring.data() + (yy % taps) * w;
        const double* mid  = line.data() + r;
        std::fill(out, out + w, 0.0);
        for (int64_t m = r; m > 0; --m) {
            const double km = k[m];
            for (int64_t x = 0; x < w; ++x)
                out[x] += km * (mid[x - m] + mid[x + m]);
        }
        for (int64_t x = 0; x < w; ++x)
            out[x] += k[0] * mid[x];
    };
    // Row yy of the ring, or beyond the frame its edge row (clamp) or zeros.
    const auto row = [&](int64_t yy) {
        if (yy < 0 || yy >= h) {
            if (edge == FrameEdge::gate)
                return zeros.data();
            yy = std::clamp<int64_t>(yy, 0, h - 1);
        }
        return static_cast<const double*>(ring.data() + (yy % taps) * w);
    };
    for (int64_t yy = 0; yy < std::min(h, r); ++yy)
        convolve_row(yy);
    for (int64_t y = 0; y < h; ++y) {
        // Rows up to y + r are in the ring (those below y - r left it).
        if (y + r < h)
            convolve_row(y + r);
        std::fill(o.begin(), o.end(), 0.0);
        for (int64_t m = r; m > 0; --m) {
            const double km   = k[m];
            const double* up  = row(y - m);
            const double* down = row(y + m);
            for (int64_t x = 0; x < w; ++x)
                o[x] += km * (up[x] + down[x]);
        }
        const double* centre = row(y);
        for (int64_t x = 0; x < w; ++x)
            o[x] += k[0] * centre[x];
        out_row(y, static_cast<const double*>(o.data()));
    }
}

/// A halation kernel's pixel weights as spread_frame transforms them, at
/// one period: the real part of the kernel's transform (kw x ny, kw = nx /
/// 2 + 1; the kernel is symmetric in both axes, so its transform is real
/// and the imaginary part round-off), and the period, which the kernel's
/// reach sets.
struct HaloTransform {
    int64_t nx = 0, ny = 0, pad = 0;
    std::vector<double> real;
};

/// What makes a HaloTransform: the kernel (its kind, radius or base,
/// cut), the pitch, and the frame and Gaussian reach that size the period.
using HaloKey = std::tuple<int, double, double, double, int, double, int64_t, int64_t, int,
                           int64_t, int64_t>;

}  // namespace

struct HaloTransforms::Impl {
    std::mutex mutex;
    std::map<HaloKey, std::shared_future<std::shared_ptr<const HaloTransform>>> made;
};

HaloTransforms::HaloTransforms()
    : m_impl(std::make_unique<Impl>())
{
}

HaloTransforms::~HaloTransforms() = default;

namespace {

/// `key`'s transform from `halos`: made here by `make` if no caller has
/// asked for it, else the one another caller made (waiting for it while it
/// is being made).
std::shared_ptr<const HaloTransform> halo_transform(
    HaloTransforms::Impl& halos, const HaloKey& key,
    const std::function<std::shared_ptr<const HaloTransform>()>& make)
{
    std::promise<std::shared_ptr<const HaloTransform>> promise;
    std::shared_future<std::shared_ptr<const HaloTransform>> made;
    {
        std::lock_guard<std::mutex> lock(halos.mutex);
        const auto it = halos.made.find(key);
        if (it != halos.made.end()) {
            made = it->second;
        } else {
            halos.made.emplace(key, promise.get_future().share());
        }
    }
    if (made.valid())
        return made.get();
    try {
        std::shared_ptr<const HaloTransform> t = make();
        promise.set_value(t);
        return t;
    } catch (...) {
        promise.set_exception(std::current_exception());
        throw;
    }
}

/// The spread light of spread_frame's result, a row at a time:
/// part_row(y, s, part) with part[x] the light (x, y) receives from the
/// spread ((G * V) scatter, and its halo), before its round-off is clamped
/// at 0, y from 0 up, and s the scatter that leaves V: the result is
/// spread_value(s, V, part). part is null where nothing spreads (direct,
/// no scatter). value_at(x, y) reads V (x in [0, w), y in [0, h)); row y
/// of V is read before row y is handed out and never after.
template <class ValueAt, class PartRow>
void spread_parts(const ValueAt& value_at, int64_t w, int64_t h, double pitch_um, double scatter,
                  double scatter_sigma_um, const HalationSpec& halo, FrameEdge edge,
                  SpreadMethod method, HaloTransforms* shared, const PartRow& part_row)
{
    const bool scattering = scatter > 0.0 && scatter_sigma_um > 0.0;
    const bool haloing    = halo.on();
    const bool base       = haloing && halo.kernel == HalationKernel::base;
    const double s        = scattering ? scatter : 0.0;
    const double halation = halo.fraction;
    // The transform's size, checked before anything is built: a kernel far
    // wider than the frame's pixels (a tiny pitch) must not exhaust memory.
    // With nothing beyond the frame (gate), the base kernel's offsets
    // beyond it (plus the Gaussian's reach) meet no pair of the frame's
    // pixels: they are left out. With the scene continued (clamp) the
    // margin's light comes from the whole reach.
    const bool crop         = base && edge == FrameEdge::gate;
    const double scatter_px = scattering ? 6.0 * scatter_sigma_um / pitch_um + 2.0 : 0.0;
    double halo_px          = haloing ? halo.reach_um() / pitch_um + 2.0 : 0.0;
    if (crop)
        halo_px = std::min(halo_px, static_cast<double>(std::max(w, h)) + scatter_px);
    const double reach_px  = scatter_px + halo_px;
    const double margin_px = (edge == FrameEdge::clamp ? 2.0 : 1.0) * reach_px;
    const double cells = (static_cast<double>(w) + margin_px) * (static_cast<double>(h) + margin_px);
    if (!(cells <= kMaxTransformCells))
        throw std::runtime_error(
            "light spread: the kernels reach " + std::to_string(reach_px) + " input pixels of "
            + std::to_string(pitch_um) + " um beyond a " + std::to_string(w) + "x"
            + std::to_string(h) + " frame, a transform of " + std::to_string(cells)
            + " values, above the limit of " + std::to_string(kMaxTransformCells)
            + (base ? ": lower scatter_sigma_um, base_thickness_um or inhibitor_diffusion_um, or "
                      "render a coarser input"
                    : ": lower scatter_sigma_um, halation_radius_um or inhibitor_diffusion_um, or "
                      "render a coarser input"));
    PixelKernel g;
    if (scattering)
        g = gaussian_pixel_kernel(scatter_sigma_um, pitch_um);
    if (spread_method(method, haloing) == SpreadMethod::direct) {
        // The spread part s (G * V).
        if (!scattering) {
            for (int64_t y = 0; y < h; ++y)
                part_row(y, s, static_cast<const double*>(nullptr));
            return;
        }
        std::vector<double> part(static_cast<size_t>(w));
        separable_convolution(value_at, w, h, g, edge, [&](int64_t y, const double* blurred) {
            for (int64_t x = 0; x < w; ++x)
                part[static_cast<size_t>(x)] = s * blurred[x];
            part_row(y, s, static_cast<const double*>(part.data()));
        });
        return;
    }
    // A period of at least the frame plus the kernels' reach: the circular
    // convolution then wraps only zeros into the frame (gate). With the
    // scene continued beyond the frame (clamp, MODEL.md 2), the frame sits
    // `pad` = reach pixels in, the margin holding the nearest edge pixel's
    // value, and the period takes the margins on both sides: what the
    // kernels read around the frame is the margin, never a wrap.
    //
    // The halo's transform first: the kernel at its offsets modulo the
    // period, symmetric in both axes, so its transform is real (the
    // imaginary part is round-off). Its real part is kept (in `shared` for
    // the next layer with the same kernel and period) and its grid freed
    // before the frame's grid is made: the two grids never coexist (a 4K
    // frame's with a 2.5 mm halo is 160 MB).
    const int64_t max_reach
        = crop ? std::max(w, h) - 1 + g.reach : std::numeric_limits<int64_t>::max();
    const auto make = [&]() {
        PixelKernel k;
        if (base)
            k = base_halation_pixel_kernel(BaseHalation(halo.base_thickness_um,
                                                        halo.base_refractive_index,
                                                        halo.rear_face),
                                           pitch_um, max_reach);
        else if (haloing)
            k = halation_pixel_kernel(halo.kernel, halo.radius_um, pitch_um);
        auto t            = std::make_shared<HaloTransform>();
        const int64_t reach = g.reach + k.reach;
        t->pad            = edge == FrameEdge::clamp ? reach : 0;
        t->nx             = fft_size_at_least(w + reach + t->pad);
        t->ny             = fft_size_at_least(h + reach + t->pad);
        if (!haloing)
            return std::shared_ptr<const HaloTransform>(std::move(t));
        const int64_t nx = t->nx, ny = t->ny, kw = nx / 2 + 1;
        FftGrid kernel(nx, ny);
        const int64_t n = 2 * k.reach + 1;
        for (int64_t j = -k.reach; j <= k.reach; ++j)
            for (int64_t i = -k.reach; i <= k.reach; ++i)
                kernel.real((i + nx) % nx, (j + ny) % ny)
                    = k.weights[static_cast<size_t>((j + k.reach) * n + (i + k.reach))];
        k = PixelKernel();  // its weights are in the grid now
        kernel.transform(true);
        t->real.resize(static_cast<size_t>(kw * ny));
        for (int64_t ky = 0; ky < ny; ++ky) {
            const std::complex<double>* row = kernel.spectrum_row(ky);
            for (int64_t kx = 0; kx < kw; ++kx)
                t->real[static_cast<size_t>(ky * kw + kx)] = row[kx].real();
        }
        return std::shared_ptr<const HaloTransform>(std::move(t));
    };
    std::shared_ptr<const HaloTransform> kt;
    if (haloing) {
        HaloTransforms own;
        const HaloKey key { static_cast<int>(halo.kernel), halo.radius_um,
                            halo.base_thickness_um, halo.base_refractive_index,
                            static_cast<int>(halo.rear_face), pitch_um, max_reach, g.reach,
                            static_cast<int>(edge), w, h };
        kt = halo_transform((shared ? shared : &own)->impl(), key, make);
    } else {
        kt = make();
    }
    const int64_t nx = kt->nx, ny = kt->ny, pad = kt->pad;
    const int64_t kw = nx / 2 + 1;  // frequencies of a row of the r2c transform

    FftGrid v(nx, ny);
    for (int64_t y = -pad; y < h + pad; ++y)
        for (int64_t x = -pad; x < w + pad; ++x)
            v.real(x + pad, y + pad)
                = value_at(std::clamp<int64_t>(x, 0, w - 1), std::clamp<int64_t>(y, 0, h - 1));
    v.transform(true);

    std::vector<double> gx, gy;
    if (scattering) {
        gx = symmetric_spectrum(g, nx, kw);
        gy = symmetric_spectrum(g, ny, ny);
    }

    // The spread part: [((1 - s) + s G)(1 + h K) - (1 - s)] * values.
    const double scale = 1.0 / (static_cast<double>(nx) * static_cast<double>(ny));
    for (int64_t ky = 0; ky < ny; ++ky) {
        std::complex<double>* row = v.spectrum_row(ky);
        const double* krow = haloing ? kt->real.data() + ky * kw : nullptr;
        for (int64_t kx = 0; kx < kw; ++kx) {
            const double gs = scattering ? (1.0 - s) + s * gx[static_cast<size_t>(kx)]
                                                           * gy[static_cast<size_t>(ky)]
                                         : 1.0;
            const double hk = haloing ? 1.0 + halation * krow[kx] : 1.0;
            row[kx] *= (gs * hk - (1.0 - s)) * scale;
        }
    }
    kt.reset();
    v.transform(false);
    for (int64_t y = 0; y < h; ++y)
        part_row(y, s, static_cast<const double*>(&v.real(pad, y + pad)));
}

/// The part that stays, exactly, plus the spread part (its round-off
/// clamped at 0: no negative light).
double spread_value(double s, double value, const double* part, int64_t x)
{
    return part ? (1.0 - s) * value + std::max(0.0, part[x]) : value;
}

}  // namespace

std::vector<double> spread_frame(std::vector<double> values, int64_t frame_width,
                                 int64_t frame_height, double pitch_um, double scatter,
                                 double scatter_sigma_um, const HalationSpec& halo, FrameEdge edge,
                                 SpreadMethod method, HaloTransforms* shared)
{
    const int64_t w = frame_width;
    double* v       = values.data();
    const auto value_at = [v, w](int64_t x, int64_t y) { return v[y * w + x]; };
    spread_parts(value_at, w, frame_height, pitch_um, scatter, scatter_sigma_um, halo, edge, method,
                 shared, [&](int64_t y, double s, const double* part) {
                     double* row = v + y * w;
                     for (int64_t x = 0; x < w; ++x)
                         row[x] = spread_value(s, row[x], part, x);
                 });
    return values;
}

std::vector<float> spread_exposure(const Stock& stock, const Layer& layer,
                                   const LayerExposure& exposure, int64_t frame_width,
                                   int64_t frame_height, double pitch_um, SpreadMethod method,
                                   HaloTransforms* shared)
{
    std::vector<float> out(static_cast<size_t>(frame_width * frame_height));
    const auto value_at = [&exposure](int64_t x, int64_t y) { return exposure.value(x, y); };
    spread_parts(value_at, frame_width, frame_height, pitch_um, layer.scatter,
                 layer.scatter_sigma_um, layer_halation(stock, layer), exposure.edge(), method,
                 shared, [&](int64_t y, double s, const double* part) {
                     float* row = out.data() + y * frame_width;
                     for (int64_t x = 0; x < frame_width; ++x)
                         row[x] = static_cast<float>(
                             std::min<double>(spread_value(s, exposure.value(x, y), part, x),
                                              std::numeric_limits<float>::max()));
                 });
    return out;
}

}  // namespace filmgrain
