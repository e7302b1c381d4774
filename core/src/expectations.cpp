// Expected values of the model, composed from its distributions.
#include "expectations.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "exposure.h"
#include "rng.h"

namespace filmgrain {

DevelopGivenPhotons::DevelopGivenPhotons(const KineticsRates& rates, double shutter_s,
                                         const Development& dev, int samples_per_n,
                                         uint64_t seed)
    : m_rates(rates)
    , m_shutter_s(shutter_s)
    , m_dev(dev)
    , m_samples(samples_per_n)
    , m_seed(seed)
{
}

Estimate DevelopGivenPhotons::operator()(uint64_t n, int samples)
{
    if (n < 4)
        return { m_dev.develop_probability(0), 0.0 };
    samples = samples > 0 ? std::min(samples, m_samples) : m_samples;
    auto it = m_cache.find(n);
    if (it != m_cache.end() && it->second.samples >= samples)
        return it->second.estimate;
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < samples; ++i) {
        // Streams keyed apart from any render's grain identities.
        Rng rng(hash_ids(m_seed, 0xe8ec7ed, n, static_cast<uint64_t>(i)), Stage::kinetics);
        const LatentImage c = simulate_latent_image(n, m_shutter_s, m_rates, rng);
        const double p      = m_dev.develop_probability(c.n4);
        sum += p;
        sum2 += p * p;
    }
    const double mean = sum / samples;
    const double var  = std::max(0.0, sum2 / samples - mean * mean);
    // A run of zero variance still has finite precision: count it as at
    // most one outcome in samples + 1 being different.
    const Estimate e { mean, std::max(std::sqrt(var / samples), 0.5 / (samples + 1.0)) };
    m_cache[n] = { samples, e };
    return e;
}

DevelopmentMoments expected_development(const Population& pop, double exposure_lxs,
                                        DevelopGivenPhotons& develop_given_photons)
{
    // Weights w_N of each photon count in the three moments, accumulated
    // over the z quadrature, so that each P(develop | N) is used (and its
    // Monte Carlo error counted) once.
    const double s  = pop.diameter_log_sigma;
    const double mu = std::log(pop.diameter_um) - 0.5 * s * s;
    const double photons_per_um2
        = pop.quantum_efficiency * kPhotonsPerUm2PerLxs * exposure_lxs;
    const int nodes = s > 0.0 ? 1801 : 1;
    const double dz = 18.0 / (nodes - 1 > 0 ? nodes - 1 : 1);
    std::map<uint64_t, std::array<double, 3>> weights;
    DevelopmentMoments m;
    for (int k = 0; k < nodes; ++k) {
        const double z      = nodes > 1 ? -9.0 + k * dz : 0.0;
        const double pdf_dz = nodes > 1 ? std::exp(-0.5 * z * z) / std::sqrt(2.0 * M_PI) * dz
                                              * ((k == 0 || k == nodes - 1) ? 0.5 : 1.0)
                                        : 1.0;
        const double d      = std::exp(mu + s * z);
        const double a      = M_PI / 4.0 * d * d;
        const double lambda = photons_per_um2 * a;
        m.mean_photons += pdf_dz * lambda;
        // Poisson pmf over lambda +- 12 sigma (the rest is below 1e-30).
        const double spread = 12.0 * std::sqrt(lambda) + 12.0;
        const uint64_t n0 = static_cast<uint64_t>(std::max(0.0, std::floor(lambda - spread)));
        const uint64_t n1 = static_cast<uint64_t>(std::ceil(lambda + spread));
        for (uint64_t n = n0; n <= n1; ++n) {
            const double log_p = lambda > 0.0
                                     ? n * std::log(lambda) - lambda - std::lgamma(n + 1.0)
                                     : (n == 0 ? 0.0 : -INFINITY);
            const double w = pdf_dz * std::exp(log_p);
            if (w < 1e-300)
                continue;
            auto& acc = weights[n];
            acc[0] += w;
            acc[1] += w * a;
            acc[2] += w * a * a;
        }
    }
    // Counts of negligible weight are not simulated: they are dropped, the
    // lightest first, while their total share of every moment stays below
    // 1e-7. Since 0 <= P <= 1 the bias this causes is at most that share,
    // which is added to the reported error.
    double total[3] = { 0, 0, 0 };
    std::vector<std::pair<double, uint64_t>> by_weight;
    for (const auto& [n, w] : weights) {
        for (int i = 0; i < 3; ++i)
            total[i] += w[i];
        by_weight.emplace_back(w[0], n);
    }
    std::sort(by_weight.begin(), by_weight.end());
    double dropped[3] = { 0, 0, 0 };
    std::vector<bool> keep(by_weight.size(), true);
    for (size_t k = 0; k < by_weight.size(); ++k) {
        const auto& w = weights[by_weight[k].second];
        bool ok       = true;
        for (int i = 0; i < 3; ++i)
            ok = ok && dropped[i] + w[i] < 1e-7 * total[i];
        if (!ok)
            break;
        for (int i = 0; i < 3; ++i)
            dropped[i] += w[i];
        keep[k] = false;
    }
    // Runs are spent in proportion to each count's weight (at least 64):
    // the variance of the sum, sum of w^2 s^2 / runs, is then spread evenly.
    const double w_max = by_weight.empty() ? 0.0 : by_weight.back().first;
    double var[3] = { 0, 0, 0 };
    double val[3] = { 0, 0, 0 };
    for (size_t k = 0; k < by_weight.size(); ++k) {
        if (!keep[k])
            continue;
        const auto& w    = weights[by_weight[k].second];
        const int runs   = static_cast<int>(std::ceil(
            std::max(64.0, develop_given_photons.max_samples() * w[0] / w_max)));
        const Estimate p = develop_given_photons(by_weight[k].second, runs);
        for (int i = 0; i < 3; ++i) {
            val[i] += w[i] * p.value;
            var[i] += w[i] * w[i] * p.standard_error * p.standard_error;
        }
    }
    for (int i = 0; i < 3; ++i)
        var[i] += dropped[i] * dropped[i];
    m.develop_fraction    = { val[0], std::sqrt(var[0]) };
    m.area_developed_um2  = { val[1], std::sqrt(var[1]) };
    m.area2_developed_um4 = { val[2], std::sqrt(var[2]) };
    return m;
}

}  // namespace filmgrain
