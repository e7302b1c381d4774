// MODEL.md section 3: the latent-image chain, simulated exactly.
#include "model/kinetics.h"

#include <cmath>

namespace filmgrain {

double rate_scale_for_area(double area_um2, double mean_area_um2, double rate_area_exponent)
{
    if (rate_area_exponent == 0.0)
        return 1.0;
    return std::pow(area_um2 / mean_area_um2, -rate_area_exponent);
}

namespace {

/// The chain's state and its three propensities (MODEL.md 3's table): the
/// one place of the rates' formulas and of what each event does, shared by
/// both samplers below.
struct ChainState {
    LatentImage c;
    uint64_t e    = 0;  // free electrons
    double a_pair = 0.0, a_join = 0.0, a_loss = 0.0, total = 0.0;

    void update_propensities(const KineticsRates& rates)
    {
        const double de      = static_cast<double>(e);
        const double centres = static_cast<double>(c.n2 + c.n3 + c.n4);
        a_pair               = rates.k_pair_per_s * de * (de - 1.0) * 0.5;
        a_join               = rates.k_join_per_s * de * centres;
        a_loss               = rates.k_loss_per_s * de;
        total                = a_pair + a_join + a_loss;
    }

    /// Fires the event that `pick`, uniform on [0, total), chooses, in
    /// proportion to its propensity. The fallbacks only matter when
    /// rounding puts `pick` on a boundary: they never choose an event whose
    /// propensity is zero. True when n4 reached stop_at_n4 (decided).
    bool fire(double pick, const KineticsRates& rates, uint64_t stop_at_n4)
    {
        if (pick < a_pair || (a_join <= 0.0 && a_loss <= 0.0)) {
            e -= 2;
            ++c.n2;
        } else if (pick < a_pair + a_join || a_loss <= 0.0) {
            // Which centre the electron joins, in proportion to the counts.
            const double which = (pick - a_pair) / (rates.k_join_per_s * static_cast<double>(e));
            if (which < static_cast<double>(c.n2) || (c.n3 == 0 && c.n4 == 0)) {
                --c.n2;
                ++c.n3;
            } else if (which < static_cast<double>(c.n2 + c.n3) || c.n4 == 0) {
                --c.n3;
                ++c.n4;
                if (c.n4 >= stop_at_n4) {
                    --e;
                    return true;  // decided: the outcome cannot change any more
                }
            }
            // else: a 4+-centre grows and stays a 4+-centre.
            --e;
        } else {
            --e;  // loss
        }
        return false;
    }
};

}  // namespace

LatentImage simulate_latent_image(uint64_t absorbed_photons, double shutter_s,
                                  const KineticsRates& rates, Rng& rng, uint64_t* events,
                                  uint64_t stop_at_n4, uint64_t* arrivals)
{
    ChainState s;
    uint64_t remaining = absorbed_photons;
    uint64_t n_events  = 0;
    // Time of the last arrival and the gap to the next one, seconds.
    // Arrivals are the order statistics of `remaining` uniforms on
    // [t, shutter]: the next one is t + (shutter - t) (1 - U^(1/remaining)),
    // computed with expm1 so that it stays exact for millions of photons.
    // Waiting times are subtracted from the (small) gap, never added to a
    // (large) t, so event ordering survives any shutter length.
    double t_s            = 0.0;  // time of the last arrival
    double next_arrival_s = 0.0;
    double gap_s          = 0.0;  // next arrival minus the current time
    const auto draw_arrival = [&]() {
        const double u = rng.uniform_open0();
        const double f = -std::expm1(std::log(u) / static_cast<double>(remaining));
        gap_s          = (shutter_s - t_s) * f;
        next_arrival_s = t_s + gap_s;
    };
    if (remaining > 0)
        draw_arrival();

    for (;;) {
        s.update_propensities(rates);
        if (remaining > 0) {
            // Does the next chain event come before the next photon?
            bool arrival = s.total <= 0.0;
            if (!arrival) {
                const double wait_s = -std::log(rng.uniform_open0()) / s.total;
                arrival             = wait_s >= gap_s;
                if (!arrival)
                    gap_s -= wait_s;
            }
            if (arrival) {
                t_s = next_arrival_s;
                ++s.e;
                --remaining;
                if (remaining > 0)
                    draw_arrival();
                continue;
            }
        } else if (s.total <= 0.0) {
            break;  // no photons left and nothing can happen: e is frozen
        }
        // After the last photon only the order of events matters (the chain
        // runs to completion), so no waiting time is drawn then.
        ++n_events;
        if (s.fire(rng.uniform() * s.total, rates, stop_at_n4))
            break;
        if (s.e == 0 && remaining == 0)
            break;
    }
    if (events)
        *events = n_events;
    if (arrivals)
        *arrivals = absorbed_photons - remaining;
    return s.c;
}

LatentImage sample_latent_image_by_spacings(uint64_t absorbed_photons, double shutter_s,
                                            const KineticsRates& rates, Rng& rng,
                                            std::vector<double>& spacings, uint64_t* events,
                                            uint64_t stop_at_n4)
{
    ChainState s;
    const uint64_t n = absorbed_photons;
    // The order statistics of n uniforms on [0, shutter] are the partial
    // sums of n + 1 standard exponential spacings, scaled to sum to the
    // shutter: arrival k comes spacings[k] * s_per_spacing after arrival k - 1.
    spacings.resize(static_cast<size_t>(n) + 1);
    double sum = 0.0;
    for (double& x : spacings) {
        x = -std::log(rng.uniform_open0());
        sum += x;
    }
    const double s_per_spacing = shutter_s / sum;
    // The next event comes when the propensity integrated over time since
    // the last event reaches `clock`, a standard exponential (the total
    // propensity is constant between arrivals and events): one draw per
    // event, none per arrival.
    double clock      = -std::log(rng.uniform_open0());
    uint64_t arrived  = 0;
    double gap_s      = n > 0 ? spacings[0] * s_per_spacing : 0.0;  // to the next arrival
    uint64_t n_events = 0;
    for (;;) {
        s.update_propensities(rates);
        if (arrived < n) {
            const double hazard = s.total * gap_s;
            if (clock >= hazard) {
                clock -= hazard;
                ++s.e;
                ++arrived;
                if (arrived < n)
                    gap_s = spacings[static_cast<size_t>(arrived)] * s_per_spacing;
                continue;
            }
            gap_s = std::max(0.0, gap_s - clock / s.total);
            clock = -std::log(rng.uniform_open0());
        } else if (s.total <= 0.0) {
            break;
        }
        ++n_events;
        if (s.fire(rng.uniform() * s.total, rates, stop_at_n4))
            break;
        if (s.e == 0 && arrived == n)
            break;
    }
    if (events)
        *events = n_events;
    return s.c;
}

}  // namespace filmgrain
