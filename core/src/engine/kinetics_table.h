// filmgrain: MODEL.md sections 3-4 tabulated: P(develop | N absorbed
// photons) for one population's rates and the scene's shutter.
//
// When irradiance is constant over the shutter, a grain's latent image
// depends only on its photon count N, the shutter and its rates. For a
// population whose rates do not depend on grain area (rate_area_exponent =
// 0) the probability that a grain with N photons develops is then one
// function P(N), the same for every grain of the scene. The table samples
// it once per scene by running the chain (MODEL.md 3) many times per node
// (sample_latent_image_by_spacings: the exact engine's law, sampled with
// fewer transcendental calls), and grains draw their outcome from it: equal
// in distribution to the exact engine up to the table's own error, which
// it reports.
#pragma once

#include <cstdint>
#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "model/development.h"
#include "filmgrain/render.h"  // table_cache_dir
#include "model/kinetics.h"

namespace filmgrain {

class DevelopTable {
public:
    struct Options {
        /// Largest N tabulated; grains with more photons use the chain.
        uint64_t max_photons = 64;
        /// Monte Carlo runs per node stop when the standard error of P at
        /// that node is below this (or at max_samples).
        double target_standard_error = 1e-3;
        int min_samples = 256;
        int max_samples = 1 << 17;
        /// Nodes are every N up to dense_photons, then spaced by node_ratio
        /// up to coarse_photons, then by coarse_ratio (P(N) flattens out).
        uint64_t dense_photons  = 64;
        double node_ratio       = 1.06;
        uint64_t coarse_photons = 1024;
        double coarse_ratio     = 1.25;
        /// Keys the Monte Carlo streams (apart from every grain's).
        uint64_t stream_key = 0;
        /// Worker threads for the build (0: all).
        int nthreads = 0;
        /// Chain steps (events + photon arrivals) the build may spend (0:
        /// no limit). A build that would spend more stops early and is
        /// incomplete(): deterministic, since it stops exactly when its
        /// full cost, total_steps() of a complete build, exceeds the
        /// budget, whatever the threads.
        uint64_t step_budget = 0;
        /// Set by another thread (a cancelled render): the build stops
        /// within a batch of runs and is incomplete(). Not part of what the
        /// table is (a complete build never saw it set).
        const std::atomic<bool>* cancel = nullptr;
    };

    /// Builds the table. Deterministic for any thread count: each node's
    /// runs have their own streams. Each run stops once its grain holds so
    /// many development centres that its survival is below a thousandth of
    /// the target standard error (the bias that leaves: less than that,
    /// upwards in survival). Cost: sum over nodes of runs x their steps
    /// (the N photons' arrival spacings, all drawn up front, and the chain
    /// events, fewer where grains form many centres early: at most ~2N).
    DevelopTable(const KineticsRates& rates, double shutter_s, const Development& dev,
                 const Options& options);

    /// The chain steps (total_steps()) a build with these options is
    /// predicted to spend, from a pilot of 16 runs per node (their own
    /// streams): each node's runs until its standard error meets the
    /// target, max(v / target^2, 1 / target), at the pilot's steps per run.
    /// Deterministic; costs about 16 runs per node.
    static double predicted_steps(const Options& options, const KineticsRates& rates,
                                  double shutter_s, const Development& dev);

    /// P(develop | n) for n <= max_photons(): exact for n < 4 (fog only),
    /// the node's estimate at a node, linear interpolation between nodes.
    double probability(uint64_t n) const
    {
        if (n < m_nodes_n.size() && n <= m_options.dense_photons)
            return m_nodes_p[n];
        return interpolate(n);
    }
    uint64_t max_photons() const { return m_options.max_photons; }
    const Options& options() const { return m_options; }
    /// Standard error of P at n (with the runs' stop bias added, at most a
    /// thousandth of the target): the node's at a node, the larger of the
    /// two neighbours' between nodes.
    double standard_error(uint64_t n) const;
    /// Whether n is a node (no interpolation error there).
    bool is_node(uint64_t n) const;
    /// Largest and smallest P over the table (for early decisions).
    double max_probability() const { return m_max_p; }
    double min_probability() const { return m_min_p; }

    /// Largest Monte Carlo standard error of a node.
    double max_standard_error() const { return m_max_se; }
    /// Estimated largest error of linear interpolation between nodes:
    /// |second difference| / 8 of each pair of neighbouring intervals (the
    /// h^2 f''/8 bound of linear interpolation, MC noise included).
    double max_interpolation_error() const { return m_max_interp; }
    size_t node_count() const { return m_nodes_n.size(); }
    uint64_t total_runs() const { return m_total_runs; }
    uint64_t total_events() const { return m_total_events; }
    /// Chain steps of the build: events plus photon arrivals (its cost).
    uint64_t total_steps() const { return m_total_steps; }
    /// False when the build ran out of its event budget or was cancelled:
    /// then the table must not be used (its nodes are unfinished).
    bool complete() const { return m_complete; }

    /// The table as bytes (its options' contents and every node), and
    /// back: deserialize gives a table equal to the one serialized, or none
    /// when the bytes are not a complete table serialized with these
    /// options.
    std::string serialize() const;
    static std::shared_ptr<const DevelopTable> deserialize(const std::string& bytes,
                                                           const Options& options);

private:
    DevelopTable() = default;
    double interpolate(uint64_t n) const;

    Options m_options;
    std::vector<uint64_t> m_nodes_n;
    std::vector<double> m_nodes_p;
    std::vector<double> m_nodes_se;
    double m_max_p = 0.0, m_min_p = 1.0, m_max_se = 0.0, m_max_interp = 0.0;
    uint64_t m_total_runs = 0, m_total_events = 0, m_total_steps = 0;
    bool m_complete = true;
};

/// The table of these rates, shutter, development and options, built once
/// per process: tables built earlier (by any render, expected curve or
/// fit) with the same key are returned, not rebuilt. The key is everything
/// that determines a table's contents (the thread count and the cancel
/// flag do not), so a table is the same whether built or found and results
/// never depend on call history. Incomplete builds (over their step budget,
/// or cancelled) are returned but never kept. Bounded: the oldest of 16
/// entries goes first. Thread safe.
///
/// Complete tables are also kept on disk, one file per key in
/// table_cache_dir() (filmgrain/render.h), so that other processes (a
/// farm's frames, a command run again) read them instead of building them:
/// a file is used only if it holds this key, was written by a build of the
/// same table code, compiler and flags (FILMGRAIN_TABLE_CODE_ID) and passes
/// its check; anything else (a partial, damaged or foreign file) is ignored
/// and replaced. Files are written whole (a temporary file renamed into
/// place); a cache that cannot be written is skipped. Unbounded: a program
/// that builds tables for many trial stocks (filmgrain-fit) turns it off.
std::shared_ptr<const DevelopTable> shared_develop_table(const KineticsRates& rates,
                                                         double shutter_s, const Development& dev,
                                                         const DevelopTable::Options& options);

}  // namespace filmgrain
