// MODEL.md section 5 at pixel scale: the Boolean model's pixel statistics.
#include "pixel_model.h"

#include <algorithm>
#include <cmath>

#include "dye.h"
#include "rng.h"
#include "sampling.h"

namespace filmgrain {

namespace {

/// size_quadrature's range and nodes (145: step 1/8).
constexpr double kSizeZ  = kSizeQuadratureZ;
constexpr int kSizeNodes = 145;
/// Distances h at which the covariance is integrated (midpoint rule on
/// [0, largest diameter]).
constexpr int kDistanceNodes = 512;
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

const std::vector<SizeNode>& size_quadrature(const Population& population)
{
    // Two fixed rules, made once (the expected curves ask for them at every
    // exposure they evaluate).
    static const std::vector<SizeNode> single { SizeNode { 0.0, 1.0 } };
    static const std::vector<SizeNode> trapezoid = [] {
        std::vector<SizeNode> nodes(kSizeNodes);
        const double dz = 2.0 * kSizeZ / (kSizeNodes - 1);
        for (int k = 0; k < kSizeNodes; ++k) {
            const double z = -kSizeZ + k * dz;
            const double w = std::exp(-0.5 * z * z) / std::sqrt(2.0 * M_PI) * dz;
            nodes[static_cast<size_t>(k)] = { z, (k == 0 || k == kSizeNodes - 1) ? 0.5 * w : w };
        }
        return nodes;
    }();
    return population.diameter_log_sigma > 0.0 ? trapezoid : single;
}

double coverage_exponent(const std::vector<PixelPopulation>& populations, double v)
{
    double k = 0.0;
    for (const PixelPopulation& pp : populations) {
        double sum = 0.0;
        for (const SizeNode& node : size_quadrature(*pp.population)) {
            const double r_um  = pp.grains->radius_at_z_um(node.z);
            const double a_um2 = M_PI * r_um * r_um;
            sum += node.weight * a_um2
                   * pixel_develop_probability(pp, pp.photons_per_value_um2 * v * a_um2);
        }
        k += pp.population->grains_per_um2 * sum;
    }
    return k;
}

namespace {

/// The quadrature and the image overlaps of a layer's populations, prepared once.
class Integrator {
public:
    Integrator(const std::vector<PixelPopulation>& pops, double px_um, double py_um,
               const ImageOverlap& image)
        : m_pops(pops), m_image(image), m_px_um(px_um), m_py_um(py_um)
    {
        double h_max_um = 0.0;
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
            }
            m_sizes.push_back(std::move(sz));
        }
        m_dh_um = h_max_um / kDistanceNodes;
        for (Sizes& sz : m_sizes)
            for (size_t k = 0; k < sz.r_um.size(); ++k)
                for (int j = 0; j < kDistanceNodes; ++j)
                    sz.overlap_um2.push_back(image.overlap_um2(sz.r_um[k], (j + 0.5) * m_dh_um));
    }

    /// Moments at exposure value v, every P times `factor` (MODEL.md 10).
    PixelModel::Moments operator()(double v, double factor = 1.0) const
    {
        PixelModel::Moments m;
        std::vector<double> g(kDistanceNodes, 0.0);
        double exponent = 0.0, developed = 0.0;
        for (size_t p = 0; p < m_pops.size(); ++p) {
            const PixelPopulation& pp = m_pops[p];
            const Sizes& sz           = m_sizes[p];
            const double n            = pp.population->grains_per_um2;
            for (size_t k = 0; k < sz.r_um.size(); ++k) {
                const double a_um2 = M_PI * sz.r_um[k] * sz.r_um[k];
                const double pd
                    = factor * pixel_develop_probability(pp, pp.photons_per_value_um2 * v * a_um2);
                const double nw = n * sz.w[k] * pd;
                exponent += nw * m_image.blocking_um2(sz.r_um[k]);
                developed += nw;
                const double* overlap = &sz.overlap_um2[k * kDistanceNodes];
                for (int j = 0; j < kDistanceNodes; ++j)
                    g[static_cast<size_t>(j)] += nw * overlap[j];
            }
        }
        m.mean = std::exp(-exponent);
        m.developed_per_pixel = developed * m_px_um * m_py_um;
        // Pixel variance and neighbour covariances: the covariance C(h)
        // against the overlap of a pixel with itself (or its neighbour)
        // shifted by h, averaged over directions (valid while the largest
        // grain is smaller than the pixel).
        const double px = m_px_um, py = m_py_um, dh = m_dh_um;
        const double a2 = px * py * px * py;
        double var = 0.0, cx = 0.0, cy = 0.0, cd = 0.0;
        for (int j = 0; j < kDistanceNodes; ++j) {
            const double h = (j + 0.5) * dh;  // micrometres
            const double c = m.mean * m.mean * std::expm1(g[static_cast<size_t>(j)]);
            var += c * 2.0 * M_PI * h * (px * py - 2.0 / M_PI * (px + py) * h + h * h / M_PI);
            cx += c * h * (2.0 * h * py - h * h);
            cy += c * h * (2.0 * h * px - h * h);
            cd += c * h * h * h / 2.0;
        }
        m.variance = std::max(0.0, var * dh / a2);
        if (m.variance > 0.0) {
            m.rho_x  = cx * dh / a2 / m.variance;
            m.rho_y  = cy * dh / a2 / m.variance;
            m.rho_xy = cd * dh / a2 / m.variance;
        }
        return m;
    }

private:
    struct Sizes {
        std::vector<double> r_um, w, overlap_um2;  // [size node][distance node]
    };
    const std::vector<PixelPopulation>& m_pops;
    const ImageOverlap& m_image;
    double m_px_um, m_py_um, m_dh_um = 0.0;
    std::vector<Sizes> m_sizes;
};

PixelModel::Moments lerp(const PixelModel::Moments& a, const PixelModel::Moments& b, double t)
{
    const auto l = [t](double x, double y) { return x + t * (y - x); };
    return { l(a.mean, b.mean), l(a.variance, b.variance), l(a.rho_x, b.rho_x),
             l(a.rho_y, b.rho_y), l(a.rho_xy, b.rho_xy),
             l(a.developed_per_pixel, b.developed_per_pixel) };
}

}  // namespace

PixelModel::Moments PixelModel::compute(const std::vector<PixelPopulation>& populations,
                                        double px_um, double py_um, double v,
                                        const ImageOverlap& image, double log_factor)
{
    return Integrator(populations, px_um, py_um, image)(v, std::exp(-log_factor));
}

PixelModel::PixelModel(const std::vector<PixelPopulation>& populations, double px_um,
                       double py_um, const ImageOverlap& image, double max_log_factor)
{
    const Integrator moments(populations, px_um, py_um, image);
    const int n   = (kOctavesBelow + kOctavesAbove) * kPerOctave;
    m_log_v0      = std::log(kGrey) - kOctavesBelow * std::log(2.0);
    const double step = std::log(2.0) / kPerOctave;
    m_inv_step    = 1.0 / step;
    const auto value = [&](double i) { return std::exp(m_log_v0 + i * step); };
    const int rows = max_log_factor > 0.0
                         ? static_cast<int>(std::ceil(max_log_factor / kLogFactorStep)) + 1
                         : 1;
    const auto factor = [](double l) { return l > 0.0 ? std::exp(-l) : 1.0; };
    const auto note_error = [&](const Moments& exact, const Moments& interp) {
        if (exact.mean > 0.0)
            m_max_mean_error = std::max(m_max_mean_error,
                                        std::fabs(interp.mean - exact.mean) / exact.mean);
        if (exact.variance > 0.0)
            m_max_sd_error = std::max(m_max_sd_error,
                                      std::fabs(std::sqrt(interp.variance / exact.variance) - 1.0));
    };
    for (int r = 0; r < rows; ++r) {
        const double f = factor(r * kLogFactorStep);
        std::vector<Moments> nodes;
        nodes.push_back(moments(0.0, f));
        for (int i = 0; i <= n; ++i)
            nodes.push_back(moments(value(i), f));
        for (int i = 0; i < n; ++i)
            note_error(moments(value(i + 0.5), f),
                       lerp(nodes[static_cast<size_t>(i) + 1], nodes[static_cast<size_t>(i) + 2], 0.5));
        m_rows.push_back(std::move(nodes));
    }
    // Between log-factor nodes, at every exposure node.
    for (int r = 0; r + 1 < rows; ++r) {
        const double f = factor((r + 0.5) * kLogFactorStep);
        for (int i = 0; i <= n + 1; ++i)
            note_error(moments(i == 0 ? 0.0 : value(i - 1), f),
                       lerp(m_rows[static_cast<size_t>(r)][static_cast<size_t>(i)],
                            m_rows[static_cast<size_t>(r) + 1][static_cast<size_t>(i)], 0.5));
    }
}

PixelModel::Moments PixelModel::row_at(const std::vector<Moments>& row, double v) const
{
    if (!(v > 0.0))
        return row.front();
    const double t = (std::log(v) - m_log_v0) * m_inv_step;
    if (t <= 0.0)
        return row[1];
    const size_t i = static_cast<size_t>(t);
    if (i + 2 >= row.size())
        return row.back();
    return lerp(row[i + 1], row[i + 2], t - static_cast<double>(i));
}

PixelModel::Moments PixelModel::at(double v, double log_factor) const
{
    const double t = log_factor / kLogFactorStep;
    if (m_rows.size() == 1 || !(t > 0.0))
        return row_at(m_rows.front(), v);
    const size_t r = static_cast<size_t>(t);
    if (r + 1 >= m_rows.size())
        return row_at(m_rows.back(), v);
    return lerp(row_at(m_rows[r], v), row_at(m_rows[r + 1], v), t - static_cast<double>(r));
}

void moving_average_taps(double rho, double taps[3])
{
    // Correlation of [b, 1, b] with itself shifted by one: 2 b / (1 + 2 b^2),
    // at most 1/sqrt(2) (b = 1/sqrt(2)).
    const double r = std::clamp(rho, -M_SQRT1_2, M_SQRT1_2);
    const double b = std::fabs(r) < 1e-12 ? 0.0 : (1.0 - std::sqrt(1.0 - 2.0 * r * r)) / (2.0 * r);
    const double norm = 1.0 / std::sqrt(1.0 + 2.0 * b * b);
    taps[0] = taps[2] = b * norm;
    taps[1] = norm;
}

double skewed_draw(double mean, double variance, double z)
{
    // A fraction in [0, 1] with the model's mean and variance: where most
    // of the pixel is open (mean >= 1/2) its covered part, else its open
    // part, is Gamma distributed: the Boolean model's few covering discs
    // (or few remaining holes) make that part skewed to the right, with
    // mass near 0. Gamma(shape k = m^2 / V, scale V / m) by the
    // Wilson-Hilferty cube of a normal (z, the pixel's correlated normal:
    // a Gaussian copula).
    const bool open = mean >= 0.5;
    const double m  = open ? 1.0 - mean : mean;
    if (!(m > 0.0) || !(variance > 0.0))
        return mean;
    const double k = m * m / variance;
    const double c = 1.0 / (9.0 * k);
    const double w = std::max(0.0, 1.0 - c + z * std::sqrt(c));
    const double g = std::min(1.0, m * w * w * w);
    return open ? 1.0 - g : g;
}

void sample_pixel_transmittance(const PixelModel& model, uint64_t key, int64_t x0, int64_t y0,
                                int64_t x1, int64_t y1, const double* v,
                                const double* log_factor, double* transmittance)
{
    const int64_t tw = x1 - x0, th = y1 - y0;
    // Standard normals of the block and a one-pixel margin, each keyed by
    // its absolute pixel.
    const int64_t zw = tw + 2;
    std::vector<double> z(static_cast<size_t>(zw * (th + 2)));
    for (int64_t j = 0; j < th + 2; ++j)
        for (int64_t i = 0; i < zw; ++i) {
            const uint64_t id = hash_ids(key, static_cast<uint64_t>(x0 + i - 1),
                                         static_cast<uint64_t>(y0 + j - 1));
            const double u = (static_cast<double>(counter_u64(id, 0) >> 11) + 0.5) * 0x1.0p-53;
            z[static_cast<size_t>(j * zw + i)] = normal_quantile(u);
        }
    for (int64_t j = 0; j < th; ++j)
        for (int64_t i = 0; i < tw; ++i) {
            const size_t o = static_cast<size_t>(j * tw + i);
            const PixelModel::Moments m = model.at(v[o], log_factor ? log_factor[o] : 0.0);
            double kx[3], ky[3];
            moving_average_taps(m.rho_x, kx);
            moving_average_taps(m.rho_y, ky);
            double noise = 0.0;
            for (int dy = 0; dy < 3; ++dy)
                for (int dx = 0; dx < 3; ++dx)
                    noise += ky[dy] * kx[dx] * z[static_cast<size_t>((j + dy) * zw + i + dx)];
            transmittance[o] = skewed_draw(m.mean, m.variance, noise);
        }
}

}  // namespace filmgrain
