// Shared helpers of the sensitometry tests.
#pragma once

#include <string>

#include <gtest/gtest.h>

#include "filmgrain/stock.h"
#include "patch.h"

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

}  // namespace filmgrain::sensitometry::testing
