// filmgrain: a population's grains under a uniform exposure as one
// quadrature (MODEL.md 1-2): lognormal diameters at fixed normal scores,
// and for each, the Poisson law of its absorbed photon count. Every
// integral "sizes x Poisson counts x P(develop | N)" of the project (the
// expected values tests rely on, the sensitometry's Boolean model, the
// planner's bound on a table's density error) iterates it here; the pixel
// scale and the expected curves take the same size nodes with
// P(develop | mean photons) already folded over the counts.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "filmgrain/stock.h"
#include "model/geometry.h"
#include "util/sampling.h"

namespace filmgrain {

/// The grain sizes of a population as every integral takes them:
/// trapezoid nodes z (the normal score of ln d) on [-9, 9], step 1/8,
/// weights phi(z) dz (the mass beyond is 2e-19, left out). Not narrower:
/// in the toe P(develop) grows like a^4, so the largest grains carry
/// E[a P] (a cut at |z| = 4 lost 1.1% of the paper stock's net density at
/// -6 stops). A population without spread: z = 0, weight 1.
inline constexpr double kSizeQuadratureZ = 9.0;
struct SizeNode {
    double z      = 0.0;
    double weight = 0.0;
};
const std::vector<SizeNode>& size_quadrature(const Population& population);

/// Poisson sigmas either side of a node's mean count that the quadrature
/// takes (plus as many counts): the mass beyond is below 1e-30.
inline constexpr double kCountWindowSigmas = 12.0;

/// Calls f(node, weight, area_um2, n, p) for every size node of
/// size_quadrature(pop) (`node` its index, `weight` its weight, `area_um2`
/// its disc area) and every absorbed photon count n <= max_count within
/// the node's window, p = Poisson(n; photons_per_um2 * area_um2) (terms
/// below 1e-300 skipped). The sum over everything of weight * p * g(a, n)
/// is E[g(a, N)] under a uniform exposure of photons_per_um2.
template<typename F>
void for_each_size_and_count(const Population& pop, double photons_per_um2, F&& f,
                             uint64_t max_count = std::numeric_limits<uint64_t>::max())
{
    const std::vector<SizeNode>& nodes = size_quadrature(pop);
    for (size_t k = 0; k < nodes.size(); ++k) {
        const double d_um    = diameter_at_z_um(pop, nodes[k].z);
        const double a_um2   = M_PI / 4.0 * d_um * d_um;
        const double lambda  = photons_per_um2 * a_um2;
        const double spread  = kCountWindowSigmas * std::sqrt(lambda) + kCountWindowSigmas;
        const double n0_real = std::max(0.0, std::floor(lambda - spread));
        if (n0_real > static_cast<double>(max_count))
            continue;
        const uint64_t n0 = static_cast<uint64_t>(n0_real);
        const uint64_t n1 = static_cast<uint64_t>(
            std::min(std::ceil(lambda + spread), static_cast<double>(max_count)));
        for_each_poisson_term(lambda, n0, n1, [&](uint64_t n, double p) {
            f(k, nodes[k].weight, a_um2, n, p);
        });
    }
}

}  // namespace filmgrain
