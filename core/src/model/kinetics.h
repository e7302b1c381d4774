// filmgrain: MODEL.md section 3, latent-image kinetics: the per-grain
// continuous-time Markov chain of free electrons and silver centres.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "util/rng.h"

namespace filmgrain {

/// Rate constants of one grain, already scaled by its area (MODEL.md 3),
/// per second. All finite and >= 0.
struct KineticsRates {
    double k_pair_per_s = 0.0;  ///< e -= 2, n2 += 1 at k_pair e (e - 1) / 2
    double k_join_per_s = 0.0;  ///< e -= 1, a centre grows, at k_join e n
    double k_loss_per_s = 0.0;  ///< e -= 1 at k_loss e
};

/// Final stable centres after the chain has run out of free electrons.
struct LatentImage {
    uint64_t n2 = 0;  ///< centres of two silver atoms
    uint64_t n3 = 0;  ///< centres of three
    uint64_t n4 = 0;  ///< centres of four or more: what development sees
    bool operator==(const LatentImage& o) const
    {
        return n2 == o.n2 && n3 == o.n3 && n4 == o.n4;
    }
};

/// Rate scale of a grain of area a: (a / a_mean)^(-rate_area_exponent).
double rate_scale_for_area(double area_um2, double mean_area_um2, double rate_area_exponent);

/// The exact engine's kinetics (MODEL.md 3): `absorbed_photons` arrivals at
/// i.i.d. uniform times on [0, shutter_s] (generated as sequential order
/// statistics, no sort, no storage), interleaved event by event with the
/// competing exponential processes of the table in MODEL.md 3 (Gillespie's
/// direct method), then run on after the shutter until no free electron is
/// left or no event can happen any more.
///
/// Every event consumes at least one free electron and every photon adds
/// one, so the loop takes at most 2 * absorbed_photons steps: it cannot
/// hang. Time is tracked only as the gap to the next arrival, so shutters
/// from 1e-9 s to 1e6 s keep events correctly ordered. Deterministic given
/// the stream. `events` (optional) receives the number of chain events.
///
/// `stop_at_n4`: n4 never decreases, so once it reaches a value at which
/// the grain's development is decided the rest of the chain cannot change
/// the outcome. The chain then stops with n4 == stop_at_n4 (n2, n3 are the
/// counts at that moment). The trajectory up to that point is the one the
/// full chain takes with the same stream, so "n4 >= k" is decided exactly as
/// by the full chain. Default: run to the end.
///
/// `arrivals` (optional) receives the photon arrivals processed (all of
/// them unless stopped early): the chain's cost is about arrivals + events
/// loop steps.
LatentImage simulate_latent_image(uint64_t absorbed_photons, double shutter_s,
                                  const KineticsRates& rates, Rng& rng,
                                  uint64_t* events     = nullptr,
                                  uint64_t stop_at_n4 = std::numeric_limits<uint64_t>::max(),
                                  uint64_t* arrivals  = nullptr);

/// The same chain, sampled another way for the P(develop | N) tables
/// (kinetics_table.h), where only the law of the outcome matters: equal in
/// distribution to simulate_latent_image (a different stream use, so not
/// the same outcome for the same stream). Arrival times are the partial
/// sums of n + 1 exponential spacings scaled to the shutter (the order
/// statistics of n uniforms), and the next event comes when the total
/// propensity integrated since the last event reaches an exponential clock
/// (the propensity is constant between arrivals and events). One logarithm
/// per photon and one per event, where simulate_latent_image takes a log
/// and an expm1 per photon and a log per photon or event that meets free
/// electrons. `spacings` is scratch (n + 1 values).
/// Every photon's spacing is drawn up front, so a run stopped early
/// (stop_at_n4) still costs n draws.
LatentImage sample_latent_image_by_spacings(
    uint64_t absorbed_photons, double shutter_s, const KineticsRates& rates, Rng& rng,
    std::vector<double>& spacings, uint64_t* events = nullptr,
    uint64_t stop_at_n4 = std::numeric_limits<uint64_t>::max());

}  // namespace filmgrain
