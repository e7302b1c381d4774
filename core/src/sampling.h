// filmgrain: sampling functions for the model's distributions.
//
// Pure functions: those with a fixed number of uniforms take the uniforms;
// rejection samplers take an Rng because they consume a variable number.
#pragma once

#include <cstdint>

#include "rng.h"

namespace filmgrain {

/// Standard normal CDF Phi(z). Accurate in both tails (erfc based).
double normal_cdf(double z);

/// Upper tail Q(z) = 1 - Phi(z), accurate for large z.
double normal_upper_tail(double z);

/// Inverse standard normal CDF, Wichura's AS241 (PPND16): relative error
/// about 1e-16 for p in (0, 1). p <= 0 gives -inf, p >= 1 gives +inf.
double normal_quantile(double p);

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

}  // namespace filmgrain
