// Stability suite: the registry of kinetics engines (MODEL.md 3-4).
//
// Every engine that turns "N absorbed photons, a shutter, the rates and a
// development" into P(develop) is listed here once, by name, with its
// stated error. The stability tests (kinetics_extremes_test.cpp) drive every
// entry over the grid of extremes and compare each approximate entry with
// the exact one. Adding an engine is one line in kinetics_engines()
// (engines.cpp).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "model/development.h"
#include "model/kinetics.h"
#include "util/rng.h"

namespace filmgrain::stability {

/// One question to an engine: a grain that absorbed `photons` during a
/// shutter of `shutter_s`, with these rates (already area-scaled).
struct KineticsQuery {
    uint64_t photons = 0;
    double shutter_s = 1.0 / 48.0;
    KineticsRates rates;
};

/// An engine's answer: P(develop | N) with its error, split in two parts.
struct EngineEstimate {
    double p               = 0.0;  ///< the estimate of P(develop | N)
    double standard_error  = 0.0;  ///< random error (the engine's Monte Carlo), 1 sigma
    double bias_bound      = 0.0;  ///< systematic error the engine states (0: none)
};

/// One engine of the registry.
struct KineticsEngine {
    std::string name;
    /// P(develop | N photons, shutter_s, rates, Development) from about
    /// `samples` runs (engines that do not sample ignore it), on streams
    /// keyed by `seed`. Deterministic.
    std::function<EngineEstimate(const KineticsQuery& query, const Development& dev,
                                 int samples, uint64_t seed)>
        develop_probability;
    /// For engines that sample grains one by one: the latent image of one
    /// grain drawn from `rng` (events: the chain events it took). Engines
    /// that may stop early return the centres at the moment they stopped
    /// (so n4 is a lower bound of the full chain's). Null if the engine does
    /// not sample.
    std::function<LatentImage(const KineticsQuery& query, const Development& dev, Rng& rng,
                              uint64_t* events)>
        sample;
    /// True for the reference (MODEL.md 3 simulated event by event).
    bool exact = false;
    /// True for engines that build a table per (rates, shutter,
    /// development) before answering: each new rate set costs a table
    /// build, so the tests give them a smaller rate grid (rate_grid()).
    bool tabulates = false;
};

/// Every engine present in this build, the exact one first.
const std::vector<KineticsEngine>& kinetics_engines();

/// The reference entry (kinetics_engines()[0]).
const KineticsEngine& exact_engine();

/// Stock with a given development: d = 1 - exp(-time / tau_dev),
/// f = 1 - exp(-time / tau_fog) (MODEL.md 4).
Stock development_stock(double development_time_s, double development_tau_s,
                        double fog_tau_s);

}  // namespace filmgrain::stability
