// MODEL.md section 4: development with fog.
#include "development.h"

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

}  // namespace filmgrain
