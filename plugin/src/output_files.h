// filmgrain CLI: all-or-nothing output files.
//
// Every output (EXR, stats, preview) is first written to a temporary file in
// its own directory (".NAME.tmp-PID"), so that the final rename is atomic
// (same file system). Nothing appears under a final name until every output
// has been written; on any failure, or if the object is destroyed before
// commit(), every temporary file is removed.
#pragma once

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

    /// Reserves the temporary file for `final_path` and checks that it can
    /// be created (an unwritable or missing directory fails here, before any
    /// work). `temp_path` receives its name.
    Status reserve(const std::string& final_path, std::string& temp_path);

    /// Renames every temporary file to its final name. On failure removes
    /// the temporary files left (and, best effort, the outputs already
    /// renamed by this call).
    Status commit();

    /// Removes every temporary file not yet committed. Idempotent.
    void discard() noexcept;

    /// The temporary name used for `final_path`: ".NAME.tmp-PID" beside it.
    static std::string temp_path_for(const std::string& final_path);

private:
    struct Entry {
        std::string final_path;
        std::string temp_path;
    };
    std::vector<Entry> m_entries;
};

}  // namespace filmgrain::cli
