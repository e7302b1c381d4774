// libFuzzer target: parse_stock_json (MODEL.md 6, core/src/model/stock.cpp) on
// arbitrary bytes. Besides the sanitizers (memory errors, undefined
// behaviour, uncaught exceptions, stack overflow), it checks the parser's
// contract on every input:
//  - failure comes with a non-empty message and leaves `out` untouched;
//  - success gives a stock that validates, and that survives the round trip
//    through stock_to_json unchanged (stock.h: parse(to_json(s)) == s).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "filmgrain/stock.h"

namespace {

[[noreturn]] void fail(const char* what, const std::string& detail)
{
    std::fprintf(stderr, "stock_json_fuzzer: %s: %s\n", what, detail.c_str());
    std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    using filmgrain::Stock;
    const std::string text(reinterpret_cast<const char*>(data), size);
    Stock out;
    out.name = "untouched";
    const std::string before = filmgrain::stock_to_json(out);
    const filmgrain::Status s = filmgrain::parse_stock_json(text, "fuzz", out);
    if (!s) {
        if (s.message().empty())
            fail("empty error message", text);
        if (filmgrain::stock_to_json(out) != before)
            fail("a failed parse changed its output", s.message());
        return 0;
    }
    if (filmgrain::Status v = out.validate(); !v)
        fail("parsed stock does not validate", v.message());
    const std::string json = filmgrain::stock_to_json(out);
    Stock again;
    if (filmgrain::Status r = filmgrain::parse_stock_json(json, "round trip", again); !r)
        fail("round trip does not parse", r.message() + " in " + json);
    if (filmgrain::stock_to_json(again) != json)
        fail("round trip changed the stock", json);
    return 0;
}
