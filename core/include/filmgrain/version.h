// filmgrain: per-grain film simulation.
#pragma once

namespace filmgrain {

/// The library version, "MAJOR.MINOR.PATCH" (from CMake's project()).
const char* version_string();

}  // namespace filmgrain
