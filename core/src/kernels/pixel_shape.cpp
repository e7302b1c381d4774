// MODEL.md sections 5 and 8 at pixel scale: a pixel law's shape, sampled.
#include "kernels/pixel_shape.h"

#include <algorithm>
#include <cmath>

#include "expect/grain_counts.h"
#include "kernels/pixel_model.h"
#include "model/dye.h"
#include "util/rng.h"
#include "util/sampling.h"

namespace filmgrain {

namespace {

/// The quadrature every moment of S(Z) takes: z on steps of 1/32 over
/// |z| <= 8 (the normal's mass beyond is 1e-15), weights phi(z) dz.
constexpr int kQuadratureSteps = 512;
constexpr double kQuadratureZ  = 8.0;
/// Hermite coefficients kept for the copula (He_1 to He_6).
constexpr int kHermiteOrder = 6;

template <typename F> void for_each_quadrature_node(F&& f)
{
    const double dz = 2.0 * kQuadratureZ / kQuadratureSteps;
    for (int k = 0; k <= kQuadratureSteps; ++k) {
        const double z = -kQuadratureZ + k * dz;
        const double w = (k == 0 || k == kQuadratureSteps ? 0.5 : 1.0) * dz
                         * std::exp(-0.5 * z * z) / std::sqrt(2.0 * M_PI);
        f(z, w);
    }
}

}  // namespace

bool can_sample_pixel_shape(const Layer& layer) { return layer.image == LayerImage::dye; }

double shape_value(const PixelShape& shape, double z)
{
    const double t = std::clamp((z + kShapeZMax) / kShapeZStep, 0.0,
                                static_cast<double>(kShapeNodes - 1));
    const int i    = std::min(static_cast<int>(t), kShapeNodes - 2);
    const double f = t - i;
    return shape[static_cast<size_t>(i)] + f * (shape[static_cast<size_t>(i) + 1]
                                                - shape[static_cast<size_t>(i)]);
}

void standardise_shape(PixelShape& shape)
{
    double m0 = 0.0, m1 = 0.0, m2 = 0.0;
    for_each_quadrature_node([&](double z, double w) {
        const double s = shape_value(shape, z);
        m0 += w;
        m1 += w * s;
        m2 += w * s * s;
    });
    const double mean = m1 / m0, var = m2 / m0 - mean * mean;
    for (double& s : shape)
        s = var > 0.0 ? (s - mean) / std::sqrt(var) : 0.0;
}

double shape_normal_correlation(const PixelShape& shape, double rho)
{
    if (!(rho > 0.0))
        return 0.0;
    if (rho >= 1.0)
        return 1.0;
    // k! c_k^2 = E[S He_k]^2 / k!, He_k by its recurrence.
    std::array<double, kHermiteOrder + 1> e {};
    for_each_quadrature_node([&](double z, double w) {
        const double s = shape_value(shape, z);
        double h0 = 1.0, h1 = z;
        e[1] += w * s * h1;
        for (int k = 2; k <= kHermiteOrder; ++k) {
            const double h2 = z * h1 - (k - 1) * h0;
            e[static_cast<size_t>(k)] += w * s * h2;
            h0 = h1;
            h1 = h2;
        }
    });
    std::array<double, kHermiteOrder + 1> weight {};
    double total = 0.0, factorial = 1.0;
    for (int k = 1; k <= kHermiteOrder; ++k) {
        factorial *= k;
        weight[static_cast<size_t>(k)] = e[static_cast<size_t>(k)] * e[static_cast<size_t>(k)]
                                         / factorial;
        total += weight[static_cast<size_t>(k)];
    }
    if (!(total > 0.0))
        return rho;
    const auto correlation = [&](double r) {
        double sum = 0.0, power = 1.0;
        for (int k = 1; k <= kHermiteOrder; ++k) {
            power *= r;
            sum += weight[static_cast<size_t>(k)] * power;
        }
        return sum / total;
    };
    // Increasing on [0, 1] from 0 to 1: bisection to 1e-12.
    double lo = 0.0, hi = 1.0;
    for (int i = 0; i < 42; ++i) {
        const double r = 0.5 * (lo + hi);
        (correlation(r) < rho ? lo : hi) = r;
    }
    return 0.5 * (lo + hi);
}

PixelShape sample_pixel_shape(const std::vector<PixelPopulation>& populations,
                              const Layer& layer, double px_um, double py_um, int samples,
                              double max_density, double v, double log_factor, uint64_t key,
                              ShapeWindow* window)
{
    const double thinning = std::exp(-log_factor);
    // The window and a margin every drawn grain's image can reach in from.
    double largest_r_um = 0.0;
    for (const PixelPopulation& pp : populations)
        largest_r_um = std::max(largest_r_um, pp.grains->radius_at_z_um(kShapeSizeZ));
    const double margin_um = image_reach_factor(layer) * largest_r_um;
    const double width_um = kShapeWindow * px_um, height_um = kShapeWindow * py_um;
    const double area_um2 = (width_um + 2.0 * margin_um) * (height_um + 2.0 * margin_um);
    Rng rng(key, Stage::cell);
    std::vector<Disc> grains;
    std::vector<size_t> population_end;
    std::vector<double> radius_um, cumulative;
    for (const PixelPopulation& pp : populations) {
        // Developed grains per um^2 by size node: n w P(develop | lambda(a)) e^-L.
        radius_um.clear();
        cumulative.clear();
        double total = 0.0;
        for_each_size_probability(pp, v, [&](const SizeNode& node, double r_um, double,
                                             double p) {
            if (std::fabs(node.z) > kShapeSizeZ)
                return;
            total += node.weight * p;
            radius_um.push_back(r_um);
            cumulative.push_back(total);
        });
        const double mean_count = pp.population->grains_per_um2 * total * thinning * area_um2;
        const uint64_t count    = total > 0.0 ? sample_poisson(mean_count, rng) : 0;
        for (uint64_t g = 0; g < count; ++g) {
            const double u = rng.uniform() * total;
            const size_t k = std::min<size_t>(
                static_cast<size_t>(std::upper_bound(cumulative.begin(), cumulative.end(), u)
                                    - cumulative.begin()),
                radius_um.size() - 1);
            const double x_um = rng.uniform() * (width_um + 2.0 * margin_um) - margin_um;
            const double y_um = rng.uniform() * (height_um + 2.0 * margin_um) - margin_um;
            grains.push_back({ x_um, y_um, radius_um[k] });
        }
        population_end.push_back(grains.size());
    }
    std::vector<double> t(static_cast<size_t>(kShapeWindow * kShapeWindow));
    DyeScratch scratch;
    dye_transmittance(grains, population_end, layer, max_density, 0, 0, kShapeWindow,
                      kShapeWindow, px_um, py_um, samples, scratch, t.data());
    std::sort(t.begin(), t.end());
    const double n = static_cast<double>(t.size());
    if (window) {
        double sum = 0.0, squares = 0.0;
        for (double x : t)
            sum += x;
        window->mean = sum / n;
        for (double x : t)
            squares += (x - window->mean) * (x - window->mean);
        window->variance = squares / (n - 1.0);
    }
    PixelShape shape {};
    for (int j = 0; j < kShapeNodes; ++j) {
        // The quantile at Phi(z_j): order statistics linearly between
        // their plotting positions (i + 1/2) / n.
        const double u   = normal_cdf(-kShapeZMax + j * kShapeZStep);
        const double pos = std::clamp(u * n - 0.5, 0.0, n - 1.0);
        const size_t i   = std::min(static_cast<size_t>(pos), t.size() - 2);
        shape[static_cast<size_t>(j)] = t[i] + (pos - static_cast<double>(i)) * (t[i + 1] - t[i]);
    }
    standardise_shape(shape);
    return shape;
}

}  // namespace filmgrain
