// Test helper: a small P(develop | N) table with the rates of MODEL.md 7,
// the scene's default shutter and the default stock's development, for the
// tests of what is built on tables (curves, kernels, pixel statistics).
#pragma once

#include "model/development.h"
#include "engine/kinetics_table.h"

namespace filmgrain {

inline DevelopTable small_develop_table(uint64_t max_photons = 256,
                                        double target_standard_error = 5e-3)
{
    Stock stock;
    DevelopTable::Options o;
    o.max_photons           = max_photons;
    o.target_standard_error = target_standard_error;
    o.stream_key            = 3;
    return DevelopTable({ 1e7, 1e6, 10 }, 1.0 / 48, Development(stock), o);
}

}  // namespace filmgrain
