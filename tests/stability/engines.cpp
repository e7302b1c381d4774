// The registry of kinetics engines (engines.h).
#include "engines.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <tuple>
#include <type_traits>
#include <utility>

// Engines that are still being written elsewhere in core are registered
// when their headers and entry points are present in this checkout, so the
// suite builds against any revision of core.
#if __has_include("kinetics_table.h")
#include "engine/kinetics_table.h"
#define FILMGRAIN_STABILITY_HAS_TABLE 1
#endif

namespace filmgrain::stability {

namespace {

/// Streams of the stability suite, apart from every render's grain streams
/// and from expectations.cpp's.
constexpr uint64_t kStreamKey = 0x57ab17e5;

/// Mean and standard error of S values in [0, 1]. A run of identical values
/// still leaves an unseen outcome possible: if one of probability q had
/// been missed in all S runs, q is below ~1/S (the chance (1 - q)^S of
/// missing it is then e^-1); its effect on a mean of values in [0, 1] is at
/// most q, so the error is never below 1/S.
EngineEstimate mean_of_runs(double sum, double sum2, int samples)
{
    const double s    = static_cast<double>(samples);
    const double mean = sum / s;
    const double var  = std::max(0.0, sum2 / s - mean * mean);
    return { mean, std::max(std::sqrt(var / s), 1.0 / s), 0.0 };
}

// ---------------------------------------------------------------------------
// exact: simulate_latent_image run to the end (MODEL.md 3), every N, even
// N < 4 (no shortcut: the tests must see the chain itself give fog only).

EngineEstimate exact_develop_probability(const KineticsQuery& q, const Development& dev,
                                         int samples, uint64_t seed)
{
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < samples; ++i) {
        Rng rng(hash_ids(kStreamKey, seed, q.photons, static_cast<uint64_t>(i)),
                Stage::kinetics);
        const LatentImage c = simulate_latent_image(q.photons, q.shutter_s, q.rates, rng);
        // The conditional expectation of the outcome given n4 (MODEL.md 4):
        // less variance than counting developed grains.
        const double p = dev.develop_probability(c.n4);
        sum += p;
        sum2 += p * p;
    }
    return mean_of_runs(sum, sum2, samples);
}

LatentImage exact_sample(const KineticsQuery& q, const Development&, Rng& rng,
                         uint64_t* events)
{
    return simulate_latent_image(q.photons, q.shutter_s, q.rates, rng, events);
}

// ---------------------------------------------------------------------------
// early_stop (registered when simulate_latent_image takes `stop_at_n4`): the
// develop uniform u is drawn first, the chain stops once n4 reaches the
// smallest count that develops the grain with that u. Its decision must be
// the full chain's exactly (no stated bias).

template<typename R, typename = void> struct HasStopAtN4 : std::false_type {};
template<typename R>
struct HasStopAtN4<R, std::void_t<decltype(simulate_latent_image(
                          uint64_t {}, 0.0, KineticsRates {}, std::declval<R&>(),
                          static_cast<uint64_t*>(nullptr), uint64_t {}))>> : std::true_type {};

/// The smallest n4 with which a grain holding uniform u develops; develops()
/// falls with n4 (survival (1 - f)(1 - d)^n4 decreases), so bisect it.
/// UINT64_MAX when no n4 up to `limit` suffices.
uint64_t n4_needed(const Development& dev, double u, uint64_t limit)
{
    if (dev.develops(0, u))
        return 0;
    if (!dev.develops(limit, u))
        return std::numeric_limits<uint64_t>::max();
    uint64_t lo = 0, hi = limit;  // !develops(lo), develops(hi)
    while (hi - lo > 1) {
        const uint64_t mid = lo + (hi - lo) / 2;
        (dev.develops(mid, u) ? hi : lo) = mid;
    }
    return hi;
}

template<typename R>
LatentImage early_stop_run(const KineticsQuery& q, R& rng, uint64_t stop_at_n4,
                           uint64_t* events)
{
    if constexpr (HasStopAtN4<R>::value)
        return simulate_latent_image(q.photons, q.shutter_s, q.rates, rng, events, stop_at_n4);
    else
        return simulate_latent_image(q.photons, q.shutter_s, q.rates, rng, events);
}

LatentImage early_stop_sample(const KineticsQuery& q, const Development& dev, Rng& rng,
                              uint64_t* events)
{
    // The uniform that decides development comes from its own draw first;
    // a grain that needs no centre (fog) or that no reachable n4 can
    // develop runs the full chain (the stop can only shorten it).
    const double u       = rng.uniform();
    const uint64_t limit = std::max<uint64_t>(1, q.photons / 4);
    uint64_t stop        = n4_needed(dev, u, limit);
    if (stop == 0)
        stop = std::numeric_limits<uint64_t>::max();
    return early_stop_run(q, rng, stop, events);
}

EngineEstimate early_stop_develop_probability(const KineticsQuery& q, const Development& dev,
                                              int samples, uint64_t seed)
{
    // Counts decided grains: develops(n4 at the stop, u) with the same u.
    double sum = 0.0;
    for (int i = 0; i < samples; ++i) {
        Rng rng(hash_ids(kStreamKey, seed, q.photons, static_cast<uint64_t>(i), 0xea51),
                Stage::kinetics);
        Rng first = rng;  // the u that early_stop_sample draws first
        const double u      = first.uniform();
        const LatentImage c = early_stop_sample(q, dev, rng, nullptr);
        sum += dev.develops(c.n4, u) ? 1.0 : 0.0;
    }
    // Indicators: sum2 == sum.
    return mean_of_runs(sum, sum, samples);
}

#ifdef FILMGRAIN_STABILITY_HAS_TABLE
// ---------------------------------------------------------------------------
// table: P(develop | N) tabulated by DevelopTable (kinetics_table.h). One
// table per (rates, shutter, development, samples, seed), built up to the
// next power of two >= 256 above the largest N asked so far (rebuilt when a
// larger N comes). Stated error: the
// node's standard error, plus the table's reported interpolation error away
// from nodes.

EngineEstimate table_develop_probability(const KineticsQuery& q, const Development& dev,
                                         int samples, uint64_t seed)
{
    using Key = std::tuple<double, double, double, double, double, double, int, uint64_t>;
    static std::map<Key, std::shared_ptr<DevelopTable>> cache;
    const Key key { q.rates.k_pair_per_s, q.rates.k_join_per_s, q.rates.k_loss_per_s,
                    q.shutter_s, dev.efficiency(), dev.fog_probability(), samples, seed };
    auto& table = cache[key];
    if (!table || table->max_photons() < q.photons) {
        DevelopTable::Options o;
        // Up to a power of two >= 256: the tests ask for increasing N, and
        // one table then serves most of them.
        uint64_t max_photons = 256;
        while (max_photons < q.photons)
            max_photons *= 2;
        o.max_photons           = max_photons;
        o.min_samples           = std::max(16, samples / 4);
        o.max_samples           = samples;
        o.target_standard_error = 0.0;  // always max_samples: comparable to exact
        o.stream_key            = hash_ids(kStreamKey, seed, 0x7ab1e);
        table                   = std::make_shared<DevelopTable>(q.rates, q.shutter_s, dev, o);
    }
    EngineEstimate e;
    e.p              = table->probability(q.photons);
    e.standard_error = table->standard_error(q.photons);
    e.bias_bound     = table->is_node(q.photons) ? 0.0 : table->max_interpolation_error();
    return e;
}
#endif

std::vector<KineticsEngine> make_engines()
{
    std::vector<KineticsEngine> engines;
    // The reference; must stay first.
    engines.push_back({ "exact", exact_develop_probability, exact_sample, true });
    // One line per further engine:
    if (HasStopAtN4<Rng>::value)
        engines.push_back({ "early_stop", early_stop_develop_probability, early_stop_sample });
#ifdef FILMGRAIN_STABILITY_HAS_TABLE
    engines.push_back({ "table", table_develop_probability, nullptr, false, true });
#endif
    return engines;
}

}  // namespace

const std::vector<KineticsEngine>& kinetics_engines()
{
    static const std::vector<KineticsEngine> engines = make_engines();
    return engines;
}

const KineticsEngine& exact_engine() { return kinetics_engines().front(); }

Stock development_stock(double development_time_s, double development_tau_s,
                        double fog_tau_s)
{
    Stock stock;
    stock.development_time_s = development_time_s;
    stock.development_tau_s  = development_tau_s;
    stock.fog_tau_s          = fog_tau_s;
    return stock;
}

}  // namespace filmgrain::stability
