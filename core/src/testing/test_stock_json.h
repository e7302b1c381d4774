// Test helper: a stock's JSON that parse_stock_json must refuse, and how.
#pragma once

#include <string>

#include <gtest/gtest.h>

#include "filmgrain/stock.h"

namespace filmgrain {

/// parse_stock_json(json, "test.json") fails with a message that contains
/// `needle` and names the file.
inline void expect_stock_error(const std::string& json, const std::string& needle)
{
    Stock s;
    const Status st = parse_stock_json(json, "test.json", s);
    ASSERT_FALSE(st) << json;
    EXPECT_NE(st.message().find(needle), std::string::npos)
        << "message: " << st.message() << "\nexpected to contain: " << needle;
    EXPECT_NE(st.message().find("test.json"), std::string::npos) << st.message();
}

}  // namespace filmgrain
