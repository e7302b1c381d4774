// filmgrain: sampling functions for the model's distributions.
//
// Pure functions: those with a fixed number of uniforms take the uniforms;
// rejection samplers take an Rng because they consume a variable number.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "util/rng.h"

namespace filmgrain {

/// Standard normal CDF Phi(z). Accurate in both tails (erfc based).
double normal_cdf(double z);

/// Upper tail Q(z) = 1 - Phi(z), accurate for large z.
double normal_upper_tail(double z);

/// Inverse standard normal CDF, Wichura's AS241 (PPND16): relative error
/// about 1e-16 for p in (0, 1). p <= 0 gives -inf, p >= 1 gives +inf.
double normal_quantile(double p);

/// normal_quantile of each of p[0..n) into z[0..n), the same values, in a
/// loop that vectorises where p is central (about 85% of uniforms).
void normal_quantiles(const double* p, double* z, size_t n);

/// A standard normal z restricted to (z_lo, z_hi], drawn by inverting the
/// CDF at uniform u in [0, 1). z_lo may be -inf. Accurate in the upper tail
/// (uses Q when z_lo >= 0), which is where radius bins live. The CDF at the
/// bounds is computed once, at construction. Thread safety: const.
class TruncatedNormal {
public:
    TruncatedNormal(double z_lo, double z_hi);
    double sample(double u) const;

private:
    double m_z_lo, m_z_hi;
    bool m_upper;       ///< invert Q rather than Phi
    double m_c_lo, m_c_hi;  ///< Phi (or Q) at the bounds
};

/// TruncatedNormal(z_lo, z_hi).sample(u).
double sample_truncated_normal(double z_lo, double z_hi, double u);

/// Exactly Poisson(mean) distributed count. Inversion for mean < 10,
/// Hormann's PTRS transformed rejection ("The transformed rejection method
/// for generating Poisson random variables", 1993) above. mean <= 0 or NaN
/// gives 0. Exact up to means of about 1e15; above, still Poisson to far
/// within its standard deviation (double rounding of the count); means of
/// 2^63 or more, +inf included, saturate at UINT64_MAX. Never decreasing in
/// the mean's range for a fixed stream, never 0 for a huge mean.
uint64_t sample_poisson(double mean, Rng& rng);

/// Poisson(mean) counts by inversion of the tabulated CDF with one uniform,
/// for a mean drawn many times (the fast kernel's cell counts): a guide
/// table (Chen and Asau) starts the search at most a step or two short of
/// the count. The CDF is summed from the pmf by recurrence up to where the
/// upper tail is below 2^-60 (beneath a uniform's resolution, 2^-53), and
/// that last count takes the tail. Means up to 1e4 (larger ones would need
/// a long table; sample_poisson takes them). Thread safety: const.
class PoissonTable {
public:
    explicit PoissonTable(double mean);
    /// The count for uniform u in [0, 1).
    uint64_t sample(double u) const
    {
        size_t k = m_guide[static_cast<size_t>(u * static_cast<double>(m_guide.size() - 1))];
        while (u >= m_cdf[k])
            ++k;
        return k;
    }
    double mean() const { return m_mean; }

private:
    double m_mean;
    std::vector<double> m_cdf;     ///< P(N <= k); the last is 1
    std::vector<uint32_t> m_guide;  ///< the smallest k with cdf[k] > j / (size - 1)
};

/// The Poisson(lambda) pmf over [n0, n1] by recurrence from the mode (one
/// lgamma in all), calling f(n, p) for each n whose p is above 1e-300.
template<typename F> void for_each_poisson_term(double lambda, uint64_t n0, uint64_t n1, F&& f)
{
    if (lambda <= 0.0) {
        if (n0 == 0)
            f(0, 1.0);
        return;
    }
    const uint64_t mode = std::clamp<uint64_t>(static_cast<uint64_t>(lambda), n0, n1);
    const double pm     = std::exp(static_cast<double>(mode) * std::log(lambda) - lambda
                                   - std::lgamma(static_cast<double>(mode) + 1.0));
    double p = pm;
    for (uint64_t n = mode;; --n) {
        f(n, p);
        if (n == n0 || p < 1e-300)
            break;
        p *= static_cast<double>(n) / lambda;
    }
    p = pm;
    for (uint64_t n = mode + 1; n <= n1; ++n) {
        p *= lambda / static_cast<double>(n);
        if (p < 1e-300)
            break;
        f(n, p);
    }
}

}  // namespace filmgrain
