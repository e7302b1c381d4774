#include "util/whole_file.h"

#include <fstream>
#include <functional>
#include <sstream>
#include <thread>

#include <unistd.h>

namespace filmgrain {

Status write_whole_file(const std::filesystem::path& path, const std::string& bytes)
{
    std::ostringstream tmp_name;
    tmp_name << path.filename().string() << ".tmp-" << ::getpid() << "-"
             << std::hash<std::thread::id>()(std::this_thread::get_id());
    const std::filesystem::path tmp = path.parent_path() / tmp_name.str();
    std::error_code ec;
    {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        out << bytes;
        out.close();
        if (!out) {
            std::filesystem::remove(tmp, ec);
            return Status::errorf("cannot write ", path.string());
        }
    }
    std::filesystem::rename(tmp, path, ec);
    if (ec) {
        const std::string why = ec.message();
        std::filesystem::remove(tmp, ec);
        return Status::errorf("cannot write ", path.string(), ": ", why);
    }
    return {};
}

}  // namespace filmgrain
