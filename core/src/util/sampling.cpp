#include "util/sampling.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace filmgrain {

double normal_cdf(double z) { return 0.5 * std::erfc(-z * M_SQRT1_2); }

double normal_upper_tail(double z) { return 0.5 * std::erfc(z * M_SQRT1_2); }

namespace {

/// AS 241's central region, |p - 0.5| <= 0.425: a rational function of
/// r = 0.180625 - q^2, no branch (so that a loop of it vectorises).
inline double central_quantile(double p)
{
    const double q = p - 0.5;
    const double r = 0.180625 - q * q;
    const double num
        = (((((((2.5090809287301226727e+3 * r + 3.3430575583588128105e+4) * r
                 + 6.7265770927008700853e+4) * r + 4.5921953931549871457e+4) * r
               + 1.3731693765509461125e+4) * r + 1.9715909503065514427e+3) * r
             + 1.3314166789178437745e+2) * r + 3.3871328727963666080e+0);
    const double den
        = (((((((5.2264952788528545610e+3 * r + 2.8729085735721942674e+4) * r
                 + 3.9307895800092710610e+4) * r + 2.1213794301586595867e+4) * r
               + 5.3941960214247511077e+3) * r + 6.8718700749205790830e+2) * r
             + 4.2313330701600911252e+1) * r + 1.0);
    return q * num / den;
}

inline bool is_central(double p) { return std::fabs(p - 0.5) <= 0.425; }

}  // namespace

void normal_quantiles(const double* p, double* z, size_t n)
{
    // Every value by the central formula first (a loop the compiler
    // vectorises), then the tails (about 15%) one by one: the same
    // operations as normal_quantile, so the same values.
    for (size_t i = 0; i < n; ++i)
        z[i] = central_quantile(p[i]);
    for (size_t i = 0; i < n; ++i)
        if (!is_central(p[i]))
            z[i] = normal_quantile(p[i]);
}

double normal_quantile(double p)
{
    if (!(p > 0.0))
        return -std::numeric_limits<double>::infinity();
    if (!(p < 1.0))
        return std::numeric_limits<double>::infinity();
    // Wichura, M. J. (1988) Algorithm AS 241: The percentage points of the
    // normal distribution. Applied Statistics 37, 477-484.
    const double q = p - 0.5;
    if (is_central(p))
        return central_quantile(p);
    double r = std::sqrt(-std::log(q < 0.0 ? p : 1.0 - p));
    double val;
    if (r <= 5.0) {
        r -= 1.6;
        const double num
            = (((((((7.74545014278341407640e-4 * r + 2.27238449892691845833e-2) * r
                     + 2.41780725177450611770e-1) * r + 1.27045825245236838258e+0) * r
                   + 3.64784832476320460504e+0) * r + 5.76949722146069140550e+0) * r
                 + 4.63033784615654529590e+0) * r + 1.42343711074968357734e+0);
        const double den
            = (((((((1.05075007164441684324e-9 * r + 5.47593808499534494600e-4) * r
                     + 1.51986665636164571966e-2) * r + 1.48103976427480074590e-1) * r
                   + 6.89767334985100004550e-1) * r + 1.67638483018380384940e+0) * r
                 + 2.05319162663775882187e+0) * r + 1.0);
        val = num / den;
    } else {
        r -= 5.0;
        const double num
            = (((((((2.01033439929228813265e-7 * r + 2.71155556874348757815e-5) * r
                     + 1.24266094738807843860e-3) * r + 2.65321895265761230930e-2) * r
                   + 2.96560571828504891230e-1) * r + 1.78482653991729133580e+0) * r
                 + 5.46378491116411436990e+0) * r + 6.65790464350110377720e+0);
        const double den
            = (((((((2.04426310338993978564e-15 * r + 1.42151175831644588870e-7) * r
                     + 1.84631831751005468180e-5) * r + 7.86869131145613259100e-4) * r
                   + 1.48753612908506148525e-2) * r + 1.36929880922735805310e-1) * r
                 + 5.99832206555887937690e-1) * r + 1.0);
        val = num / den;
    }
    return q < 0.0 ? -val : val;
}

TruncatedNormal::TruncatedNormal(double z_lo, double z_hi)
    : m_z_lo(z_lo)
    , m_z_hi(z_hi)
    , m_upper(z_lo >= 0.0)
    , m_c_lo(m_upper ? normal_upper_tail(z_lo) : normal_cdf(z_lo))
    , m_c_hi(m_upper ? normal_upper_tail(z_hi) : normal_cdf(z_hi))
{
}

double TruncatedNormal::sample(double u) const
{
    // Upper tail: invert Q to keep precision where Phi is close to 1.
    const double z = m_upper ? -normal_quantile(m_c_hi + u * (m_c_lo - m_c_hi))
                             : normal_quantile(m_c_lo + u * (m_c_hi - m_c_lo));
    return std::fmin(std::fmax(z, m_z_lo), m_z_hi);
}

double sample_truncated_normal(double z_lo, double z_hi, double u)
{
    return TruncatedNormal(z_lo, z_hi).sample(u);
}

namespace {

uint64_t poisson_inversion(double mean, Rng& rng)
{
    // Sequential search of the CDF. For mean < 10 the mass beyond k = 200
    // is below 1e-100, so the cap only guards against a rounding stall.
    const double u = rng.uniform();
    double p       = std::exp(-mean);
    double cdf     = p;
    uint64_t k     = 0;
    while (u >= cdf && k < 200) {
        ++k;
        p *= mean / static_cast<double>(k);
        cdf += p;
    }
    return k;
}

/// Means at or above this saturate (2^63: every count a uint64_t holds is
/// then far below the mean's own rounding error of sd sqrt(mean) ~ 3e9).
constexpr double kPoissonSaturation = 9223372036854775808.0;

/// A non-negative integral double as a count, saturating at UINT64_MAX
/// (a plain cast of a value >= 2^64 is undefined behaviour).
uint64_t to_count(double kf)
{
    return kf < 18446744073709551616.0 ? static_cast<uint64_t>(kf)
                                       : std::numeric_limits<uint64_t>::max();
}

uint64_t poisson_ptrs(double mean, Rng& rng)
{
    const double smu       = std::sqrt(mean);
    const double b         = 0.931 + 2.53 * smu;
    const double a         = -0.059 + 0.02483 * b;
    const double inv_alpha = 1.1239 + 1.1328 / (b - 3.4);
    const double vr        = 0.9277 - 3.6224 / (b - 2.0);
    const double log_mean  = std::log(mean);
    for (;;) {
        const double u  = rng.uniform() - 0.5;
        const double v  = rng.uniform_open0();
        const double us = 0.5 - std::fabs(u);
        const double kf = std::floor((2.0 * a / us + b) * u + mean + 0.43);
        if (us >= 0.07 && v <= vr)
            return to_count(kf);
        if (kf < 0.0 || (us < 0.013 && v > us))
            continue;
        if (std::log(v) + std::log(inv_alpha) - std::log(a / (us * us) + b)
            <= -mean + kf * log_mean - std::lgamma(kf + 1.0))
            return to_count(kf);
    }
}

}  // namespace

uint64_t sample_poisson(double mean, Rng& rng)
{
    if (!(mean > 0.0))
        return 0;
    if (mean >= kPoissonSaturation)
        return std::numeric_limits<uint64_t>::max();
    return mean < 10.0 ? poisson_inversion(mean, rng) : poisson_ptrs(mean, rng);
}

PoissonTable::PoissonTable(double mean) : m_mean(mean)
{
    if (!(mean >= 0.0 && mean <= 1e4))
        throw std::invalid_argument("PoissonTable: mean must be in [0, 1e4]");
    // The pmf from the mode outwards (no underflow at e^-mean for large
    // means), normalised by its sum, then summed from 0.
    const uint64_t mode = static_cast<uint64_t>(mean);
    const uint64_t top  = static_cast<uint64_t>(mean + 40.0 * std::sqrt(mean) + 60.0);
    std::vector<double> pmf(static_cast<size_t>(top) + 1, 0.0);
    pmf[static_cast<size_t>(mode)] = 1.0;
    for (uint64_t k = mode; k > 0; --k)
        pmf[static_cast<size_t>(k - 1)] = pmf[static_cast<size_t>(k)] * static_cast<double>(k) / mean;
    for (uint64_t k = mode + 1; k <= top; ++k)
        pmf[static_cast<size_t>(k)] = pmf[static_cast<size_t>(k - 1)] * mean / static_cast<double>(k);
    if (mean == 0.0)
        pmf.assign(1, 1.0);
    double total = 0.0;
    for (double p : pmf)
        total += p;
    double cdf = 0.0;
    for (size_t k = 0; k < pmf.size(); ++k) {
        cdf += pmf[k] / total;
        m_cdf.push_back(cdf);
        if (1.0 - cdf < 0x1.0p-60)
            break;
    }
    m_cdf.back() = 1.0;  // the last count takes the tail
    const size_t guides = std::max<size_t>(m_cdf.size(), 2);
    m_guide.resize(guides);
    size_t k = 0;
    for (size_t j = 0; j < guides; ++j) {
        const double u = static_cast<double>(j) / static_cast<double>(guides - 1);
        while (k + 1 < m_cdf.size() && m_cdf[k] <= u)
            ++k;
        m_guide[j] = static_cast<uint32_t>(k);
    }
}

}  // namespace filmgrain
