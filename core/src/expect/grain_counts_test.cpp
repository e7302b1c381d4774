// Tests of the one quadrature of sizes and photon counts (grain_counts.h)
// against the lognormal's and the Poisson law's closed-form moments.
#include "expect/grain_counts.h"

#include <gtest/gtest.h>

#include <cmath>

namespace filmgrain {
namespace {

Population population(double diameter_um, double log_sigma)
{
    Population pop;
    pop.diameter_um        = diameter_um;
    pop.diameter_log_sigma = log_sigma;
    pop.grains_per_um2     = 1.0;
    return pop;
}

// E[a^k] of a disc of lognormal diameter: (pi/4)^k exp(2k mu + 2 k^2 s^2),
// mu = ln d - s^2/2. The trapezoid rule in z on [-9, 9] at step 1/8 is
// exact to rounding for these smooth Gaussian integrands; what lies beyond
// |z| = 9 is the tail of a normal shifted to z = 2ks: for a^2 at s = 0.7,
// Q(9 - 2.8) = 3e-10 of the moment.
TEST(GrainCounts, SizeQuadratureHasTheLognormalsAreaMoments)
{
    for (double s : { 0.0, 0.05, 0.24, 0.5, 0.7 }) {
        const Population pop = population(1.7, s);
        double w = 0.0, a1 = 0.0, a2 = 0.0;
        for (const SizeNode& node : size_quadrature(pop)) {
            const double d = diameter_at_z_um(pop, node.z);
            const double a = M_PI / 4.0 * d * d;
            w += node.weight;
            a1 += node.weight * a;
            a2 += node.weight * a * a;
        }
        const double mu = std::log(1.7) - 0.5 * s * s;
        EXPECT_NEAR(w, 1.0, 1e-12) << "s = " << s;
        EXPECT_NEAR(a1 / (M_PI / 4.0 * std::exp(2.0 * mu + 2.0 * s * s)), 1.0, 1e-10)
            << "s = " << s;
        EXPECT_NEAR(a2 / (M_PI * M_PI / 16.0 * std::exp(4.0 * mu + 8.0 * s * s)), 1.0, 1e-9)
            << "s = " << s;
    }
}

// Over sizes and counts: the Poisson masses sum to 1 at every node, so the
// total weight is 1; E[N] = photons E[a]; E[N^2] = photons E[a] +
// photons^2 E[a^2]; and a count cap drops exactly the counts above it.
TEST(GrainCounts, CountsHaveThePoissonMixturesMoments)
{
    for (double photons_per_um2 : { 0.0, 0.3, 12.0, 900.0 }) {
        const Population pop = population(1.2, 0.4);
        double w = 0.0, n1 = 0.0, n2 = 0.0, a1 = 0.0, a2 = 0.0;
        for (const SizeNode& node : size_quadrature(pop)) {
            const double d = diameter_at_z_um(pop, node.z);
            const double a = M_PI / 4.0 * d * d;
            a1 += node.weight * a;
            a2 += node.weight * a * a;
        }
        for_each_size_and_count(pop, photons_per_um2,
                                [&](size_t, double weight, double, uint64_t n, double p) {
            const double x = static_cast<double>(n);
            w += weight * p;
            n1 += weight * p * x;
            n2 += weight * p * x * x;
        });
        const double c = photons_per_um2;
        EXPECT_NEAR(w, 1.0, 1e-9) << "photons " << c;
        EXPECT_NEAR(n1, c * a1, 1e-9 * (1.0 + c * a1)) << "photons " << c;
        EXPECT_NEAR(n2, c * a1 + c * c * a2, 1e-9 * (1.0 + c * a1 + c * c * a2))
            << "photons " << c;
        uint64_t largest = 0;
        for_each_size_and_count(
            pop, c, [&](size_t, double, double, uint64_t n, double) { largest = std::max(largest, n); },
            5);
        EXPECT_LE(largest, 5u) << "photons " << c;
    }
}

}  // namespace
}  // namespace filmgrain
