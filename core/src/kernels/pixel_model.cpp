// MODEL.md section 5 at pixel scale: the Boolean model's pixel statistics.
#include "kernels/pixel_model.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>

#include "model/dye.h"
#include "util/bytes.h"
#include "util/parallel.h"
#include "util/rng.h"
#include "util/sampling.h"

namespace filmgrain {

namespace {

/// Distances h at which the covariance is integrated (Integrator's cells:
/// [0, h_min], then geometric up to the largest image's overlap range).
constexpr int kDistanceNodes = 512;
/// h_min over the overlap range of the smallest image that counts (size
/// nodes of weight above kSmallestImageWeight): the first cell then holds
/// at most ~(1/1024)^2 of any image's share of the covariance integral.
constexpr double kFirstCellShare      = 1.0 / 1024.0;
constexpr double kSmallestImageWeight = 1e-9;
/// The exposure values tabulated: log-spaced, 16 per octave, from 2^-16 to
/// 2^12 times grey (0.18); v = 0 is its own node. A property of the scene,
/// never of the pixels, so that every ROI uses the same table.
constexpr double kGrey = 0.18;
constexpr int kOctavesBelow = 16, kOctavesAbove = 12, kPerOctave = 16;

}  // namespace

double pixel_develop_probability(const PixelPopulation& p, double lambda)
{
    if (lambda <= p.curve->lambda_max())
        return p.curve->probability(lambda);
    const double n = std::min(lambda, static_cast<double>(p.table->max_photons()));
    return p.table->probability(static_cast<uint64_t>(std::llround(n)));
}

double population_cover(const PixelPopulation& pp, double v)
{
    double sum = 0.0;
    for_each_size_probability(pp, v, [&](const SizeNode& node, double, double a_um2, double p) {
        sum += node.weight * a_um2 * p;
    });
    return pp.population->grains_per_um2 * sum;
}

double coverage_exponent(const std::vector<PixelPopulation>& populations, double v)
{
    double k = 0.0;
    for (const PixelPopulation& pp : populations)
        k += population_cover(pp, v);
    return k;
}

std::vector<double> population_covers(const std::vector<PixelPopulation>& populations, double v)
{
    std::vector<double> c;
    for (const PixelPopulation& pp : populations)
        c.push_back(population_cover(pp, v));
    return c;
}

namespace {

/// expm1(x), by its series where |x| < 1e-3 (to 1e-14 relative: x^5 / 120
/// is the first term left out): most distance nodes of a sparse layer hold
/// tiny sums, and the table evaluates half a million of them per layer.
inline double small_expm1(double x)
{
    return std::fabs(x) < 1e-3 ? x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0))))
                               : std::expm1(x);
}

/// The quadrature and the image overlaps of a layer's populations, prepared once.
class Integrator {
public:
    /// `distance_nodes`: cells of the distance grid (kDistanceNodes; more
    /// only to test convergence).
    Integrator(const std::vector<PixelPopulation>& pops, double px_um, double py_um,
               const ImageOverlap& image, int distance_nodes = kDistanceNodes)
        : m_pops(pops), m_image(image), m_px_um(px_um), m_py_um(py_um)
    {
        double h_max_um = 0.0, h_min_um = std::numeric_limits<double>::infinity();
        for (const PixelPopulation& p : pops) {
            Sizes sz;
            for (const SizeNode& node : size_quadrature(*p.population)) {
                const double r_um = p.grains->radius_at_z_um(node.z);
                sz.r_um.push_back(r_um);
                sz.w.push_back(node.weight);
                // Overlaps out to the largest image that carries weight
                // (z = 9 would stretch the distance grid for nothing).
                if (node.weight > 1e-15)
                    h_max_um = std::max(h_max_um, image.overlap_range_um(r_um));
                if (node.weight > kSmallestImageWeight)
                    h_min_um = std::min(h_min_um, kFirstCellShare * image.overlap_range_um(r_um));
            }
            m_sizes.push_back(std::move(sz));
        }
        distance_grid(std::min(h_min_um, h_max_um), h_max_um, std::max(distance_nodes, 2));
        for (size_t p = 0; p < m_sizes.size(); ++p) {
            Sizes& sz = m_sizes[p];
            // A coupler-limited population's clouds fill (FilledImage):
            // its statistics are its cloud discs' union's.
            sz.limited = pops[p].population->coupler_limited();
            if (sz.limited)
                m_filled.push_back(image.filled(*pops[p].population));
            for (size_t k = 0; k < sz.r_um.size(); ++k)
                for (double h_um : m_h_um)
                    sz.overlap_um2.push_back(sz.limited ? image.cloud_lens_um2(sz.r_um[k], h_um)
                                                        : image.overlap_um2(sz.r_um[k], h_um));
        }
        lag_weights();
    }

    /// The sums over the populations' sizes at exposure value v: the
    /// coverage exponent sum n E[P b], the developed density sum n E[P] and,
    /// at each distance node, sum n E[P k(h)]. Every P times a factor (MODEL.md
    /// 10) scales all three by it, so one set serves every log factor.
    /// A coupler-limited population (FilledImage) keeps its own sums, its
    /// cloud cover m = n E[P pi R^2] and, at each distance node, n E[P
    /// lens(R, h)]: its moments are not exponentials of them.
    struct Sums {
        double exponent = 0.0, developed = 0.0;
        std::vector<double> g;
        std::vector<double> cover;                // [coupler-limited population]
        std::vector<std::vector<double>> shared;  // [coupler-limited population][distance node]
    };
    Sums sums(double v) const
    {
        Sums s;
        s.g.assign(m_h_um.size(), 0.0);
        for (size_t p = 0; p < m_pops.size(); ++p) {
            const PixelPopulation& pp = m_pops[p];
            const Sizes& sz           = m_sizes[p];
            const double n            = pp.population->grains_per_um2;
            double* exponent          = &s.exponent;
            std::vector<double>* g    = &s.g;
            if (sz.limited) {
                s.cover.push_back(0.0);
                s.shared.emplace_back(m_h_um.size(), 0.0);
                exponent = &s.cover.back();
                g        = &s.shared.back();
            }
            for (size_t k = 0; k < sz.r_um.size(); ++k) {
                const double a_um2 = M_PI * sz.r_um[k] * sz.r_um[k];
                const double pd
                    = pixel_develop_probability(pp, pp.photons_per_value_um2 * v * a_um2);
                const double nw = n * sz.w[k] * pd;
                *exponent += nw * (sz.limited ? m_image.cloud_lens_um2(sz.r_um[k], 0.0)
                                              : m_image.blocking_um2(sz.r_um[k]));
                s.developed += nw;
                const double* overlap = &sz.overlap_um2[k * m_h_um.size()];
                for (size_t j = 0; j < m_h_um.size(); ++j)
                    (*g)[j] += nw * overlap[j];
            }
        }
        return s;
    }

    /// Moments at exposure value v, every P times `factor` (MODEL.md 10).
    PixelModel::Moments operator()(double v, double factor = 1.0) const
    {
        return moments(sums(v), factor);
    }

    /// Moments from the sums at some v, every P times `factor`.
    PixelModel::Moments moments(const Sums& s, double factor) const
    {
        PixelModel::Moments m;
        const double exponent = factor * s.exponent, developed = factor * s.developed;
        const std::vector<double>& g = s.g;
        m.mean = std::exp(-exponent);
        for (size_t q = 0; q < m_filled.size(); ++q)
            m.mean *= m_filled[q].mean(factor * s.cover[q]);
        m.developed_per_pixel = developed * m_px_um * m_py_um;
        // The pixel covariances: C(h) at each distance node against the
        // lags' weights (lag_weights).
        LagArray cov {};
        double integral = 0.0;
        for (size_t j = 0; j < m_h_um.size(); ++j) {
            double log_ratio = factor * g[j];  // ln(E[T(x) T(x + h)] / E[T]^2)
            for (size_t q = 0; q < m_filled.size(); ++q)
                log_ratio += m_filled[q].log_pair_ratio(factor * s.cover[q],
                                                        small_expm1(factor * s.shared[q][j]));
            const double c = m.mean * m.mean * small_expm1(log_ratio);
            const double* w = &m_lag_weight[j * kLagCount];
            for (int lag = 0; lag < kLagCount; ++lag)
                cov[static_cast<size_t>(lag)] += c * w[lag];
            integral += c * m_area_weight[j];
        }
        m.variance = std::max(0.0, cov[0]);
        if (m.variance > 0.0) {
            for (int lag = 0; lag < kLagCount; ++lag)
                m.correlation[static_cast<size_t>(lag)] = cov[static_cast<size_t>(lag)] / m.variance;
            m.correlation_sum = integral / m.variance;
        } else {
            m.correlation[0] = 1.0;
            m.correlation_sum = 1.0;
        }
        return m;
    }

private:
    /// The cells of the distance grid and a node in each: [0, h_min] (its
    /// midpoint), then `nodes` - 1 cells whose ends grow geometrically to
    /// h_max (their geometric midpoints), with the cell's integral of h dh.
    /// The images' overlaps vary on their own scale, from the smallest
    /// grain's to the largest's (a factor 10^6 for a wide lognormal): a
    /// uniform grid fine enough for the smallest would need millions of
    /// cells; the geometric one resolves every scale alike (relative
    /// spacing ln(h_max / h_min) / nodes; PixelModel.VarianceConverges).
    void distance_grid(double h_min_um, double h_max_um, int nodes)
    {
        m_h_um.assign(static_cast<size_t>(nodes), 0.0);
        m_h_dh_um2.assign(static_cast<size_t>(nodes), 0.0);
        if (!(h_max_um > 0.0))  // no image has an extent: no covariance
            return;
        m_h_um[0]     = 0.5 * h_min_um;
        m_h_dh_um2[0] = 0.5 * h_min_um * h_min_um;
        const double q = std::pow(h_max_um / h_min_um, 1.0 / (nodes - 1));
        double e0      = h_min_um;
        for (int j = 1; j < nodes; ++j) {
            const double e1 = j + 1 == nodes ? h_max_um : e0 * q;
            m_h_um[static_cast<size_t>(j)]     = std::sqrt(e0 * e1);
            m_h_dh_um2[static_cast<size_t>(j)] = 0.5 * (e1 * e1 - e0 * e0);
            e0 = e1;
        }
    }

    /// The weight of each distance node h in the covariance of each lag
    /// (i, j): Cov(i, j) = sum over nodes of C(h) times
    ///   h dh / A^2  int_0^{pi/2} [T_x(h c - i px) + T_x(h c + i px)]
    ///                            [T_y(h s - j py) + T_y(h s + j py)] dtheta,
    /// the four quadrants of the circle of radius h folded onto the first
    /// (c = cos theta, s = sin theta), by the midpoint rule on 256 angles
    /// (the integrand is piecewise smooth; at lag 0 below a pixel it
    /// approximates the closed form 2 pi h (A - 2 (px + py) h / pi + h^2 /
    /// pi) / A^2); and
    /// of the plane, 2 pi h dh / A (the sum over all lags: the T's of a row
    /// of pixels sum to the pitch; core PixelModel.LagsSumToThePlane).
    void lag_weights()
    {
        constexpr int kAngles = 256;
        const double px_um = m_px_um, py_um = m_py_um, area_um2 = px_um * py_um;
        const auto tri = [](double t_um, double pitch_um) {
            return std::max(0.0, pitch_um - std::fabs(t_um));
        };
        m_lag_weight.assign(m_h_um.size() * kLagCount, 0.0);
        m_area_weight.assign(m_h_um.size(), 0.0);
        const double dtheta = 0.5 * M_PI / kAngles;
        for (size_t n = 0; n < m_h_um.size(); ++n) {
            const double h_um = m_h_um[n], h_dh_um2 = m_h_dh_um2[n];
            m_area_weight[n] = 2.0 * M_PI * h_dh_um2 / area_um2;
            double* w = &m_lag_weight[n * kLagCount];
            for (int t = 0; t < kAngles; ++t) {
                const double theta = (t + 0.5) * dtheta;
                const double hx_um = h_um * std::cos(theta), hy_um = h_um * std::sin(theta);
                double tx[kLagSide], ty[kLagSide];
                for (int i = 0; i < kLagSide; ++i) {
                    tx[i] = tri(hx_um - i * px_um, px_um) + tri(hx_um + i * px_um, px_um);
                    ty[i] = tri(hy_um - i * py_um, py_um) + tri(hy_um + i * py_um, py_um);
                }
                for (int j = 0; j < kLagSide; ++j)
                    for (int i = 0; i < kLagSide; ++i)
                        w[j * kLagSide + i] += tx[i] * ty[j];
            }
            for (int lag = 0; lag < kLagCount; ++lag)
                w[lag] *= h_dh_um2 * dtheta / (area_um2 * area_um2);
        }
    }

    struct Sizes {
        std::vector<double> r_um, w, overlap_um2;  // [size node][distance node]
        bool limited = false;  ///< coupler-limited: overlap_um2 is cloud_lens_um2
    };
    std::vector<FilledImage> m_filled;  ///< the coupler-limited populations', in order
    const std::vector<PixelPopulation>& m_pops;
    const ImageOverlap& m_image;
    double m_px_um, m_py_um;
    std::vector<double> m_h_um;      ///< [distance node] its distance
    std::vector<double> m_h_dh_um2;  ///< [distance node] its cell's integral of h dh
    std::vector<Sizes> m_sizes;
    std::vector<double> m_lag_weight;   // [distance node][lag]
    std::vector<double> m_area_weight;  // [distance node]
};

/// The multiplicity of lag i of a symmetric field: i and -i.
inline double multiplicity(int i) { return i == 0 ? 1.0 : 2.0; }

/// The share of correlation_sum outside the lags |i|, |j| <= lags.
double dropped_correlation(const PixelModel::Moments& m, int lags)
{
    double kept = 0.0;
    for (int j = 0; j <= lags; ++j)
        for (int i = 0; i <= lags; ++i)
            kept += multiplicity(i) * multiplicity(j)
                    * m.correlation[static_cast<size_t>(j * kLagSide + i)];
    return m.correlation_sum > 0.0 ? std::max(0.0, 1.0 - kept / m.correlation_sum) : 0.0;
}

/// The logarithm the table interpolates means and variances in (both are
/// near exponential in the exposure's logarithm: a transmittance is
/// exp(-coverage exponent)); floored so that a zero stays finite.
inline double table_log(double x) { return std::log(std::max(x, 1e-300)); }

PixelModel::Moments lerp(const PixelModel::Moments& a, const PixelModel::Moments& b, double t)
{
    const auto l = [t](double x, double y) { return x + t * (y - x); };
    const auto g = [t](double x, double y) {
        return std::exp(table_log(x) + t * (table_log(y) - table_log(x)));
    };
    PixelModel::Moments m;
    m.mean                = g(a.mean, b.mean);
    m.variance            = g(a.variance, b.variance);
    m.correlation_sum     = l(a.correlation_sum, b.correlation_sum);
    m.developed_per_pixel = l(a.developed_per_pixel, b.developed_per_pixel);
    for (size_t k = 0; k < m.correlation.size(); ++k)
        m.correlation[k] = l(a.correlation[k], b.correlation[k]);
    return m;
}

/// cos(2 pi k / kGrid) for k in [0, kGrid): copula_filter's transforms.
constexpr int kGrid = 32;
const std::array<double, kGrid>& grid_cosines()
{
    static const std::array<double, kGrid> c = [] {
        std::array<double, kGrid> v {};
        for (int k = 0; k < kGrid; ++k)
            v[static_cast<size_t>(k)] = std::cos(2.0 * M_PI * k / kGrid);
        return v;
    }();
    return c;
}

}  // namespace

double copula_filter(const LagArray& rho, int lags, LagArray& f)
{
    static_assert(4 * kMaxLag + 1 <= kGrid, "the filter's autocorrelation must not wrap");
    const int support = filter_lags(lags);
    const auto& cs = grid_cosines();
    const auto cosine = [&](int u, int i) { return cs[static_cast<size_t>((u * i) % kGrid)]; };
    const auto at = [](const LagArray& a, int i, int j) {
        return a[static_cast<size_t>(j * kLagSide + i)];
    };
    // Power spectrum of the symmetric correlation on the lags kept
    // (a cosine transform: rho is even in each axis), its square root, and
    // back to the filter's lags. Both transforms are separable: one axis,
    // then the other.
    std::array<double, kGrid * kLagSide> half {};  // [u][j]: the sum over i
    for (int u = 0; u < kGrid; ++u)
        for (int j = 0; j <= lags; ++j) {
            double s = 0.0;
            for (int i = 0; i <= lags; ++i)
                s += multiplicity(i) * at(rho, i, j) * cosine(u, i);
            half[static_cast<size_t>(u * kLagSide + j)] = s;
        }
    std::vector<double> root(kGrid * kGrid);
    for (int v = 0; v < kGrid; ++v)
        for (int u = 0; u < kGrid; ++u) {
            double s = 0.0;
            for (int j = 0; j <= lags; ++j)
                s += multiplicity(j) * half[static_cast<size_t>(u * kLagSide + j)] * cosine(v, j);
            root[static_cast<size_t>(v * kGrid + u)] = std::sqrt(std::max(0.0, s));
        }
    std::array<double, kGrid * kLagSide> back {};  // [v][i]: the sum over u
    for (int v = 0; v < kGrid; ++v)
        for (int i = 0; i <= support; ++i) {
            double s = 0.0;
            for (int u = 0; u < kGrid; ++u)
                s += root[static_cast<size_t>(v * kGrid + u)] * cosine(u, i);
            back[static_cast<size_t>(v * kLagSide + i)] = s;
        }
    f.fill(0.0);
    double norm = 0.0;
    for (int j = 0; j <= support; ++j)
        for (int i = 0; i <= support; ++i) {
            double s = 0.0;
            for (int v = 0; v < kGrid; ++v)
                s += back[static_cast<size_t>(v * kLagSide + i)] * cosine(v, j);
            s /= kGrid * kGrid;
            f[static_cast<size_t>(j * kLagSide + i)] = s;
            norm += multiplicity(i) * multiplicity(j) * s * s;
        }
    if (!(norm > 0.0)) {
        f.fill(0.0);
        f[0] = 1.0;
        norm = 1.0;
    }
    for (double& t : f)
        t /= std::sqrt(norm);
    // The cut filter's autocorrelation against rho, at every lag it reaches.
    const int side = 2 * support + 1;
    std::vector<double> full(static_cast<size_t>(side * side));
    for (int b = -support; b <= support; ++b)
        for (int a = -support; a <= support; ++a)
            full[static_cast<size_t>((b + support) * side + a + support)]
                = at(f, std::abs(a), std::abs(b));
    double error = 0.0;
    for (int j = 0; j < side; ++j)
        for (int i = 0; i < side; ++i) {
            double acf = 0.0;
            for (int b = 0; b + j < side; ++b)
                for (int a = 0; a + i < side; ++a)
                    acf += full[static_cast<size_t>(b * side + a)]
                           * full[static_cast<size_t>((b + j) * side + a + i)];
            const double want = (i <= kMaxLag && j <= kMaxLag) ? at(rho, i, j) : 0.0;
            error = std::max(error, std::fabs(acf - want));
        }
    return error;
}

PixelModel::Moments PixelModel::compute(const std::vector<PixelPopulation>& populations,
                                        double px_um, double py_um, double v,
                                        const ImageOverlap& image, double log_factor,
                                        int distance_nodes)
{
    return Integrator(populations, px_um, py_um, image,
                      distance_nodes > 0 ? distance_nodes : kDistanceNodes)(
        v, std::exp(-log_factor));
}

PixelModel::PixelModel(const std::vector<PixelPopulation>& populations, double px_um,
                       double py_um, const ImageOverlap& image, double max_log_factor,
                       int nthreads, double max_density, const ShapeSampling* shape)
{
    const double floor_t = std::pow(10.0, -max_density);  // the clamp's (0 without)
    const Integrator integrate(populations, px_um, py_um, image);
    const int n   = (kOctavesBelow + kOctavesAbove) * kPerOctave;
    m_log_v0      = std::log(kGrey) - kOctavesBelow * std::log(2.0);
    const double step = std::log(2.0) / kPerOctave;
    m_inv_step    = 1.0 / step;
    const auto value = [&](double i) { return std::exp(m_log_v0 + i * step); };
    const int rows = max_log_factor > 0.0
                         ? static_cast<int>(std::ceil(max_log_factor / kLogFactorStep)) + 1
                         : 1;
    const auto factor = [](double l) { return l > 0.0 ? std::exp(-l) : 1.0; };
    // Every node (and every midpoint the errors are measured at) is
    // independent of the others: computed in parallel, each into its own
    // slot, so the table is the same for any thread count.
    const size_t cols = static_cast<size_t>(n) + 2;  // v = 0, then n + 1 values
    const auto node_v = [&](size_t i) { return i == 0 ? 0.0 : value(static_cast<double>(i) - 1.0); };
    std::atomic<bool> stop { false };
    const auto each = [&](size_t count, const std::function<void(size_t)>& body) {
        parallel_for(static_cast<int64_t>(count), nthreads, stop,
                     [&](int, int64_t k) { body(static_cast<size_t>(k)); });
    };
    // The sums over sizes once per exposure (node and midpoint), for every
    // log factor (they scale with it).
    std::vector<Integrator::Sums> at_node(cols), at_mid(static_cast<size_t>(n));
    each(cols + static_cast<size_t>(n), [&](size_t k) {
        if (k < cols)
            at_node[k] = integrate.sums(node_v(k));
        else
            at_mid[k - cols] = integrate.sums(value(static_cast<double>(k - cols) + 0.5));
    });
    m_rows.assign(static_cast<size_t>(rows), std::vector<Moments>(cols));
    each(rows * cols, [&](size_t k) {
        const size_t r = k / cols, i = k % cols;
        m_rows[r][i]
            = integrate.moments(at_node[i], factor(static_cast<double>(r) * kLogFactorStep));
    });
    // Interpolation errors: at exposure midpoints of every row, and at
    // log-factor midpoints of every exposure node.
    const size_t v_mid = static_cast<size_t>(rows) * static_cast<size_t>(n);
    const size_t l_mid = static_cast<size_t>(rows - 1) * cols;
    std::vector<double> mean_error(v_mid + l_mid, 0.0), sd_error(v_mid + l_mid, 0.0);
    each(v_mid + l_mid, [&](size_t k) {
        Moments exact, interp;
        if (k < v_mid) {
            const size_t r = k / static_cast<size_t>(n), i = k % static_cast<size_t>(n);
            exact  = integrate.moments(at_mid[i], factor(static_cast<double>(r) * kLogFactorStep));
            interp = lerp(m_rows[r][i + 1], m_rows[r][i + 2], 0.5);
        } else {
            const size_t r = (k - v_mid) / cols, i = (k - v_mid) % cols;
            exact  = integrate.moments(at_node[i],
                                     factor((static_cast<double>(r) + 0.5) * kLogFactorStep));
            interp = lerp(m_rows[r][i], m_rows[r + 1][i], 0.5);
        }
        if (exact.mean > 0.0 && interp.mean > 0.0)
            mean_error[k] = std::fabs(
                std::log(std::max(interp.mean, floor_t) / std::max(exact.mean, floor_t)));
        const bool clamped = exact.mean < floor_t && interp.mean < floor_t;
        if (exact.variance > 0.0 && !clamped)
            sd_error[k] = std::fabs(std::sqrt(interp.variance / exact.variance) - 1.0);
    });
    for (size_t k = 0; k < mean_error.size(); ++k) {
        m_max_mean_error = std::max(m_max_mean_error, mean_error[k]);
        m_max_sd_error   = std::max(m_max_sd_error, sd_error[k]);
    }
    // The lags kept: the fewest that leave at most kDroppedCorrelation of
    // the correlation out at every node.
    m_lags = -1;
    for (int k = 0; k <= kMaxLag && m_lags < 0; ++k) {
        double worst = 0.0;
        for (const auto& row : m_rows)
            for (const Moments& m : row)
                worst = std::max(worst, dropped_correlation(m, k));
        m_max_dropped = worst;
        if (worst <= kDroppedCorrelation)
            m_lags = k;
    }
    if (shape)
        sample_shapes(populations, px_um, py_um, max_density, *shape, each);
    // The nodes as drawn: each with its copula filter, for the normals'
    // correlation that the law (skewed_draw's, or the sampled shape) bends
    // into the model's.
    m_nodes.assign(static_cast<size_t>(rows), std::vector<Node>(cols));
    std::vector<double> copula_error(rows * cols, 0.0);
    each(rows * cols, [&](size_t k) {
        const size_t r = k / cols, i = k % cols;
        const Moments& m = m_rows[r][i];
        Node& node       = m_nodes[r][i];
        node.log_mean     = table_log(m.mean);
        node.log_variance = table_log(m.variance);
        if (m_lags < 0)
            return;
        LagArray normal {};
        for (size_t j = 0; j < normal.size(); ++j)
            normal[j] = shaped() ? shape_normal_correlation(m_shapes[r][i], m.correlation[j])
                                 : copula_normal_correlation(m.mean, m.variance, m.correlation[j]);
        copula_error[k] = copula_filter(normal, m_lags, node.taps);
    });
    for (double e : copula_error)
        m_max_copula_error = std::max(m_max_copula_error, e);
}

void PixelModel::sample_shapes(
    const std::vector<PixelPopulation>& populations, double px_um, double py_um,
    double max_density, const ShapeSampling& sampling,
    const std::function<void(size_t, const std::function<void(size_t)>&)>& each)
{
    const size_t rows = m_rows.size(), cols = m_rows.front().size();
    // The sampled grid: exposure node 0 (v = 0) and every kShapeStride-th
    // from node 1 to the last; every kShapeRowStride-th row and the last.
    std::vector<size_t> grid_cols { 0 }, grid_rows;
    for (size_t i = 1; i < cols; i += kShapeStride)
        grid_cols.push_back(i);
    if (grid_cols.back() != cols - 1)
        grid_cols.push_back(cols - 1);
    for (size_t r = 0; r < rows; r += kShapeRowStride)
        grid_rows.push_back(r);
    if (grid_rows.back() != rows - 1)
        grid_rows.push_back(rows - 1);
    // Which grid node each takes its shape from: itself, or the last one
    // sampled in its row where the moments have not moved (kShapeReuse).
    const size_t gc = grid_cols.size(), gr = grid_rows.size();
    std::vector<size_t> source(gc * gr);
    std::vector<size_t> sampled;
    const auto near = [](double a, double b) {
        return std::fabs(a - b) <= kShapeReuse * std::max(std::fabs(a), std::fabs(b));
    };
    for (size_t b = 0; b < gr; ++b) {
        size_t last = gc;  // none yet
        for (size_t a = 0; a < gc; ++a) {
            const size_t k = b * gc + a;
            if (last < gc) {
                const Moments& m0 = m_rows[grid_rows[b]][grid_cols[last]];
                const Moments& m1 = m_rows[grid_rows[b]][grid_cols[a]];
                if (near(m0.mean, m1.mean) && near(m0.variance, m1.variance)) {
                    source[k] = b * gc + last;
                    continue;
                }
            }
            source[k] = k;
            last      = a;
            sampled.push_back(k);
        }
    }
    std::vector<PixelShape> grid(gc * gr);
    each(sampled.size(), [&](size_t s) {
        const size_t k = sampled[s], b = k / gc, a = k % gc;
        const size_t r = grid_rows[b], i = grid_cols[a];
        const double v = i == 0 ? 0.0
                                : std::exp(m_log_v0 + static_cast<double>(i - 1) / m_inv_step);
        grid[k] = sample_pixel_shape(populations, *sampling.layer, px_um, py_um,
                                     sampling.samples, max_density, v,
                                     static_cast<double>(r) * kLogFactorStep,
                                     hash_ids(0x5a4e7u, r, i));
    });
    for (size_t k = 0; k < grid.size(); ++k)
        grid[k] = grid[source[k]];
    m_shapes_sampled = static_cast<int>(sampled.size());
    // Every node's shape: linear between the grid's nodes in both axes,
    // standardised again.
    const auto bracket = [](const std::vector<size_t>& g, size_t x, size_t& lo, double& t) {
        lo = static_cast<size_t>(std::upper_bound(g.begin(), g.end(), x) - g.begin()) - 1;
        if (lo + 1 >= g.size()) {
            lo = g.size() - 1;
            t  = 0.0;
            return;
        }
        t = static_cast<double>(x - g[lo]) / static_cast<double>(g[lo + 1] - g[lo]);
    };
    m_shapes.assign(rows, std::vector<PixelShape>(cols));
    each(rows * cols, [&](size_t k) {
        const size_t r = k / cols, i = k % cols;
        size_t a, b;
        double ta, tb;
        bracket(grid_cols, i, a, ta);
        bracket(grid_rows, r, b, tb);
        const size_t a1 = std::min(a + 1, gc - 1), b1 = std::min(b + 1, gr - 1);
        PixelShape& s = m_shapes[r][i];
        for (size_t j = 0; j < s.size(); ++j)
            s[j] = (1.0 - tb) * ((1.0 - ta) * grid[b * gc + a][j] + ta * grid[b * gc + a1][j])
                   + tb * ((1.0 - ta) * grid[b1 * gc + a][j] + ta * grid[b1 * gc + a1][j]);
        standardise_shape(s);
    });
}

std::string PixelModel::serialize() const
{
    static_assert(std::is_trivially_copyable_v<Moments> && std::is_trivially_copyable_v<Node>);
    Bytes b;
    b.put(m_log_v0);
    b.put(m_inv_step);
    b.put(static_cast<uint64_t>(m_rows.size()));
    for (size_t r = 0; r < m_rows.size(); ++r) {
        b.put(m_rows[r]);
        b.put(m_nodes[r]);
    }
    b.put(m_lags);
    b.put(m_max_dropped);
    b.put(m_max_copula_error);
    b.put(m_max_mean_error);
    b.put(m_max_sd_error);
    b.put(static_cast<uint64_t>(m_shapes.size()));
    for (const std::vector<PixelShape>& row : m_shapes)
        b.put(row);
    b.put(m_shapes_sampled);
    return std::move(b.data);
}

std::shared_ptr<const PixelModel> PixelModel::deserialize(const std::string& bytes)
{
    Bytes b;
    b.data = bytes;
    std::shared_ptr<PixelModel> m(new PixelModel());
    m->m_log_v0         = b.get<double>();
    m->m_inv_step       = b.get<double>();
    const uint64_t rows = b.get<uint64_t>();
    if (!b.ok || rows == 0 || rows > bytes.size())
        return nullptr;
    for (uint64_t r = 0; r < rows && b.ok; ++r) {
        m->m_rows.push_back(b.get_vector<Moments>());
        m->m_nodes.push_back(b.get_vector<Node>());
        // Every row as long as the first, each node beside its moments.
        if (m->m_rows.back().size() < 2 || m->m_nodes.back().size() != m->m_rows.back().size()
            || m->m_rows.back().size() != m->m_rows.front().size())
            return nullptr;
    }
    m->m_lags             = b.get<int>();
    m->m_max_dropped      = b.get<double>();
    m->m_max_copula_error = b.get<double>();
    m->m_max_mean_error   = b.get<double>();
    m->m_max_sd_error     = b.get<double>();
    // A shaped model's shapes: one row beside each row of moments.
    const uint64_t shape_rows = b.get<uint64_t>();
    if (!b.ok || (shape_rows != 0 && shape_rows != rows))
        return nullptr;
    for (uint64_t r = 0; r < shape_rows && b.ok; ++r) {
        m->m_shapes.push_back(b.get_vector<PixelShape>());
        if (m->m_shapes.back().size() != m->m_rows.front().size())
            return nullptr;
    }
    m->m_shapes_sampled = b.get<int>();
    if (!b.done() || m->m_lags > kMaxLag)
        return nullptr;
    return m;
}

PixelModel::Position PixelModel::position(double v, double log_factor) const
{
    Position p;
    const size_t last = m_rows.front().size() - 1;
    if (v > 0.0) {
        const double t = (std::log(v) - m_log_v0) * m_inv_step;
        if (t <= 0.0) {
            p.i0 = p.i1 = 1;
        } else if (static_cast<size_t>(t) + 2 > last) {
            p.i0 = p.i1 = last;
        } else {
            const size_t i = static_cast<size_t>(t);
            p.i0 = i + 1;
            p.i1 = i + 2;
            p.ti = t - static_cast<double>(i);
        }
    }
    const double t = log_factor / kLogFactorStep;
    if (m_rows.size() > 1 && t > 0.0) {
        const size_t r = static_cast<size_t>(t);
        if (r + 1 >= m_rows.size()) {
            p.r0 = p.r1 = m_rows.size() - 1;
        } else {
            p.r0 = r;
            p.r1 = r + 1;
            p.tr = t - static_cast<double>(r);
        }
    }
    return p;
}

PixelModel::Moments PixelModel::at(double v, double log_factor) const
{
    const Position p = position(v, log_factor);
    const auto row = [&](size_t r) { return lerp(m_rows[r][p.i0], m_rows[r][p.i1], p.ti); };
    return lerp(row(p.r0), row(p.r1), p.tr);
}

double PixelModel::developed_per_pixel_at(double v, double log_factor) const
{
    // at()'s interpolation of this one field (the same arithmetic).
    const Position p = position(v, log_factor);
    const auto l     = [](double x, double y, double t) { return x + t * (y - x); };
    const auto row   = [&](size_t r) {
        return l(m_rows[r][p.i0].developed_per_pixel, m_rows[r][p.i1].developed_per_pixel, p.ti);
    };
    return l(row(p.r0), row(p.r1), p.tr);
}

template <int K>
void PixelModel::draw_at(double v, double log_factor, Draw& out) const
{
    const Position p = position(v, log_factor);
    const Node* n[4] = { &m_nodes[p.r0][p.i0], &m_nodes[p.r0][p.i1], &m_nodes[p.r1][p.i0],
                         &m_nodes[p.r1][p.i1] };
    const double w[4] = { (1.0 - p.tr) * (1.0 - p.ti), (1.0 - p.tr) * p.ti, p.tr * (1.0 - p.ti),
                          p.tr * p.ti };
    double log_mean = 0.0, log_variance = 0.0;
    for (int c = 0; c < 4; ++c) {
        log_mean += w[c] * n[c]->log_mean;
        log_variance += w[c] * n[c]->log_variance;
    }
    for (int j = 0; j <= K; ++j)
        for (int i = 0; i <= K; ++i) {
            const size_t t = static_cast<size_t>(j * kLagSide + i);
            double tap = 0.0;
            for (int c = 0; c < 4; ++c)
                tap += w[c] * n[c]->taps[t];
            out.taps[t] = tap;
        }
    out.mean     = std::exp(log_mean);
    out.variance = std::exp(log_variance);
    if (shaped()) {
        const size_t r[4] = { p.r0, p.r0, p.r1, p.r1 }, i[4] = { p.i0, p.i1, p.i0, p.i1 };
        for (int c = 0; c < 4; ++c) {
            out.shape[c]        = &m_shapes[r[c]][i[c]];
            out.shape_weight[c] = w[c];
        }
    }
}

namespace {

/// skewed_draw's law for (mean, variance): two Wilson-Hilferty cubes
/// m (a + b z)^3, Gamma(k = m^2 / V) each, one for the open part (mean m
/// = mean) and one for the covered part (m = 1 - mean, taken at -z so that
/// both grow with z), weighted 1 - mean and mean, and the scale that
/// gives their sum the variance V; and the sum's Hermite coefficients c1,
/// c2, c3 (He1, He2, He3) before that scale. False where the draw is its
/// mean (no variance, or a mean of 0 or 1).
struct SkewedLaw {
    double m_open = 0.0, a_open = 0.0, b_open = 0.0;
    double m_covered = 0.0, a_covered = 0.0, b_covered = 0.0;
    double weight_covered = 0.0, scale = 1.0;
    double c1 = 0.0, c2 = 0.0, c3 = 0.0;
};

[[gnu::always_inline]] inline bool skewed_law(double mean, double variance, SkewedLaw& law)
{
    // Every field computed whatever the answer (no branch: skewed_draws'
    // loop is vectorised); where it is false they are not used.
    const bool drawn = mean > 0.0 && mean < 1.0 && variance > 0.0;
    // (a + b z)^3 = (a^3 + 3 a b^2) + (3 a^2 b + 3 b^3) He1 + 3 a b^2 He2 + b^3 He3.
    const auto cube = [variance](double m, double& a, double& b, double& c1, double& c2,
                                 double& c3) {
        const double c = variance / (9.0 * m * m);
        a  = 1.0 - c;
        b  = std::sqrt(c);
        c1 = m * (3.0 * a * a * b + 3.0 * b * b * b);
        c2 = m * 3.0 * a * b * b;
        c3 = m * b * b * b;
    };
    double o1, o2, o3, k1, k2, k3;
    law.m_open    = mean;
    law.m_covered = 1.0 - mean;
    cube(law.m_open, law.a_open, law.b_open, o1, o2, o3);
    cube(law.m_covered, law.a_covered, law.b_covered, k1, k2, k3);
    // 1 - cube(-z): He1 and He3 keep their sign, He2 flips.
    const double w     = mean;
    law.weight_covered = w;
    law.c1             = (1.0 - w) * o1 + w * k1;
    law.c2             = (1.0 - w) * o2 - w * k2;
    law.c3             = (1.0 - w) * o3 + w * k3;
    const double v     = law.c1 * law.c1 + 2.0 * law.c2 * law.c2 + 6.0 * law.c3 * law.c3;
    law.scale          = v > 0.0 ? std::sqrt(variance / v) : 1.0;
    return drawn;
}

}  // namespace

void skewed_draws(const double* mean, const double* variance, const double* z, double* out,
                  size_t n)
{
    // A fraction in [0, 1] with the model's mean and variance, skewed as
    // the Boolean model's pixels are where they are skewed most: where most
    // of the pixel is open its covered part is a few images (right-skewed,
    // mass near 0: Gamma), where most is covered its open part is a few
    // holes (likewise). In between, both at once: the two Gamma laws
    // (Wilson-Hilferty cubes of the same normal z, the pixel's correlated
    // normal: a Gaussian copula) weighted by the mean, so that the skew
    // passes through 0 at a mean of 1/2 continuously (a switch from one
    // Gamma to its mirror there made pixels 24% too spread on VISION3
    // 500T's blue layer near that mean: docs/performance), and scaled about
    // the mean to the model's variance. No branch: the compiler vectorises
    // the loop, and every lane computes what the scalar code would.
    const auto cube = [](double m, double a, double b, double z) {
        const double w = std::max(0.0, a + z * b);
        return m * w * w * w;
    };
    for (size_t i = 0; i < n; ++i) {
        SkewedLaw law;
        const bool drawn = skewed_law(mean[i], variance[i], law);
        const double w   = law.weight_covered;
        const double t   = (1.0 - w) * cube(law.m_open, law.a_open, law.b_open, z[i])
                         + w * (1.0 - cube(law.m_covered, law.a_covered, law.b_covered, -z[i]));
        const double d   = std::clamp(mean[i] + law.scale * (t - mean[i]), 0.0, 1.0);
        out[i]           = drawn ? d : mean[i];
    }
}

double skewed_draw(double mean, double variance, double z)
{
    double t = mean;
    skewed_draws(&mean, &variance, &z, &t, 1);
    return t;
}

double copula_normal_correlation(double mean, double variance, double rho)
{
    SkewedLaw law;
    if (!skewed_law(mean, variance, law) || !(rho > 0.0))
        return std::max(0.0, rho);
    if (rho >= 1.0)
        return 1.0;
    const double w1 = law.c1 * law.c1, w2 = 2.0 * law.c2 * law.c2, w3 = 6.0 * law.c3 * law.c3;
    const double total = w1 + w2 + w3;
    // Increasing on [0, 1] from 0 to 1: bisection to 1e-12.
    double lo = 0.0, hi = 1.0;
    for (int i = 0; i < 42; ++i) {
        const double r = 0.5 * (lo + hi);
        ((w1 * r + w2 * r * r + w3 * r * r * r) / total < rho ? lo : hi) = r;
    }
    return 0.5 * (lo + hi);
}

namespace {

/// sample_pixel_transmittance's draws, with its filter on K lags each way:
/// each pixel's law and correlated normal, then all of the block's draws.
template <int K>
void draw_block(const PixelModel& model, int64_t tw, int64_t th, const double* v,
                const double* log_factor, const double* z, double* transmittance)
{
    const int64_t zw = tw + 2 * K;
    const size_t n = static_cast<size_t>(tw * th);
    std::vector<double> mean(n), variance(n), normal(n);
    PixelModel::Draw d;
    for (int64_t j = 0; j < th; ++j)
        for (int64_t i = 0; i < tw; ++i) {
            const size_t o = static_cast<size_t>(j * tw + i);
            model.draw_at<K>(v[o], log_factor ? log_factor[o] : 0.0, d);
            // The filter on the normals around (i, j): each tap (a, b)
            // weighs the normals at (+-a, +-b); its sum of squares, which
            // interpolation leaves within rounding of 1 only at nodes,
            // normalises.
            const double* centre = &z[static_cast<size_t>((j + K) * zw + i + K)];
            double noise = 0.0, norm = 0.0;
            for (int b = 0; b <= K; ++b)
                for (int a = 0; a <= K; ++a) {
                    const double t = d.taps[static_cast<size_t>(b * kLagSide + a)];
                    const int64_t dx = a, dy = b * zw;
                    double s = centre[dy + dx];
                    if (a > 0)
                        s += centre[dy - dx];
                    if (b > 0) {
                        s += centre[-dy + dx];
                        if (a > 0)
                            s += centre[-dy - dx];
                    }
                    noise += t * s;
                    norm += multiplicity(a) * multiplicity(b) * t * t;
                }
            mean[o]     = d.mean;
            variance[o] = d.variance;
            normal[o]   = norm > 0.0 ? noise / std::sqrt(norm) : 0.0;
            if (model.shaped()) {
                // The sampled shape at the pixel's normal: mean + sd S(z).
                double s = 0.0;
                for (int c = 0; c < 4; ++c)
                    s += d.shape_weight[c] * shape_value(*d.shape[c], normal[o]);
                transmittance[o] = std::clamp(d.mean + std::sqrt(d.variance) * s, 0.0, 1.0);
            }
        }
    if (!model.shaped())
        skewed_draws(mean.data(), variance.data(), normal.data(), transmittance, n);
}

}  // namespace

void sample_pixel_transmittance(const PixelModel& model, uint64_t key, int64_t x0, int64_t y0,
                                int64_t x1, int64_t y1, const double* v,
                                const double* log_factor, double* transmittance)
{
    const int64_t tw = x1 - x0, th = y1 - y0;
    const int k = filter_lags(std::max(model.lags(), 0));
    // Standard normals of the block and a margin of the filter's lags, each
    // keyed by its absolute pixel.
    const int64_t zw = tw + 2 * k;
    std::vector<double> z(static_cast<size_t>(zw * (th + 2 * k)));
    std::vector<double> u(z.size());
    for (int64_t j = 0; j < th + 2 * k; ++j)
        for (int64_t i = 0; i < zw; ++i) {
            const uint64_t id = hash_ids(key, static_cast<uint64_t>(x0 + i - k),
                                         static_cast<uint64_t>(y0 + j - k));
            u[static_cast<size_t>(j * zw + i)] = uniform_from_bits53(counter_u64(id, 0));
        }
    normal_quantiles(u.data(), z.data(), z.size());
    static_assert(kMaxLag == 4, "draw_block is instantiated for 1 to 4 lags");
    switch (k) {  // filter_lags: 1 to kMaxLag
    case 1: draw_block<1>(model, tw, th, v, log_factor, z.data(), transmittance); break;
    case 2: draw_block<2>(model, tw, th, v, log_factor, z.data(), transmittance); break;
    case 3: draw_block<3>(model, tw, th, v, log_factor, z.data(), transmittance); break;
    default: draw_block<4>(model, tw, th, v, log_factor, z.data(), transmittance); break;
    }
}

}  // namespace filmgrain
