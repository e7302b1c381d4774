// Numbers read from text (parse_number.h).
#include "util/parse_number.h"

#include <charconv>
#include <cmath>
#include <system_error>

namespace filmgrain {

bool parse_decimal(std::string_view s, double& out, std::string& why)
{
    if (!s.empty() && s[0] == '+' && s.size() > 1
        && ((s[1] >= '0' && s[1] <= '9') || s[1] == '.'))
        s.remove_prefix(1);
    double v          = 0.0;
    const char* end   = s.data() + s.size();
    const auto result = std::from_chars(s.data(), end, v, std::chars_format::general);
    if (result.ec == std::errc::result_out_of_range) {
        why = "out of the range of a double";
        return false;
    }
    if (result.ec != std::errc() || result.ptr != end) {
        why = "not a decimal number";
        return false;
    }
    if (!std::isfinite(v)) {
        why = "not a finite number";
        return false;
    }
    out = v;
    return true;
}

bool parse_count(std::string_view s, uint64_t max, uint64_t& out, std::string& why)
{
    if (s.empty()) {
        why = "empty number";
        return false;
    }
    for (char c : s)
        if (c < '0' || c > '9') {
            why = "not a non-negative whole number (decimal digits only)";
            return false;
        }
    uint64_t v        = 0;
    const char* end   = s.data() + s.size();
    const auto result = std::from_chars(s.data(), end, v, 10);
    if (result.ec == std::errc::result_out_of_range || (result.ec == std::errc() && v > max)) {
        why = "too large (at most " + std::to_string(max) + ")";
        return false;
    }
    if (result.ec != std::errc() || result.ptr != end) {
        why = "not a non-negative whole number";
        return false;
    }
    out = v;
    return true;
}

}  // namespace filmgrain
