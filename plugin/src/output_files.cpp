// filmgrain CLI: all-or-nothing output files (output_files.h).
#include "output_files.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <utility>

namespace filmgrain::cli {

namespace fs = std::filesystem;

namespace {

std::string directory_of(const std::string& path)
{
    const std::string dir = fs::path(path).parent_path().string();
    return dir.empty() ? std::string(".") : dir;
}

Status cannot_create(const std::string& final_path, int err)
{
    const std::string dir = fs::path(final_path).parent_path().string();
    return Status::errorf("cannot write '", final_path, "': cannot create a file in ",
                          dir.empty() ? std::string("the current directory")
                                      : "directory '" + dir + "'",
                          ": ", std::strerror(err));
}

/// An unnamed file in `dir`, or -1 with errno set. EOPNOTSUPP / EISDIR /
/// EINVAL mean the file system (or kernel) has no O_TMPFILE.
int open_unnamed(const std::string& dir)
{
#ifdef O_TMPFILE
    return ::open(dir.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
#else
    (void)dir;
    errno = EOPNOTSUPP;
    return -1;
#endif
}

bool no_tmpfile_support(int err) { return err == EOPNOTSUPP || err == EISDIR || err == EINVAL; }

}  // namespace

std::string OutputFiles::temp_path_for(const std::string& final_path)
{
    const fs::path p(final_path);
    const std::string name = "." + p.filename().string() + ".tmp-" + std::to_string(::getpid());
    return (p.parent_path() / name).string();
}

OutputFiles::~OutputFiles() { discard(); }

OutputFiles::Entry* OutputFiles::find(const std::string& final_path)
{
    for (Entry& e : m_entries)
        if (e.final_path == final_path)
            return &e;
    return nullptr;
}

Status OutputFiles::reserve(const std::string& final_path)
{
    if (find(final_path))
        return Status::errorf("internal: output '", final_path, "' reserved twice");
    // Probe: an unnamed file vanishes on close; the fallback's named probe
    // exists only between these two calls.
    int fd = open_unnamed(directory_of(final_path));
    if (fd < 0 && no_tmpfile_support(errno)) {
        const std::string probe = temp_path_for(final_path);
        fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0)
            ::unlink(probe.c_str());
    }
    if (fd < 0)
        return cannot_create(final_path, errno);
    ::close(fd);
    Entry entry;
    entry.final_path = final_path;
    m_entries.push_back(std::move(entry));
    return {};
}

Status OutputFiles::open(const std::string& final_path, std::FILE*& out)
{
    out      = nullptr;
    Entry* e = find(final_path);
    if (!e || e->fd >= 0 || !e->named_temp.empty())
        return Status::errorf("internal: output '", final_path,
                              e ? "' opened twice" : "' not reserved");
    int fd = open_unnamed(directory_of(final_path));
    if (fd >= 0) {
        e->fd = fd;
        fd    = ::dup(fd);  // the stream closes its own descriptor
    } else if (no_tmpfile_support(errno)) {
        e->named_temp = temp_path_for(final_path);
        fd = ::open(e->named_temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
        if (fd < 0)
            e->named_temp.clear();
    }
    if (fd < 0)
        return cannot_create(final_path, errno);
    out = ::fdopen(fd, "wb");
    if (!out) {
        const int err = errno;
        ::close(fd);
        return cannot_create(final_path, err);
    }
    e->written = true;
    return {};
}

Status OutputFiles::write(const std::string& final_path, const std::string& bytes)
{
    std::FILE* f = nullptr;
    if (Status s = open(final_path, f); !s)
        return s;
    errno            = 0;
    const bool wrote = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
    const int err    = errno;
    if (std::fclose(f) != 0 || !wrote)
        return Status::errorf("cannot write '", final_path, "'",
                              err ? std::string(": ") + std::strerror(err) : std::string());
    return {};
}

Status OutputFiles::commit()
{
    for (const Entry& e : m_entries)
        if (!e.written)
            return Status::errorf("internal: output '", e.final_path, "' was never written");
    size_t done = 0;
    for (; done < m_entries.size(); ++done) {
        Entry& e = m_entries[done];
        Status s;
        if (e.fd >= 0) {
            // Give the unnamed file its hidden name (linkat through /proc
            // needs no privilege, unlike AT_EMPTY_PATH), then rename it.
            const std::string temp = temp_path_for(e.final_path);
            const std::string proc = "/proc/self/fd/" + std::to_string(e.fd);
            ::unlink(temp.c_str());  // a stale one from a killed run of this PID
            if (::linkat(AT_FDCWD, proc.c_str(), AT_FDCWD, temp.c_str(), AT_SYMLINK_FOLLOW) != 0)
                s = Status::errorf("cannot create '", temp, "' for '", e.final_path,
                                   "': ", std::strerror(errno));
            else
                e.named_temp = temp;
            ::close(e.fd);
            e.fd = -1;
        }
        if (s && std::rename(e.named_temp.c_str(), e.final_path.c_str()) != 0)
            s = Status::errorf("cannot rename '", e.named_temp, "' to '", e.final_path,
                               "': ", std::strerror(errno));
        if (!s) {
            // All or nothing, best effort: take back what this call placed.
            for (size_t i = 0; i < done; ++i)
                std::remove(m_entries[i].final_path.c_str());
            m_entries.erase(m_entries.begin(), m_entries.begin() + static_cast<long>(done));
            discard();
            return s;
        }
        e.named_temp.clear();
    }
    m_entries.clear();
    return {};
}

void OutputFiles::discard() noexcept
{
    for (Entry& e : m_entries) {
        if (e.fd >= 0)
            ::close(e.fd);
        if (!e.named_temp.empty())
            std::remove(e.named_temp.c_str());
    }
    m_entries.clear();
}

}  // namespace filmgrain::cli
