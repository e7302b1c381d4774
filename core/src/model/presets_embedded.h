// filmgrain: the built-in stock presets, embedded from stocks/*.json.
#pragma once

#include <vector>

namespace filmgrain {

/// One built-in preset: its name (the file's stem) and its JSON text.
struct EmbeddedPreset {
    const char* name;
    const char* json;
};

/// All built-in presets, the default first. Generated at build time.
const std::vector<EmbeddedPreset>& embedded_presets();

}  // namespace filmgrain
