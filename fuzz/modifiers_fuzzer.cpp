// libFuzzer target: the CLI's modifier parsers (plugin/src/modifiers.h),
// documented as total: no exception, no undefined behaviour on any bytes.
// The input is one command-line word, tried as given and behind
// "--filmgrain:" and "-o:". Contract checked on every input:
//  - failure: a non-empty message, `out` unchanged;
//  - success: the scene validates, sizes and tile are within their
//    documented ranges, and the ROI is well formed.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "modifiers.h"

namespace {

[[noreturn]] void fail(const char* what, const std::string& arg)
{
    std::fprintf(stderr, "modifiers_fuzzer: %s (argument of %zu bytes)\n", what, arg.size());
    std::abort();
}

void check_filmgrain(const std::string& arg)
{
    using filmgrain::cli::FilmgrainCommand;
    FilmgrainCommand cmd;
    cmd.stock         = "sentinel";
    cmd.scene.seed    = 12345;
    cmd.tile_size_px  = 7;
    const filmgrain::Status s = filmgrain::cli::parse_filmgrain_modifiers(arg, cmd);
    if (!s) {
        if (s.message().empty())
            fail("empty error message", arg);
        if (cmd.stock != "sentinel" || cmd.scene.seed != 12345 || cmd.tile_size_px != 7)
            fail("a failed parse changed its output", arg);
        return;
    }
    if (!cmd.scene.validate())
        fail("accepted a scene that does not validate", arg);
    if (cmd.tile_size_px < 1 || cmd.tile_size_px > 4096)
        fail("accepted a tile outside [1, 4096]", arg);
    if (cmd.scan_width < 0 || cmd.scan_height < 0 || cmd.scan_width > INT32_MAX
        || cmd.scan_height > INT32_MAX)
        fail("accepted a scan outside [0, 2^31 - 1]", arg);
    if (cmd.has_roi
        && (cmd.roi_x < -INT32_MAX || cmd.roi_y < -INT32_MAX  // negative: overscan
            || cmd.roi_width < 1 || cmd.roi_height < 1
            || cmd.roi_x + cmd.roi_width > INT32_MAX || cmd.roi_y + cmd.roi_height > INT32_MAX))
        fail("accepted a malformed roi", arg);
    if (cmd.stock.empty())
        fail("accepted an empty stock", arg);
}

void check_output(const std::string& arg)
{
    filmgrain::cli::OutputModifiers out;
    out.compression = "sentinel";
    const filmgrain::Status s = filmgrain::cli::parse_output_modifiers(arg, out);
    if (!s) {
        if (s.message().empty() || out.compression != "sentinel")
            fail("-o: failed parse without message or with its output changed", arg);
        return;
    }
    bool known = false;
    for (const std::string& c : filmgrain::cli::exr_compressions())
        known |= c == out.compression;
    if (!known && out.compression != "sentinel")
        fail("-o: accepted an unknown compression", arg);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    const std::string word(reinterpret_cast<const char*>(data), size);
    check_filmgrain(word);
    check_filmgrain("--filmgrain:" + word);
    check_output(word);
    check_output("-o:" + word);
    return 0;
}
