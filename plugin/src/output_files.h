// filmgrain CLI: all-or-nothing output files.
//
// Every output (EXR, stats, preview) is checked at the start (its directory
// must accept a new file) but created only when it is written, as an
// unnamed file in its own directory (Linux O_TMPFILE): a run killed at any
// moment, SIGKILL included, leaves no file behind. commit() links each into
// place under a hidden name (".NAME.tmp-PID") and renames that onto the
// final name (atomic on the same file system), so nothing appears under a
// final name until every output has been written. On a file system without
// O_TMPFILE the file is created under the hidden name when it is written
// (and removed on failure), as before. On any failure, or if the object is
// destroyed before commit(), every temporary file is removed.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "filmgrain/status.h"

namespace filmgrain::cli {

class OutputFiles {
public:
    OutputFiles() = default;
    ~OutputFiles();
    OutputFiles(const OutputFiles&)            = delete;
    OutputFiles& operator=(const OutputFiles&) = delete;

    /// Checks that `final_path`'s directory accepts a new file (an
    /// unwritable or missing directory fails here, before any work) and
    /// records the output. Creates nothing that outlives the call.
    Status reserve(const std::string& final_path);

    /// Creates the (unnamed) file of the reserved output `final_path` and
    /// opens it for writing: `out` is a stdio stream the caller writes and
    /// closes (fclose) before commit(). Fails if `final_path` was not
    /// reserved or is already open.
    Status open(const std::string& final_path, std::FILE*& out);

    /// Writes `bytes` as the whole content of the reserved output.
    Status write(const std::string& final_path, const std::string& bytes);

    /// Links every output written into place under its final name. On
    /// failure removes the temporary files left (and, best effort, the
    /// outputs already placed by this call). Outputs reserved but never
    /// written are an error.
    Status commit();

    /// Removes every temporary file not yet committed. Idempotent.
    void discard() noexcept;

    /// The hidden name used for `final_path` on its way into place:
    /// ".NAME.tmp-PID" beside it.
    static std::string temp_path_for(const std::string& final_path);

private:
    struct Entry {
        std::string final_path;
        int fd = -1;              ///< the unnamed file (O_TMPFILE), else -1
        std::string named_temp;   ///< the fallback's named file, else empty
        bool written = false;
    };
    Entry* find(const std::string& final_path);
    std::vector<Entry> m_entries;
};

}  // namespace filmgrain::cli
