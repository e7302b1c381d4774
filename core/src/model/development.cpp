// MODEL.md section 4: development with fog.
#include "model/development.h"

#include <algorithm>
#include <cmath>

namespace filmgrain {

Development::Development(const Stock& stock)
    : m_fog_exponent(stock.development_time_s / stock.fog_tau_s)
    , m_dev_exponent(stock.development_time_s / stock.development_tau_s)
{
}

double Development::efficiency() const { return -std::expm1(-m_dev_exponent); }

double Development::fog_probability() const { return -std::expm1(-m_fog_exponent); }

double Development::survival_probability(uint64_t n4) const
{
    // (1 - f) (1 - d)^n4 = exp(-t/fog_tau - n4 t/dev_tau).
    return std::exp(-m_fog_exponent - static_cast<double>(n4) * m_dev_exponent);
}

uint64_t Development::n4_needed(double u) const
{
    constexpr uint64_t never = std::numeric_limits<uint64_t>::max();
    if (develops(0, u))
        return 0;
    if (m_dev_exponent <= 0.0)
        return never;
    // exp(-F - k D) <= u  <=>  k >= (-log(u) - F) / D; then settle the
    // rounding against develops() itself so both always agree.
    const double k = std::ceil((-std::log(u) - m_fog_exponent) / m_dev_exponent);
    if (!(k < 1e18))
        return never;
    uint64_t n = static_cast<uint64_t>(std::max(1.0, k));
    while (n > 1 && develops(n - 1, u))
        --n;
    while (!develops(n, u)) {
        if (n > (uint64_t(1) << 62))
            return never;
        ++n;
    }
    return n;
}

}  // namespace filmgrain
