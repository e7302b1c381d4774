// Shared helpers of the sensitometry tests.
#pragma once

#include <string>

#include <gtest/gtest.h>

#include "filmgrain/stock.h"
#include "patch.h"
#include "strip.h"

namespace filmgrain::sensitometry::testing {

/// A built-in preset or a stock of tools/sensitometry/stocks by name.
inline Stock load_test_stock(const std::string& name)
{
    Stock stock;
    const Status s = name == "dense"
                         ? load_stock(std::string(FILMGRAIN_SENSITOMETRY_STOCKS) + "/dense.json", stock)
                         : load_stock(name, stock);
    EXPECT_TRUE(s) << s.message();
    return stock;
}

/// The engine the tests measure: the reference.
/// The exact engine's results, bit for bit, computed faster: the chain
/// stops once each grain's fate is decided (exposure and coverage exact).
inline MeasureSettings exact_settings()
{
    MeasureSettings m;
    m.engine   = Engine::automatic;
    m.kinetics = KineticsMethod::early_stop;
    return m;
}

/// A strip of the tests: 10^log10_h_min to 10^log10_h_max lx s, 0.1 log H
/// apart, patches of up to 1 mm^2 and max_cost_s each, fog_area_um2 of fog.
inline StripSpec test_strip(double log10_h_min, double log10_h_max, double max_cost_s,
                            double fog_area_um2, uint64_t seed)
{
    StripSpec spec;
    spec.log10_h_min         = log10_h_min;
    spec.log10_h_max         = log10_h_max;
    spec.log10_h_step        = 0.1;
    spec.budget.max_area_um2 = 1.0e6;
    spec.budget.max_cost_s   = max_cost_s;
    spec.fog_area_um2        = fog_area_um2;
    spec.seed                = seed;
    return spec;
}

/// `stock` exposed through `spec` and measured by the reference
/// (exact_settings); a failure fails the test.
inline Curve measure_strip(const Stock& stock, const StripSpec& spec)
{
    Curve c;
    const Status s = expose_strip(stock, spec, exact_settings(), c);
    EXPECT_TRUE(s) << s.message();
    return c;
}

}  // namespace filmgrain::sensitometry::testing
