// filmgrain: numbers read from text the one way every command line here
// reads them (the CLI's modifiers and options, filmgrain-fit,
// filmgrain-sensitometry): decimal, locale-independent, fully consumed
// (std::from_chars), with a reason when they are not.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace filmgrain {

/// A finite decimal number, fully consumed. An optional leading '+' is
/// accepted (exposure_stops=+1). On failure `why` says what is wrong and `out`
/// is unchanged.
bool parse_decimal(std::string_view s, double& out, std::string& why);

/// A non-negative whole number in [0, max], decimal digits only (no sign,
/// no spaces), fully consumed. On failure `why` says what is wrong and
/// `out` is unchanged.
bool parse_count(std::string_view s, uint64_t max, uint64_t& out, std::string& why);

}  // namespace filmgrain
