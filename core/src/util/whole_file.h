// Writing a file all or nothing: a temporary file of this process and
// thread beside it, renamed over it once complete. A reader sees the old
// file or the new one, never a part; a failed write leaves neither the
// temporary file nor a changed target.
#pragma once

#include <filesystem>
#include <string>

#include "filmgrain/status.h"

namespace filmgrain {

/// Writes `bytes` to `path` whole (the directory must exist).
Status write_whole_file(const std::filesystem::path& path, const std::string& bytes);

}  // namespace filmgrain
