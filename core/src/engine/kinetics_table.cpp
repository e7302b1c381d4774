// MODEL.md sections 3-4 tabulated: P(develop | N).
#include "engine/kinetics_table.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <limits>
#include <optional>
#include <thread>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include <unistd.h>

#include "util/parallel.h"
#include "util/process_cache.h"
#include "util/rng.h"
#include "util/bytes.h"
#include "util/cache_file.h"

namespace filmgrain {

namespace {

struct NodeResult {
    double p      = 0.0;
    double se     = 0.0;
    uint64_t runs = 0, events = 0, arrivals = 0;
};

/// The n4 at which a run of the chain stops (stop_at_n4): the survival
/// probability (1 - f)(1 - d)^n4 is then at most a thousandth of the target
/// standard error, and n4 never falls, so the run's survival, taken as the
/// value at that n4, is too high by less than that (the full chain would
/// only have lowered it). Runs at large N, where every grain forms many
/// development centres, stop after the first few instead of processing all
/// N arrivals. No stop when centres do not develop (d = 0).
uint64_t stop_n4(const Development& dev, double target_standard_error)
{
    return dev.n4_needed(std::max(1e-3 * target_standard_error, 1e-300));
}

/// One run of the chain for n photons on its own stream (key, salt, n,
/// run): its survival probability and the steps it took (events, and the
/// n photons' spacings, all drawn up front).
double survival_run(uint64_t n, uint64_t key, uint64_t salt, uint64_t run,
                    const KineticsRates& rates, double shutter_s, const Development& dev,
                    uint64_t stop, uint64_t& events, uint64_t& arrivals)
{
    thread_local std::vector<double> spacings;
    Rng rng(hash_ids(key, salt, n, run), Stage::kinetics);
    const LatentImage c
        = sample_latent_image_by_spacings(n, shutter_s, rates, rng, spacings, &events, stop);
    arrivals = n;
    return dev.survival_probability(c.n4);
}

/// Chain steps spent by a build so far, against its budget (Options).
struct Budget {
    uint64_t limit = 0;  ///< 0: none
    std::atomic<uint64_t> spent { 0 };
    std::atomic<bool> exceeded { false };
    /// Adds a batch's steps; false once the budget is exceeded.
    bool charge(uint64_t steps)
    {
        if (limit && (spent += steps) > limit)
            exceeded = true;
        return !exceeded;
    }
};

/// Runs the chain for n photons until the standard error of the mean
/// survival is below the target. Each run contributes its survival
/// probability (1 - f)(1 - d)^n4: a conditional expectation, with less
/// variance than counting developed grains.
NodeResult estimate_node(uint64_t n, const KineticsRates& rates, double shutter_s,
                         const Development& dev, const DevelopTable::Options& o, Budget& budget)
{
    NodeResult r;
    if (n < 4) {
        r.p = dev.develop_probability(0);
        return r;
    }
    double sum = 0.0, sum2 = 0.0;
    // Runs cost about n events each: above 256 photons the first batch
    // shrinks so that it costs no more than at 256 (the error floor below
    // keeps a small batch from stopping on a lucky zero variance).
    const int batch = std::max(32, static_cast<int>(std::min<uint64_t>(
                                       o.min_samples, o.min_samples * uint64_t(256) / n)));
    const uint64_t stop = stop_n4(dev, o.target_standard_error);
    // The stop's bias (P low by at most this) is part of the node's error.
    const double stop_bias
        = stop == std::numeric_limits<uint64_t>::max() ? 0.0 : dev.survival_probability(stop);
    for (int done = 0; done < o.max_samples;) {
        if (budget.exceeded || cancel_requested(o.cancel))
            return r;
        const uint64_t steps_before = r.events + r.arrivals;
        for (int i = 0; i < batch && done < o.max_samples; ++i, ++done) {
            uint64_t events = 0, arrivals = 0;
            const double s = survival_run(n, o.stream_key, 0x7ab1e, static_cast<uint64_t>(done),
                                          rates, shutter_s, dev, stop, events, arrivals);
            sum += s;
            sum2 += s * s;
            r.events += events;
            r.arrivals += arrivals;
        }
        // Cost in chain steps: events and photon arrivals processed.
        if (!budget.charge(r.events + r.arrivals - steps_before))
            return r;
        r.runs          = static_cast<uint64_t>(done);
        const double m  = sum / done;
        const double v  = std::max(0.0, sum2 / done - m * m);
        // Runs that all agree still leave an unseen outcome possible: its
        // weight is about 1/done at most, so the error is never below that.
        const double se = std::max(std::sqrt(v / done), 1.0 / done);
        r.se            = se + stop_bias;
        r.p             = 1.0 - m;
        if (se <= o.target_standard_error)
            break;
    }
    return r;
}

/// The photon counts tabulated: every n up to dense_photons, then spaced
/// by node_ratio up to coarse_photons, then by coarse_ratio.
std::vector<uint64_t> node_photons(const DevelopTable::Options& options)
{
    std::vector<uint64_t> nodes;
    for (uint64_t n = 0; n <= std::min(options.max_photons, options.dense_photons); ++n)
        nodes.push_back(n);
    double next = static_cast<double>(nodes.back());
    while (nodes.back() < options.max_photons) {
        const double ratio = nodes.back() < options.coarse_photons ? options.node_ratio
                                                                   : options.coarse_ratio;
        next = std::max(next * ratio, static_cast<double>(nodes.back() + 1));
        nodes.push_back(std::min(options.max_photons, static_cast<uint64_t>(std::ceil(next))));
    }
    return nodes;
}

}  // namespace

double DevelopTable::predicted_steps(const Options& options, const KineticsRates& rates,
                                     double shutter_s, const Development& dev)
{
    constexpr int kPilotRuns = 16;
    const double target = options.target_standard_error;
    const uint64_t stop = stop_n4(dev, target);
    double steps        = 0.0;
    for (uint64_t n : node_photons(options)) {
        if (n < 4)
            continue;
        double sum = 0.0, sum2 = 0.0;
        uint64_t pilot_steps = 0;
        for (int i = 0; i < kPilotRuns; ++i) {
            uint64_t events = 0, arrivals = 0;
            const double s = survival_run(n, options.stream_key, 0x9e55, static_cast<uint64_t>(i),
                                          rates, shutter_s, dev, stop, events, arrivals);
            sum += s;
            sum2 += s * s;
            pilot_steps += events + arrivals;
        }
        const double m = sum / kPilotRuns;
        const double v = std::max(0.0, sum2 / kPilotRuns - m * m);
        // Runs until max(sqrt(v / runs), 1 / runs) <= target (estimate_node).
        const double runs = std::min(static_cast<double>(options.max_samples),
                                     std::ceil(std::max(v / (target * target), 1.0 / target)));
        steps += runs * static_cast<double>(pilot_steps) / kPilotRuns;
    }
    return steps;
}

DevelopTable::DevelopTable(const KineticsRates& rates, double shutter_s, const Development& dev,
                           const Options& options)
    : m_options(options), m_nodes_n(node_photons(options))
{
    // Nodes are independent: build them on worker threads, largest first
    // (they cost most), each into its own slot.
    std::vector<NodeResult> results(m_nodes_n.size());
    Budget budget;
    budget.limit = options.step_budget;
    std::atomic<bool> stop { false };
    const int64_t n = static_cast<int64_t>(m_nodes_n.size());
    const auto cancelled = [&] { return cancel_requested(options.cancel); };
    parallel_for(n, options.nthreads, stop, [&](int, int64_t k) {
        if (budget.exceeded || cancelled())
            return;
        const size_t i = static_cast<size_t>(n - 1 - k);
        results[i] = estimate_node(m_nodes_n[i], rates, shutter_s, dev, m_options, budget);
    });
    if (budget.exceeded || cancelled()) {
        m_complete    = false;
        m_total_steps = budget.spent;
        return;
    }

    for (const NodeResult& r : results) {
        m_nodes_p.push_back(r.p);
        m_nodes_se.push_back(r.se);
        m_max_p  = std::max(m_max_p, r.p);
        m_min_p  = std::min(m_min_p, r.p);
        m_max_se = std::max(m_max_se, r.se);
        m_total_runs += r.runs;
        m_total_events += r.events;
        m_total_steps += r.events + r.arrivals;
    }
    // Interpolation error: only between sparse nodes (dense nodes are exact
    // integers, nothing is interpolated there).
    for (size_t i = 1; i + 1 < m_nodes_n.size(); ++i) {
        if (m_nodes_n[i + 1] - m_nodes_n[i - 1] <= 2)
            continue;
        const double h0 = static_cast<double>(m_nodes_n[i] - m_nodes_n[i - 1]);
        const double h1 = static_cast<double>(m_nodes_n[i + 1] - m_nodes_n[i]);
        const double s0 = (m_nodes_p[i] - m_nodes_p[i - 1]) / h0;
        const double s1 = (m_nodes_p[i + 1] - m_nodes_p[i]) / h1;
        // f'' ~ 2 (s1 - s0) / (h0 + h1); error <= h^2 f'' / 8 with h = max.
        const double h     = std::max(h0, h1);
        const double err   = h * h * std::fabs(2.0 * (s1 - s0) / (h0 + h1)) / 8.0;
        m_max_interp       = std::max(m_max_interp, err);
    }
}

namespace {

/// What of the options decides a table's contents (not threads, budget or
/// the cancel flag), in a fixed order.
void put_options(Bytes& b, const DevelopTable::Options& o)
{
    b.put(o.max_photons);
    b.put(o.target_standard_error);
    b.put(o.min_samples);
    b.put(o.max_samples);
    b.put(o.dense_photons);
    b.put(o.node_ratio);
    b.put(o.coarse_photons);
    b.put(o.coarse_ratio);
    b.put(o.stream_key);
}

}  // namespace

std::string DevelopTable::serialize() const
{
    Bytes b;
    put_options(b, m_options);
    b.put(m_nodes_n);
    b.put(m_nodes_p);
    b.put(m_nodes_se);
    b.put(m_max_p);
    b.put(m_min_p);
    b.put(m_max_se);
    b.put(m_max_interp);
    b.put(m_total_runs);
    b.put(m_total_events);
    b.put(m_total_steps);
    b.put(static_cast<uint8_t>(m_complete));
    return std::move(b.data);
}

std::shared_ptr<const DevelopTable> DevelopTable::deserialize(const std::string& bytes,
                                                              const Options& options)
{
    Bytes want;
    put_options(want, options);
    if (bytes.compare(0, want.data.size(), want.data) != 0)
        return nullptr;
    Bytes b { bytes, want.data.size() };
    std::shared_ptr<DevelopTable> t(new DevelopTable());
    t->m_options      = options;
    t->m_nodes_n      = b.get_vector<uint64_t>();
    t->m_nodes_p      = b.get_vector<double>();
    t->m_nodes_se     = b.get_vector<double>();
    t->m_max_p        = b.get<double>();
    t->m_min_p        = b.get<double>();
    t->m_max_se       = b.get<double>();
    t->m_max_interp   = b.get<double>();
    t->m_total_runs   = b.get<uint64_t>();
    t->m_total_events = b.get<uint64_t>();
    t->m_total_steps  = b.get<uint64_t>();
    t->m_complete     = b.get<uint8_t>() == 1;
    // Whole, complete, and the nodes these options place.
    if (!b.ok || b.at != bytes.size() || !t->m_complete || t->m_nodes_n != node_photons(options)
        || t->m_nodes_p.size() != t->m_nodes_n.size()
        || t->m_nodes_se.size() != t->m_nodes_n.size())
        return nullptr;
    return t;
}

std::string table_cache_dir()
{
#ifdef FILMGRAIN_TABLE_CODE_ID
    if (const char* dir = std::getenv("FILMGRAIN_CACHE_DIR"))
        return std::string(dir) == "off" ? std::string() : std::string(dir);
    if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg == '/')
        return std::string(xdg) + "/filmgrain";
    if (const char* home = std::getenv("HOME"); home && *home)
        return std::string(home) + "/.cache/filmgrain";
#endif
    return {};
}

bool DevelopTable::is_node(uint64_t n) const
{
    return std::binary_search(m_nodes_n.begin(), m_nodes_n.end(), n);
}

double DevelopTable::standard_error(uint64_t n) const
{
    const auto it = std::lower_bound(m_nodes_n.begin(), m_nodes_n.end(), n);
    if (it == m_nodes_n.end())
        return m_nodes_se.back();
    const size_t i = static_cast<size_t>(it - m_nodes_n.begin());
    if (*it == n || i == 0)
        return m_nodes_se[i];
    return std::max(m_nodes_se[i - 1], m_nodes_se[i]);
}

double DevelopTable::interpolate(uint64_t n) const
{
    const auto it = std::upper_bound(m_nodes_n.begin(), m_nodes_n.end(), n);
    if (it == m_nodes_n.end())
        return m_nodes_p.back();
    const size_t i = static_cast<size_t>(it - m_nodes_n.begin());  // nodes[i] > n
    if (i == 0)
        return m_nodes_p.front();
    const double n0 = static_cast<double>(m_nodes_n[i - 1]), n1 = static_cast<double>(m_nodes_n[i]);
    const double t  = (static_cast<double>(n) - n0) / (n1 - n0);
    return m_nodes_p[i - 1] + t * (m_nodes_p[i] - m_nodes_p[i - 1]);
}

namespace {

#ifdef FILMGRAIN_TABLE_CODE_ID
constexpr char kTableFileMagic[] = "filmgrain P(develop|N) table 1";

/// The first bytes of a table's cache file: the format, the build's table
/// code id, and what of the key is not in the table's own bytes.
std::string table_file_header(const KineticsRates& rates, double shutter_s,
                              const Development& dev)
{
    Bytes b;
    b.data = std::string(kTableFileMagic) + '\n' + FILMGRAIN_TABLE_CODE_ID + '\n';
    b.put(rates.k_pair_per_s);
    b.put(rates.k_join_per_s);
    b.put(rates.k_loss_per_s);
    b.put(shutter_s);
    b.put(dev.fog_exponent());
    b.put(dev.dev_exponent());
    return std::move(b.data);
}

/// The cache file of a table: named by a hash of its header and options
/// (a collision only costs a rebuild: the file's header is compared, and
/// the table's own bytes hold its options).
std::filesystem::path table_file(const std::string& dir, const std::string& header,
                                 const DevelopTable::Options& options)
{
    Bytes b;
    put_options(b, options);
    return cache_file_path(dir, "tables", "table", header + b.data);
}
#endif

std::shared_ptr<const DevelopTable> read_cached_table(const KineticsRates& rates,
                                                      double shutter_s, const Development& dev,
                                                      const DevelopTable::Options& options)
{
#ifdef FILMGRAIN_TABLE_CODE_ID
    const std::string dir = table_cache_dir();
    if (dir.empty())
        return nullptr;
    const std::string header = table_file_header(rates, shutter_s, dev);
    const std::optional<std::string> body
        = read_cache_file(table_file(dir, header, options), header);
    return body ? DevelopTable::deserialize(*body, options) : nullptr;
#else
    (void)rates, (void)shutter_s, (void)dev, (void)options;
    return nullptr;
#endif
}

void write_cached_table(const KineticsRates& rates, double shutter_s, const Development& dev,
                        const DevelopTable& table)
{
#ifdef FILMGRAIN_TABLE_CODE_ID
    const std::string dir = table_cache_dir();
    if (dir.empty())
        return;
    const std::string header = table_file_header(rates, shutter_s, dev);
    write_cache_file(table_file(dir, header, table.options()), header, table.serialize());
#else
    (void)rates, (void)shutter_s, (void)dev, (void)table;
#endif
}

}  // namespace

std::shared_ptr<const DevelopTable> shared_develop_table(const KineticsRates& rates,
                                                         double shutter_s, const Development& dev,
                                                         const DevelopTable::Options& options)
{
    using Key = std::tuple<double, double, double, double, double, double, uint64_t, double, int,
                           int, uint64_t, double, uint64_t, double, uint64_t>;
    const Key key { rates.k_pair_per_s,   rates.k_join_per_s,           rates.k_loss_per_s,
                    shutter_s,            dev.fog_exponent(),           dev.dev_exponent(),
                    options.max_photons,  options.target_standard_error, options.min_samples,
                    options.max_samples,  options.dense_photons,        options.node_ratio,
                    options.coarse_photons, options.coarse_ratio,       options.stream_key };
    static ProcessCache<Key, DevelopTable> cache(16);
    if (std::shared_ptr<const DevelopTable> kept = cache.find(key))
        return kept;
    std::shared_ptr<const DevelopTable> table = read_cached_table(rates, shutter_s, dev, options);
    if (!table) {
        table = std::make_shared<const DevelopTable>(rates, shutter_s, dev, options);
        if (!table->complete())
            return table;  // over its budget or cancelled: unfinished, never kept
        write_cached_table(rates, shutter_s, dev, *table);
    }
    cache.put(key, table);
    return table;
}

}  // namespace filmgrain
