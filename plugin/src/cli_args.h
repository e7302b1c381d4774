// filmgrain CLI: the command line (OIIO::ArgParse) and its help text.
#pragma once

#include <array>
#include <optional>
#include <string>

#include "input_image.h"
#include "filmgrain/status.h"
#include "modifiers.h"

namespace filmgrain::cli {

/// Output pixel types accepted by -d.
enum class OutputType { float32, half16 };

/// Everything the command line asks for, checked for form but not yet for
/// consistency (see validate_render_args) nor against the files.
struct CliArgs {
    std::string input;  ///< INPUT (empty: none)
    /// Which part, view and channels of INPUT (--subimage, --view, --ch).
    InputSelection input_selection;
    bool wedge = false;  ///< --wedge: the built-in step wedge instead of INPUT
    bool chart = false;  ///< --chart: the built-in look chart instead of INPUT

    std::string colorconfig;  ///< --colorconfig FILE (empty: $OCIO, else embedded)
    std::optional<std::string> iscolorspace;  ///< --iscolorspace NAME
    std::optional<std::string> ocolorspace;  ///< --ocolorspace NAME (output=regrain only)

    bool has_filmgrain = false;  ///< --filmgrain given
    FilmgrainCommand filmgrain;

    std::string output;  ///< -o FILE.exr
    OutputModifiers output_modifiers;
    OutputType output_type = OutputType::float32;  ///< -d half|float

    std::string frames;  ///< --frames LIST (empty: not given)
    bool skip_existing = false;  ///< --skip-existing
    bool skip_missing  = false;  ///< --skip-missing
    bool dry_run       = false;  ///< --dry-run
    bool report_json   = false;  ///< --report-json

    std::string stats_path;  ///< --stats FILE.json
    std::string preview_path;  ///< --preview FILE.png

    int threads   = 0;  ///< --threads N (0: all)
    bool quiet    = false;  ///< -q / --quiet
    bool progress = false;  ///< --progress (also shown when stderr is a TTY)

    bool help        = false;
    bool version     = false;
    bool list_stocks = false;
    bool list_options = false;  ///< --list-options: the option table as JSON
    std::string print_stock;  ///< --print-stock NAME|FILE (empty: not given)
};

/// One of the files a render names, as the command line names it.
struct NamedFile {
    const char* what;  ///< "INPUT", "-o", "--stats", "--preview"
    const std::string* path;  ///< into the CliArgs; empty: not given
};

/// INPUT, -o, --stats and --preview of `a`, in that order (the order of a
/// FrameJob's files).
std::array<NamedFile, 4> named_files(const CliArgs& a);

/// Parses argv (argv[0] is the program). Errors name the option and say
/// what is wrong. Never throws.
Status parse_command_line(int argc, const char** argv, CliArgs& out);

/// Checks what a render needs: one of INPUT / --wedge / --chart, --filmgrain, -o
/// FILE.exr, file name extensions, distinct paths. Touches no file other
/// than to compare paths.
Status validate_render_args(const CliArgs& args);

/// True when argv asks for --help (or -h) anywhere: help wins over errors.
bool wants_help(int argc, const char** argv);

/// The full --help text: usage, every option, every modifier with its
/// default (printed from the default structs), the presets, the colour
/// config resolution order and the exit status.
std::string help_text();

/// The options and modifiers as one JSON document (--list-options):
/// {"options": [{"name", "aliases", "value" (the metavar, "" for a flag),
/// "modifiers" (takes :key=value), "prints_and_exits", "help"}...],
/// "modifiers": {"--filmgrain": [{"key", "value", "default", "help"}...],
/// "-o": [...]}}, in --help's order.
std::string options_json();

/// Exit status of a failed run (usage errors included).
constexpr int kExitError = 1;
/// Exit status of a run interrupted by signal N is kExitSignalBase + N.
constexpr int kExitSignalBase = 128;

}  // namespace filmgrain::cli
