#include "util/cache_file.h"

#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <sstream>
#include <system_error>

#include "util/whole_file.h"

namespace filmgrain {

uint64_t content_hash(const std::string& bytes)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (unsigned char c : bytes)
        h = (h ^ c) * 0x100000001b3ull;
    return h;
}

std::optional<std::string> read_cache_file(const std::filesystem::path& path,
                                           const std::string& header)
{
    std::ifstream in(path, std::ios::binary);
    if (!in)
        return std::nullopt;
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (bytes.size() < header.size() + sizeof(uint64_t)
        || bytes.compare(0, header.size(), header) != 0)
        return std::nullopt;
    const size_t body = bytes.size() - sizeof(uint64_t);
    uint64_t check    = 0;
    std::memcpy(&check, bytes.data() + body, sizeof check);
    if (check != content_hash(bytes.substr(0, body)))
        return std::nullopt;
    return bytes.substr(header.size(), body - header.size());
}

void write_cache_file(const std::filesystem::path& path, const std::string& header,
                      const std::string& value)
{
    std::error_code ec;
    std::filesystem::create_directories(path.parent_path(), ec);
    if (ec)
        return;
    std::string bytes    = header + value;
    const uint64_t check = content_hash(bytes);
    bytes.append(reinterpret_cast<const char*>(&check), sizeof check);
    (void)write_whole_file(path, bytes);
}

std::filesystem::path cache_file_path(const std::string& dir, const char* folder,
                                      const char* prefix, const std::string& header)
{
    std::ostringstream name;
    name << prefix << "-" << std::hex << std::hash<std::string>()(header) << ".bin";
    return std::filesystem::path(dir) / folder / name.str();
}

}  // namespace filmgrain
