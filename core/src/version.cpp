#include "filmgrain/version.h"

namespace filmgrain {

const char* version_string() { return FILMGRAIN_VERSION_STRING; }

}  // namespace filmgrain
