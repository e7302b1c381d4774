// filmgrain CLI: all-or-nothing output files (output_files.h).
#include "output_files.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

namespace filmgrain::cli {

namespace fs = std::filesystem;

std::string OutputFiles::temp_path_for(const std::string& final_path)
{
    const fs::path p(final_path);
    const std::string name = "." + p.filename().string() + ".tmp-" + std::to_string(::getpid());
    return (p.parent_path() / name).string();
}

OutputFiles::~OutputFiles() { discard(); }

Status OutputFiles::reserve(const std::string& final_path, std::string& temp_path)
{
    temp_path = temp_path_for(final_path);
    const int fd = ::open(temp_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd < 0) {
        const int err = errno;
        const std::string dir = fs::path(final_path).parent_path().string();
        return Status::errorf("cannot write '", final_path, "': cannot create a file in ",
                              dir.empty() ? std::string("the current directory")
                                          : "directory '" + dir + "'",
                              ": ", std::strerror(err));
    }
    ::close(fd);
    m_entries.push_back({ final_path, temp_path });
    return {};
}

Status OutputFiles::commit()
{
    size_t done = 0;
    for (; done < m_entries.size(); ++done) {
        const Entry& e = m_entries[done];
        if (std::rename(e.temp_path.c_str(), e.final_path.c_str()) != 0) {
            const int err = errno;
            Status s = Status::errorf("cannot rename '", e.temp_path, "' to '", e.final_path,
                                      "': ", std::strerror(err));
            // All or nothing, best effort: take back what this call renamed.
            for (size_t i = 0; i < done; ++i)
                std::remove(m_entries[i].final_path.c_str());
            m_entries.erase(m_entries.begin(), m_entries.begin() + static_cast<long>(done));
            discard();
            return s;
        }
    }
    m_entries.clear();
    return {};
}

void OutputFiles::discard() noexcept
{
    for (const Entry& e : m_entries)
        std::remove(e.temp_path.c_str());
    m_entries.clear();
}

}  // namespace filmgrain::cli
