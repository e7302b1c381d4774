// filmgrain CLI: image sequences (sequence.h).
#include "sequence.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/strutil.h>

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <set>

#include "cli_args.h"
#include "filmgrain/render.h"

namespace filmgrain::cli {

namespace {

/// Runs of two or more '#' become as many '@' (one digit each), so that
/// "####" means four digits; a lone '#' stays oiiotool's four digits.
std::string normalise_hashes(const std::string& path)
{
    std::string out = path;
    for (size_t i = 0; i < out.size();) {
        if (out[i] != '#') {
            ++i;
            continue;
        }
        size_t j = i;
        while (j < out.size() && out[j] == '#')
            ++j;
        if (j - i > 1)
            std::fill(out.begin() + static_cast<long>(i), out.begin() + static_cast<long>(j), '@');
        i = j;
    }
    return out;
}

bool parse_int(std::string_view s, int64_t& out)
{
    if (s.empty())
        return false;
    const auto r = std::from_chars(s.data(), s.data() + s.size(), out, 10);
    return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

/// Frames in one comma-separated part "A", "A-B" or "A-BxS", when it has
/// that shape (else -1: OIIO decides). Guards against a list such as
/// "1-1000000000" allocating billions of frames.
int64_t part_frame_count(std::string_view part)
{
    const size_t dash = part.find('-', 1);  // a leading '-' is a sign
    int64_t a = 0, b = 0, step = 1;
    if (dash == std::string_view::npos)
        return parse_int(part, a) ? 1 : -1;
    std::string_view rest = part.substr(dash + 1);
    const size_t x        = rest.find('x');
    if (!parse_int(part.substr(0, dash), a)
        || !parse_int(x == std::string_view::npos ? rest : rest.substr(0, x), b))
        return -1;
    if (x != std::string_view::npos && (!parse_int(rest.substr(x + 1), step) || step == 0))
        return -1;
    const int64_t span = a <= b ? b - a : a - b;
    return span / (step < 0 ? -step : step) + 1;
}

}  // namespace

bool is_frame_pattern(const std::string& path)
{
    std::string printf_form, frames;
    return OIIO::Filesystem::parse_pattern(normalise_hashes(path).c_str(), 0, printf_form,
                                           frames);
}

Status parse_frame_pattern(const std::string& path, const std::string& what, FramePattern& out)
{
    out = FramePattern();
    if (!OIIO::Filesystem::parse_pattern(normalise_hashes(path).c_str(), 0, out.printf,
                                         out.frames))
        return Status::errorf(what, " '", path,
                              "' has no frame-number field: with --frames it must be a "
                              "pattern such as name.####.exr, name.#.exr, name.@@@@.exr or "
                              "name.%04d.exr");
    return {};
}

Status parse_frame_list(const std::string& spec, std::vector<int>& frames)
{
    frames.clear();
    const auto malformed = [&spec](const std::string& why) {
        return Status::errorf("--frames ", spec, ": ", why,
                              " (a frame list is e.g. 1001, 1001-1100 or 1-10,20,30-40x2)");
    };
    if (spec.empty())
        return malformed("empty frame list");
    uint64_t total = 0;
    for (const auto& part : OIIO::Strutil::splitsv(spec, ",")) {
        const int64_t n = part_frame_count(part);
        if (n > 0)
            total += static_cast<uint64_t>(n);
        if (total > kMaxSequenceFrames)
            return malformed("more than " + std::to_string(kMaxSequenceFrames) + " frames");
    }
    for (char c : spec)
        if (!((c >= '0' && c <= '9') || c == '-' || c == ',' || c == 'x'))
            return malformed(std::string("unexpected character '") + c + "'");
    for (size_t i = 0; i < spec.size();) {  // no number OIIO's int cannot hold
        size_t j = i;
        while (j < spec.size() && spec[j] >= '0' && spec[j] <= '9')
            ++j;
        int64_t v = 0;
        if (j > i && (j - i > 10 || !parse_int(std::string_view(spec).substr(i, j - i), v)
                      || v > kMaxFrameNumber))
            return malformed("frame " + spec.substr(i, j - i) + " is beyond +-"
                             + std::to_string(kMaxFrameNumber));
        i = j > i ? j : i + 1;
    }
    std::vector<int> numbers;
    if (!OIIO::Filesystem::enumerate_sequence(spec, numbers) || numbers.empty())
        return malformed("not a frame list");
    if (numbers.size() > kMaxSequenceFrames)
        return malformed("more than " + std::to_string(kMaxSequenceFrames) + " frames");
    std::set<int> seen;
    for (int f : numbers) {
        if (f < -kMaxFrameNumber || f > kMaxFrameNumber)
            return malformed("frame " + std::to_string(f) + " is beyond +-"
                             + std::to_string(kMaxFrameNumber));
        if (!seen.insert(f).second)
            return malformed("frame " + std::to_string(f) + " is listed twice");
    }
    frames = std::move(numbers);
    return {};
}

std::string frame_path(const FramePattern& pattern, int frame)
{
    std::vector<std::string> names;
    OIIO::Filesystem::enumerate_file_sequence(pattern.printf, { frame }, names);
    return names.empty() ? std::string() : names.front();
}

Status plan_frames(const CliArgs& a, std::vector<FrameJob>& jobs)
{
    jobs.clear();
    const std::array<NamedFile, 4> files = named_files(a);
    std::string list = a.frames;
    FramePattern input_pattern;
    if (!a.input.empty() && is_frame_pattern(a.input)) {
        if (Status s = parse_frame_pattern(a.input, "INPUT", input_pattern); !s)
            return s;
        if (!input_pattern.frames.empty()) {
            if (!list.empty() && list != input_pattern.frames)
                return Status::errorf("--frames ", list, " and INPUT '", a.input,
                                      "' name different frames: give the list once");
            list = input_pattern.frames;
        }
    }
    if (list.empty()) {
        for (const NamedFile& f : files)
            if (!f.path->empty() && is_frame_pattern(*f.path))
                return Status::errorf(f.what, " '", *f.path,
                                      "' is a frame pattern: give the frames with --frames "
                                      "LIST (e.g. --frames 1001-1100)");
        if (a.skip_missing)
            return Status::error("--skip-missing applies to sequences (--frames)");
        jobs.push_back(FrameJob { std::nullopt, a.input, a.output, a.stats_path, a.preview_path });
        return {};
    }
    if (a.filmgrain.scene.frame)
        return Status::errorf("--filmgrain:frame=", *a.filmgrain.scene.frame,
                              " with --frames: each frame's number comes from --frames");
    std::vector<int> frames;
    if (Status s = parse_frame_list(list, frames); !s)
        return s;
    // An INPUT without a frame field is a still: the same image every frame
    // (each with its own grain). Outputs must be patterns.
    const bool still_input = !a.input.empty() && !is_frame_pattern(a.input);
    FramePattern patterns[4];
    for (size_t i = 0; i < 4; ++i)
        if (!files[i].path->empty() && !(i == 0 && still_input))
            if (Status s = parse_frame_pattern(*files[i].path, files[i].what, patterns[i]); !s)
                return s;
    for (int f : frames) {
        FrameJob job;
        job.frame = f;
        std::string* out[] = { &job.input, &job.output, &job.stats, &job.preview };
        for (size_t i = 0; i < 4; ++i)
            if (!files[i].path->empty())
                *out[i] = i == 0 && still_input ? a.input : frame_path(patterns[i], f);
        jobs.push_back(std::move(job));
    }
    return {};
}

}  // namespace filmgrain::cli
