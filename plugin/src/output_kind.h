// filmgrain CLI: what the output EXR holds (--filmgrain:output=).
// Plain names only, so that the modifier parser (modifiers.h) needs nothing
// but the core; the transforms are in output_transform.h.
#pragma once

#include <string>
#include <string_view>

namespace filmgrain::cli {

enum class OutputKind {
    density,  ///< negative density per layer (the operator's output)
    adx10,    ///< Academy Density Exchange, 10-bit code values / 1023
    adx16,    ///< Academy Density Exchange, 16-bit code values / 65535
    regrain,  ///< scene-linear positive: the input plus the film's grain
};

/// The name used by output=, filmgrain:output and --stats.
inline const char* output_kind_name(OutputKind k)
{
    switch (k) {
    case OutputKind::density: return "density";
    case OutputKind::adx10: return "adx10";
    case OutputKind::adx16: return "adx16";
    case OutputKind::regrain: return "regrain";
    }
    return "density";
}

/// Every kind, the default first.
inline constexpr OutputKind kOutputKinds[]
    = { OutputKind::density, OutputKind::adx10, OutputKind::adx16, OutputKind::regrain };

/// False when `name` is none of the names above.
inline bool parse_output_kind(std::string_view name, OutputKind& out)
{
    for (OutputKind k : kOutputKinds)
        if (name == output_kind_name(k)) {
            out = k;
            return true;
        }
    return false;
}

}  // namespace filmgrain::cli
