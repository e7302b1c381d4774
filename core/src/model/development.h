// filmgrain: MODEL.md section 4, development.
#pragma once

#include <cstdint>
#include <limits>

#include "filmgrain/stock.h"

namespace filmgrain {

/// Development of one stock: each grain develops independently with
/// probability P = 1 - (1 - f) (1 - d)^n4, where the development efficiency
/// d = 1 - exp(-t / development_tau_s) and the fog probability
/// f = 1 - exp(-t / fog_tau_s). Computed in log space, so d -> 0, d -> 1
/// and huge n4 stay exact. Thread safety: const, shareable.
class Development {
public:
    explicit Development(const Stock& stock);

    /// d, the development efficiency.
    double efficiency() const;
    /// f, the fog probability.
    double fog_probability() const;
    /// 1 - P: the probability that a grain with n4 centres stays undeveloped.
    double survival_probability(uint64_t n4) const;
    /// P(develop | n4).
    double develop_probability(uint64_t n4) const { return 1.0 - survival_probability(n4); }
    /// The outcome for uniform u in [0, 1): develops iff u >= 1 - P.
    bool develops(uint64_t n4, double u) const { return u >= survival_probability(n4); }
    /// The smallest n4 with which a grain holding uniform u develops:
    /// develops(n4, u) == (n4 >= n4_needed(u)) for every n4 (survival falls
    /// with n4). UINT64_MAX when no n4 suffices (d = 0 and u below 1 - f).
    uint64_t n4_needed(double u) const;
    /// t / fog_tau and t / development_tau: all that the probabilities
    /// above depend on (a key for what is built from them).
    double fog_exponent() const { return m_fog_exponent; }
    double dev_exponent() const { return m_dev_exponent; }

private:
    double m_fog_exponent = 0.0;  ///< t / fog_tau
    double m_dev_exponent = 0.0;  ///< t / development_tau
};

}  // namespace filmgrain
