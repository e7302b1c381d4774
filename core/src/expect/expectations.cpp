// Expected values of the model, composed from its distributions.
#include "expect/expectations.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "model/exposure.h"
#include "expect/grain_counts.h"
#include "util/rng.h"

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
    // over the size nodes (grain_counts.h), so that each P(develop | N) is
    // used (and its Monte Carlo error counted) once.
    const double photons_per_um2
        = pop.quantum_efficiency * kPhotonsPerUm2PerLxs * exposure_lxs;
    std::map<uint64_t, std::array<double, 3>> weights;
    DevelopmentMoments m;
    for_each_size_and_count(pop, photons_per_um2,
                            [&](size_t, double weight, double a, uint64_t n, double p) {
        const double w = weight * p;
        m.mean_photons += w * static_cast<double>(n);
        if (w < 1e-300)
            return;
        auto& acc = weights[n];
        acc[0] += w;
        acc[1] += w * a;
        acc[2] += w * a * a;
    });
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
