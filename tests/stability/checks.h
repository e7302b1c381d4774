// Stability suite: the assertions shared by its tests, as functions, so
// that checks_test.cpp can feed them wrong answers and see them fail.
#pragma once

#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engines.h"

namespace filmgrain::stability {

/// Sigmas of every statistical comparison in the suite. Each comparison is
/// of two independent estimates (or of one estimate and an exact value);
/// P(|Z| > 5) = 5.7e-7 for a normal Z, so even the ~1e4 comparisons of the
/// whole suite give a false alarm with probability below 1% (and seeds are
/// fixed: a run that passes passes every time).
inline constexpr double kSigmas = 5.0;

/// The estimate is a finite probability with finite, non-negative errors.
inline ::testing::AssertionResult is_probability(const EngineEstimate& e)
{
    if (std::isfinite(e.p) && e.p >= 0.0 && e.p <= 1.0 && std::isfinite(e.standard_error)
        && e.standard_error >= 0.0 && std::isfinite(e.bias_bound) && e.bias_bound >= 0.0)
        return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure()
           << "not a probability with finite errors: p = " << e.p << ", se = "
           << e.standard_error << ", bias bound = " << e.bias_bound;
}

/// Two estimates of the same P agree: their difference is within both
/// stated biases plus kSigmas standard deviations of the difference of two
/// independent estimates, sqrt(se_a^2 + se_b^2).
inline ::testing::AssertionResult agree(const EngineEstimate& a, const EngineEstimate& b)
{
    const double tolerance
        = a.bias_bound + b.bias_bound + kSigmas * std::hypot(a.standard_error, b.standard_error);
    const double diff = std::fabs(a.p - b.p);
    if (diff <= tolerance)
        return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure()
           << a.p << " (se " << a.standard_error << ", bias <= " << a.bias_bound << ") vs "
           << b.p << " (se " << b.standard_error << ", bias <= " << b.bias_bound
           << "): differ by " << diff << " > " << tolerance;
}

/// An estimate equals an exact value: within its bias plus kSigmas of its
/// standard error, and within 1e-12 (a mean of identical doubles may round
/// by a few ulps) when the engine is exact and all its runs agreed.
inline ::testing::AssertionResult equals_exactly_or_within_error(const EngineEstimate& e,
                                                                 double exact_value)
{
    const double tolerance = std::max(1e-12, e.bias_bound + kSigmas * e.standard_error);
    if (std::fabs(e.p - exact_value) <= tolerance)
        return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "P = " << e.p << " (se " << e.standard_error
                                         << ", bias <= " << e.bias_bound << "), expected "
                                         << exact_value;
}

/// A sequence of estimates (in increasing exposure) never falls by more
/// than the noise: each step may fall by at most both biases plus kSigmas
/// standard deviations of the difference (independent estimates).
inline ::testing::AssertionResult non_decreasing(const std::vector<EngineEstimate>& seq)
{
    for (size_t i = 1; i < seq.size(); ++i) {
        const EngineEstimate &a = seq[i - 1], &b = seq[i];
        const double noise = a.bias_bound + b.bias_bound
                             + kSigmas * std::hypot(a.standard_error, b.standard_error);
        if (b.p < a.p - noise)
            return ::testing::AssertionFailure()
                   << "falls from " << a.p << " to " << b.p << " at step " << i
                   << " (noise allowance " << noise << ")";
    }
    return ::testing::AssertionSuccess();
}

/// Bookkeeping of one grain's chain (MODEL.md 3). Every event consumes at
/// least one free electron and each photon adds one, so events <= N (the
/// "no hang" bound); atoms are conserved, so 2 n2 + 3 n3 + 4 n4 <= N (4+
/// centres hold at least 4 atoms); fewer than 4 photons cannot build a
/// 4-centre. For an engine that runs the chain to the end, every centre
/// came from one pairing event and every other event consumed one electron,
/// so the free electrons left are N - events - centres >= 0, and they are 0
/// whenever some process could still consume them: loss (k_loss > 0), or
/// growth (k_join > 0) of an existing centre; with pairing alone at most
/// one is left (a lone electron cannot pair).
inline ::testing::AssertionResult chain_bookkeeping(const LatentImage& c, uint64_t events,
                                                    uint64_t photons,
                                                    const KineticsRates& rates,
                                                    bool ran_to_the_end)
{
    std::ostringstream why;
    const uint64_t centres = c.n2 + c.n3 + c.n4;
    const uint64_t atoms   = 2 * c.n2 + 3 * c.n3 + 4 * c.n4;
    if (events > photons)
        why << "events " << events << " > photons " << photons << "; ";
    if (atoms > photons)
        why << "atoms " << atoms << " > photons " << photons << "; ";
    if (photons < 4 && c.n4 != 0)
        why << "n4 = " << c.n4 << " from " << photons << " photons; ";
    if (ran_to_the_end) {
        if (events + centres > photons) {
            why << "events + centres = " << events + centres << " > photons " << photons
                << "; ";
        } else {
            const uint64_t left = photons - events - centres;
            uint64_t allowed    = photons;  // nothing can consume them
            if (rates.k_loss_per_s > 0.0 || (rates.k_join_per_s > 0.0 && centres > 0))
                allowed = 0;
            else if (rates.k_pair_per_s > 0.0)
                allowed = 1;
            if (left > allowed)
                why << left << " free electrons left (at most " << allowed << " may be); ";
        }
    }
    if (why.str().empty())
        return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure()
           << why.str() << "n2 " << c.n2 << " n3 " << c.n3 << " n4 " << c.n4 << " events "
           << events << " photons " << photons << " rates (" << rates.k_pair_per_s << ", "
           << rates.k_join_per_s << ", " << rates.k_loss_per_s << ")";
}

}  // namespace filmgrain::stability
