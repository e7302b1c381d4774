// filmgrain: MODEL.md sections 2-4 folded into one function of a grain's
// mean absorbed photon count: P(develop | lambda).
//
// Given its mean lambda, a grain absorbs N ~ Poisson(lambda) photons and
// then develops with P(develop | N) (the latent-image chain and development,
// tabulated by DevelopTable). Its probability of developing is therefore
//   P(develop | lambda) = sum_N Poisson(N; lambda) P(develop | N),
// and one uniform per grain against this curve draws the outcome with the
// same distribution as drawing N, running the chain and developing (the
// grains are independent given their exposure, MODEL.md 2-4). The curve is
// built once per table; its own error (linear interpolation between nodes,
// the Poisson tail beyond the table) is measured at construction and
// reported with the table's.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "engine/kinetics_table.h"

namespace filmgrain {

class DevelopCurve {
public:
    /// Nodes are spaced evenly in sqrt(lambda) (where Poisson smoothing
    /// makes P vary on the scale of sqrt(lambda)) from 0 up to
    /// lambda_max(), the largest mean whose Poisson mass beyond the table's
    /// max_photons() is below 1e-12.
    explicit DevelopCurve(const DevelopTable& table, int nodes = 4096);

    /// Means up to this are covered; a grain with a larger mean must draw
    /// its photon count and use the table (or the chain).
    double lambda_max() const { return m_lambda_max; }

    /// P(develop | lambda) for 0 <= lambda <= lambda_max(): linear
    /// interpolation between nodes in sqrt(lambda). (Larger means read the
    /// last node: callers must not rely on it, see lambda_max().)
    double probability(double lambda) const
    {
        const double t = std::min(std::sqrt(lambda) * m_inv_step, m_t_max);
        const size_t i = static_cast<size_t>(t);
        const double f = t - static_cast<double>(i);
        return m_p[i] + f * (m_p[i + 1] - m_p[i]);
    }

    /// An upper bound of probability(l) over every 0 <= l <= s^2, given
    /// s = sqrt(lambda) >= 0 (the nodes are even in s: no root to take
    /// where s is known): the largest node value up to the node at or
    /// after s (linear interpolation never exceeds its two nodes, and the
    /// tabulated chain need not make the curve monotonic); 1 beyond
    /// lambda_max(), where grains are decided from their photon count. For
    /// filtering out the grains that cannot develop (tile_renderer.cpp).
    double probability_bound_at_root(double s) const
    {
        if (!(s <= m_root_lambda_max))
            return 1.0;
        const double t = std::min(s * m_inv_step, m_t_max);
        return m_running_max[static_cast<size_t>(t) + 1];
    }

    /// Largest |interpolated - exact sum| found at the midpoints between
    /// nodes (where linear interpolation errs most), plus the truncated
    /// Poisson tail: the curve's error on top of the table's.
    double max_interpolation_error() const { return m_max_error; }
    size_t node_count() const { return m_p.size() - 1; }

    /// The sum itself, without interpolation (for tests and the error).
    static double exact_probability(const DevelopTable& table, double lambda);

private:
    double m_lambda_max = 0.0;
    double m_root_lambda_max = 0.0;  ///< sqrt(m_lambda_max)
    double m_inv_step   = 0.0;
    double m_t_max      = 0.0;  ///< the last node's index
    double m_max_error  = 0.0;
    /// P at the nodes, plus a copy of the last one (so that lambda_max()
    /// itself interpolates without a bounds check).
    std::vector<double> m_p;
    /// max(m_p[0..i]) at each i (probability_bound).
    std::vector<double> m_running_max;
};

}  // namespace filmgrain
