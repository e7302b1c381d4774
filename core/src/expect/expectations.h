// filmgrain: expected values of the model (MODEL.md 5, "expected values
// that tests can rely on"), computed independently of the render pipeline:
// no grains, no images, no tiles. They compose the model's distributions
// directly: lognormal disc areas, Poisson photon counts, and P(develop | N)
// estimated by running the chain of MODEL.md 3 on its own.
#pragma once

#include <cstdint>
#include <array>
#include <map>

#include "model/development.h"
#include "model/kinetics.h"

namespace filmgrain {

/// A Monte Carlo estimate with its standard error.
struct Estimate {
    double value          = 0.0;
    double standard_error = 0.0;
};

/// P(develop | N absorbed photons) for one set of rates and one shutter,
/// estimated from independent runs of the exact chain and cached per N.
/// Each run contributes 1 - (1 - f)(1 - d)^n4 (a conditional expectation,
/// lower variance than counting developed grains). N < 4 is exact (fog).
class DevelopGivenPhotons {
public:
    /// max_samples_per_n: the runs spent on the most important counts.
    DevelopGivenPhotons(const KineticsRates& rates, double shutter_s, const Development& dev,
                        int max_samples_per_n, uint64_t seed);
    /// P(develop | n) from at least `samples` runs (default: the maximum).
    Estimate operator()(uint64_t n, int samples = 0);
    int max_samples() const { return m_samples; }

private:
    KineticsRates m_rates;
    double m_shutter_s;
    const Development& m_dev;
    int m_samples;
    uint64_t m_seed;
    struct Cached {
        int samples;
        Estimate estimate;
    };
    std::map<uint64_t, Cached> m_cache;
};

/// Moments of development over one population under uniform exposure
/// (MODEL.md 2-5), over the lognormal diameter and N ~
/// Poisson(quantum_efficiency * 4.09e3 * H * a) as grain_counts.h's
/// quadrature takes them. Only for rate_area_exponent = 0 (P(develop | N)
/// then does not depend on a).
struct DevelopmentMoments {
    Estimate develop_fraction;   ///< E[P]
    Estimate area_developed_um2; ///< E[a P]
    Estimate area2_developed_um4;///< E[a^2 P]
    double mean_photons = 0.0;   ///< E[N]
};

DevelopmentMoments expected_development(const Population& pop, double exposure_lxs,
                                        DevelopGivenPhotons& develop_given_photons);

}  // namespace filmgrain
