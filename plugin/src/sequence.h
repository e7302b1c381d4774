// filmgrain CLI: image sequences (--frames), oiiotool style.
//
// A frame pattern is a file name with one frame-number field: `#` (four
// digits, as oiiotool), a run of several `#` or `@` (one digit each:
// `####` is four digits, as in Nuke and most pipelines; oiiotool would make
// `####` sixteen), or printf's `%0Nd`. A frame list is oiiotool's: `1001`,
// `1001-1100`, `1-10,20,30-40x2` (x: step), also decreasing and negative.
// Parsing and expansion use OpenImageIO's Filesystem::parse_pattern and
// enumerate_sequence.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "filmgrain/status.h"

namespace filmgrain::cli {

/// Most frames one command renders.
constexpr size_t kMaxSequenceFrames = 1000000;

/// A parsed frame pattern: `printf` holds the number as "%0Nd"; `frames`
/// is a frame list embedded in the pattern ("plate.1001-1100#.exr"), or
/// empty.
struct FramePattern {
    std::string printf;
    std::string frames;
};

/// True when `path` holds a frame-number field (and so is a pattern).
bool is_frame_pattern(const std::string& path);

/// Parses a frame pattern; an error names `what` (e.g. "-o") when `path`
/// holds no frame field.
Status parse_frame_pattern(const std::string& path, const std::string& what,
                           FramePattern& out);

/// The frame numbers of a frame list, in order. Errors: malformed, empty,
/// a frame repeated, more than kMaxSequenceFrames frames, a frame number
/// beyond +-kMaxFrameNumber.
Status parse_frame_list(const std::string& spec, std::vector<int>& frames);

/// The file name of `frame` in a parsed pattern.
std::string frame_path(const FramePattern& pattern, int frame);

struct CliArgs;

/// One image to render: its frame number (none: a single image, not part
/// of a sequence) and its files (empty: not asked for).
struct FrameJob {
    std::optional<int> frame;
    std::string input;  ///< empty with --wedge or --chart
    std::string output;
    std::string stats;
    std::string preview;
};

/// The images a command renders, in order: one job without a frame number,
/// or one per frame of --frames (or of a frame list in INPUT's pattern,
/// "plate.1001-1100#.exr"). Checks the sequence's form: with frames, -o,
/// --stats and --preview must be patterns (INPUT may be a still, read for
/// every frame) and frame= must not be given; without, none may be a
/// pattern.
Status plan_frames(const CliArgs& args, std::vector<FrameJob>& jobs);

}  // namespace filmgrain::cli
