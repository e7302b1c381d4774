// filmgrain: one file of an on-disk cache (the P(develop | N) tables, the
// pixel models): a header that names what the file holds (its format, the
// build's code id and the key), the value, and a check of both. A file is
// read back only when it starts with the header asked for and its check
// holds: a partial, damaged, foreign or colliding file is ignored (and the
// caller writes it again). Written whole (whole_file.h), so concurrent
// processes (a farm's frames) may share a cache directory.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace filmgrain {

/// FNV-1a over the bytes: a cache file's check (not a defence against
/// anyone, a guard against a damaged file).
uint64_t content_hash(const std::string& bytes);

/// The value of the cache file `path` if it holds `header` and passes its
/// check; nothing otherwise (missing, unreadable, other or damaged).
std::optional<std::string> read_cache_file(const std::filesystem::path& path,
                                           const std::string& header);

/// Writes header, value and check to `path`, creating its directory. Best
/// effort: a cache that cannot be written only costs the next process a
/// build, so failures are silent.
void write_cache_file(const std::filesystem::path& path, const std::string& header,
                      const std::string& value);

/// `dir`/`folder`/`prefix`-<hash of header, hex>.bin: a file name for a key.
std::filesystem::path cache_file_path(const std::string& dir, const char* folder,
                                      const char* prefix, const std::string& header);

}  // namespace filmgrain
