// MODEL.md 1-2 as one quadrature (grain_counts.h).
#include "expect/grain_counts.h"

namespace filmgrain {

namespace {

/// size_quadrature's nodes (145: step 1/8 on [-9, 9]).
constexpr int kSizeNodes = 145;

}  // namespace

const std::vector<SizeNode>& size_quadrature(const Population& population)
{
    // Two fixed rules, made once (the expected curves ask for them at every
    // exposure they evaluate).
    static const std::vector<SizeNode> single { SizeNode { 0.0, 1.0 } };
    static const std::vector<SizeNode> trapezoid = [] {
        std::vector<SizeNode> nodes(kSizeNodes);
        const double dz = 2.0 * kSizeQuadratureZ / (kSizeNodes - 1);
        for (int k = 0; k < kSizeNodes; ++k) {
            const double z = -kSizeQuadratureZ + k * dz;
            const double w = std::exp(-0.5 * z * z) / std::sqrt(2.0 * M_PI) * dz;
            nodes[static_cast<size_t>(k)] = { z, (k == 0 || k == kSizeNodes - 1) ? 0.5 * w : w };
        }
        return nodes;
    }();
    return population.diameter_log_sigma > 0.0 ? trapezoid : single;
}

}  // namespace filmgrain
