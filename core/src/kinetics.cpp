// MODEL.md section 3: the latent-image chain, simulated exactly.
#include "kinetics.h"

#include <cmath>

namespace filmgrain {

double rate_scale_for_area(double area_um2, double mean_area_um2, double rate_area_exponent)
{
    if (rate_area_exponent == 0.0)
        return 1.0;
    return std::pow(area_um2 / mean_area_um2, -rate_area_exponent);
}

LatentImage simulate_latent_image(uint64_t absorbed_photons, double shutter_s,
                                  const KineticsRates& rates, Rng& rng, uint64_t* events,
                                  uint64_t stop_at_n4, uint64_t* arrivals)
{
    LatentImage c;
    uint64_t e         = 0;  // free electrons
    uint64_t remaining = absorbed_photons;
    uint64_t n_events  = 0;
    // Time of the last arrival and the gap to the next one, seconds.
    // Arrivals are the order statistics of `remaining` uniforms on
    // [t, shutter]: the next one is t + (shutter - t) (1 - U^(1/remaining)),
    // computed with expm1 so that it stays exact for millions of photons.
    // Waiting times are subtracted from the (small) gap, never added to a
    // (large) t, so event ordering survives any shutter length.
    double t            = 0.0;  // time of the last arrival
    double next_arrival = 0.0;
    double gap          = 0.0;  // next_arrival minus the current time
    const auto draw_arrival = [&]() {
        const double u = rng.uniform_open0();
        const double f = -std::expm1(std::log(u) / static_cast<double>(remaining));
        gap            = (shutter_s - t) * f;
        next_arrival   = t + gap;
    };
    if (remaining > 0)
        draw_arrival();

    for (;;) {
        const double de      = static_cast<double>(e);
        const double centres = static_cast<double>(c.n2 + c.n3 + c.n4);
        const double a_pair  = rates.k_pair_per_s * de * (de - 1.0) * 0.5;
        const double a_join  = rates.k_join_per_s * de * centres;
        const double a_loss  = rates.k_loss_per_s * de;
        const double total   = a_pair + a_join + a_loss;

        if (remaining > 0) {
            // Does the next chain event come before the next photon?
            bool arrival = total <= 0.0;
            if (!arrival) {
                const double wait = -std::log(rng.uniform_open0()) / total;
                arrival           = wait >= gap;
                if (!arrival)
                    gap -= wait;
            }
            if (arrival) {
                t = next_arrival;
                ++e;
                --remaining;
                if (remaining > 0)
                    draw_arrival();
                continue;
            }
        } else if (total <= 0.0) {
            break;  // no photons left and nothing can happen: e is frozen
        }
        // After the last photon only the order of events matters (the chain
        // runs to completion), so no waiting time is drawn then.
        ++n_events;
        // Choose the event in proportion to its propensity. The fallbacks
        // only matter when rounding puts `pick` on a boundary: they never
        // choose an event whose propensity is zero.
        const double pick = rng.uniform() * total;
        if (pick < a_pair || (a_join <= 0.0 && a_loss <= 0.0)) {
            e -= 2;
            ++c.n2;
        } else if (pick < a_pair + a_join || a_loss <= 0.0) {
            // Which centre the electron joins, in proportion to the counts.
            const double which = (pick - a_pair) / (rates.k_join_per_s * de);
            if (which < static_cast<double>(c.n2) || (c.n3 == 0 && c.n4 == 0)) {
                --c.n2;
                ++c.n3;
            } else if (which < static_cast<double>(c.n2 + c.n3) || c.n4 == 0) {
                --c.n3;
                ++c.n4;
                if (c.n4 >= stop_at_n4) {
                    --e;
                    break;  // decided: the outcome cannot change any more
                }
            }
            // else: a 4+-centre grows and stays a 4+-centre.
            --e;
        } else {
            --e;  // loss
        }
        if (e == 0 && remaining == 0)
            break;
    }
    if (events)
        *events = n_events;
    if (arrivals)
        *arrivals = absorbed_photons - remaining;
    return c;
}

}  // namespace filmgrain
