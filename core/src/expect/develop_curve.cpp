// MODEL.md sections 2-4 folded: P(develop | lambda).
#include "expect/develop_curve.h"

#include <algorithm>
#include <cmath>

#include "util/sampling.h"

namespace filmgrain {

namespace {

/// Poisson mass beyond the table that a covered mean may leave out.
constexpr double kTailMass = 1e-12;

/// P(N > n_max) for N ~ Poisson(lambda).
double upper_tail(double lambda, uint64_t n_max)
{
    double tail       = 0.0;
    const uint64_t n1 = n_max + 1 + static_cast<uint64_t>(40.0 * std::sqrt(lambda) + 60.0);
    for_each_poisson_term(lambda, n_max + 1, n1, [&](uint64_t, double p) { tail += p; });
    return tail;
}

}  // namespace

double DevelopCurve::exact_probability(const DevelopTable& table, double lambda)
{
    const double spread = 14.0 * std::sqrt(lambda) + 20.0;
    const uint64_t n0   = static_cast<uint64_t>(std::max(0.0, lambda - spread));
    const uint64_t n1   = std::min<uint64_t>(table.max_photons(),
                                             static_cast<uint64_t>(lambda + spread));
    double sum = 0.0;
    for_each_poisson_term(lambda, n0, n1,
                          [&](uint64_t n, double p) { sum += p * table.probability(n); });
    return sum;
}

DevelopCurve::DevelopCurve(const DevelopTable& table, int nodes)
{
    // The largest covered mean, by bisection (the tail grows with lambda).
    const uint64_t n_max = table.max_photons();
    double lo = 0.0, hi = static_cast<double>(n_max);
    for (int i = 0; i < 60; ++i) {
        const double mid = 0.5 * (lo + hi);
        (upper_tail(mid, n_max) <= kTailMass ? lo : hi) = mid;
    }
    m_lambda_max      = lo;
    m_root_lambda_max = std::sqrt(lo);
    nodes        = std::max(nodes, 2);
    const double step = std::sqrt(m_lambda_max) / nodes;
    m_inv_step        = step > 0.0 ? 1.0 / step : 0.0;
    m_t_max = static_cast<double>(nodes);
    m_p.resize(static_cast<size_t>(nodes) + 2);
    for (int i = 0; i <= nodes; ++i) {
        const double s = step * i;
        m_p[static_cast<size_t>(i)] = exact_probability(table, s * s);
    }
    m_p.back() = m_p[static_cast<size_t>(nodes)];
    m_running_max.resize(m_p.size());
    double top = 0.0;
    for (size_t i = 0; i < m_p.size(); ++i)
        m_running_max[i] = top = std::max(top, m_p[i]);
    // Linear interpolation errs most between nodes: measure it at every
    // midpoint against the sum itself.
    for (int i = 0; i < nodes; ++i) {
        const double s     = step * (i + 0.5);
        const double exact = exact_probability(table, s * s);
        const double interp
            = 0.5 * (m_p[static_cast<size_t>(i)] + m_p[static_cast<size_t>(i) + 1]);
        m_max_error = std::max(m_max_error, std::fabs(interp - exact));
    }
    m_max_error += kTailMass;
}

}  // namespace filmgrain
