// filmgrain CLI: command-line parsing and help (cli_args.h).
//
// One table declares every option with its value names, help and handler;
// OIIO::ArgParse is configured from it and --help is printed from it, so
// an option cannot be parsed without being documented.
#include "cli_args.h"

#include <OpenImageIO/argparse.h>

#include <nlohmann/json.hpp>

#include <charconv>
#include <cstring>
#include <exception>
#include <filesystem>
#include <functional>
#include <sstream>
#include <system_error>

#include "filmgrain/chart.h"
#include "filmgrain/ocio.h"
#include "filmgrain/version.h"
#include "filmgrain/wedge.h"
#include "util/parse_number.h"

namespace filmgrain::cli {

namespace {

namespace fs = std::filesystem;

/// Handles one occurrence of an option: `flag` is the command-line word as
/// given (with any :modifiers), `value` its parameter (null for flags).
/// Returns an error to stop parsing.
using Handler = std::function<Status(CliArgs&, const std::string& flag, const char* value)>;

struct OptionSpec {
    const char* flag;  ///< "-o", "--threads"
    const char* alias;  ///< another spelling ("--quiet" for -q), or null
    const char* metavar;  ///< value name(s), "" for a flag
    std::string help;
    Handler handle;
    bool takes_modifiers = false;  ///< --filmgrain and -o accept :key=value
    bool prints_and_exits = false;  ///< --version, --list-stocks and the like
};

/// The option name without its :modifiers.
std::string base_flag(const std::string& word)
{
    return word.substr(0, word.find(':'));
}

Status once(bool already, const char* flag)
{
    if (already)
        return Status::errorf(flag, " may be given at most once");
    return {};
}

/// An option that names something: given at most once (`already`: it was
/// given before), its value stored in `out` even on error, and an empty
/// value refused as "FLAG: empty WHAT".
Status set_once(bool already, const char* flag, const char* value, const char* what,
                std::string& out)
{
    Status s = once(already, flag);
    out      = value;
    if (s && out.empty())
        s = Status::errorf(flag, ": empty ", what);
    return s;
}

Status parse_threads(const char* value, int& out)
{
    uint64_t n = 0;
    std::string why;
    if (!parse_count(value, 4096, n, why))
        return Status::errorf("--threads ", value,
                              ": expected a whole number of threads in [0, 4096] (0: all)");
    out = static_cast<int>(n);
    return {};
}

std::string format_stops(double stops)
{
    std::ostringstream out;
    out << std::showpos << stops;
    return out.str();
}

/// --wedge's help, from the WedgeSpec defaults.
std::string wedge_help()
{
    const WedgeSpec w;
    std::ostringstream out;
    out << "Render the built-in grey step wedge instead of INPUT: " << w.width_px() << "x"
        << w.height_px << " scene-linear, " << w.steps << " steps of " << w.stops_per_step
        << " stop from " << format_stops(w.step_stops(0)) << " to "
        << format_stops(w.step_stops(w.steps - 1)) << " stops around 0.18, on a test strip "
        << w.strip_width_mm << " mm wide (width_mm= overrides it)";
    return out.str();
}

/// --chart's help, from the ChartSpec defaults.
std::string chart_help()
{
    const ChartSpec c;
    std::ostringstream out;
    out << "Render the built-in look chart instead of INPUT: " << c.width_px << "x" << c.height_px
        << " scene-linear RGB on a ground at " << format_stops(c.ground_stops)
        << " stops around 0.18: a point light of radius " << c.point_radius_px << " px at "
        << format_stops(c.point_stops) << " stops and a dimmer one at "
        << format_stops(c.dim_point_stops) << " (halation), a sharp-edged rectangle at "
        << format_stops(c.rect_stops) << " (adjacency effect) and the " << kChartPatches
        << "-patch ColorChecker (colour), on a test strip " << c.strip_width_mm
        << " mm wide (width_mm= overrides it)";
    return out.str();
}

/// The handler of an option that names something (set_once): `field`
/// gives the string it sets.
Handler name_once(const char* flag, const char* what, std::string& (*field)(CliArgs&))
{
    return [flag, what, field](CliArgs& a, const std::string&, const char* v) {
        std::string& out = field(a);
        return set_once(!out.empty(), flag, v, what, out);
    };
}

/// The handler of a switch given at most once.
Handler switch_once(const char* flag, bool CliArgs::*member)
{
    return [flag, member](CliArgs& a, const std::string&, const char*) {
        Status s  = once(a.*member, flag);
        a.*member = true;
        return s;
    };
}

/// The handler of --iscolorspace and --ocolorspace: a colour space name
/// given at most once (set even when refused, as set_once).
Handler colour_space_once(const char* flag, std::optional<std::string> CliArgs::*name)
{
    return [flag, name](CliArgs& a, const std::string&, const char* v) {
        const bool given = (a.*name).has_value();
        return set_once(given, flag, v, "colour space name", (a.*name).emplace());
    };
}

/// The handler of a switch: sets it (given twice, it stays set).
Handler switch_on(bool CliArgs::*member)
{
    return [member](CliArgs& a, const std::string&, const char*) {
        a.*member = true;
        return Status();
    };
}

const std::vector<OptionSpec>& option_table()
{
    static const std::vector<OptionSpec> table = {
        { "--wedge", nullptr, "", wedge_help(),
          switch_once("--wedge", &CliArgs::wedge) },
        { "--chart", nullptr, "", chart_help(),
          switch_once("--chart", &CliArgs::chart) },
        { "--colorconfig", nullptr, "FILE",
          "OCIO config for the input conversion, the regrain output and the preview (default: "
          "$OCIO, else the embedded config)",
          name_once("--colorconfig", "file name",
                    [](CliArgs& a) -> std::string& { return a.colorconfig; }) },
        { "--iscolorspace", nullptr, "NAME",
          "Colour space of INPUT (default: the file's oiio:ColorSpace when the config knows "
          "it, else an EXR's chromaticities (its primaries and white), else scene_linear)",
          colour_space_once("--iscolorspace", &CliArgs::iscolorspace) },
        { "--subimage", nullptr, "N|NAME",
          "Part of a multi-part INPUT to read, by index (from 0) or name (as oiiotool's "
          "--subimage; default: the first part with the channels)",
          name_once("--subimage", "part name",
                    [](CliArgs& a) -> std::string& { return a.input_selection.subimage; }) },
        { "--view", nullptr, "NAME",
          "View of a multi-view INPUT to read (default: the file's default view, the first it "
          "lists)",
          name_once("--view", "view name",
                    [](CliArgs& a) -> std::string& { return a.input_selection.view; }) },
        { "--ch", nullptr, "R,G,B|Y",
          "Channels of INPUT to read as red, green and blue, or one as grey, by name (as "
          "oiiotool's --ch; default: R, G, B, else Y, of the view)",
          [](CliArgs& a, const std::string&, const char* v) {
              if (Status s = once(!a.input_selection.channels.empty(), "--ch"); !s)
                  return s;
              return parse_channel_list(v, a.input_selection.channels);
          } },
        { "--ocolorspace", nullptr, "NAME",
          "Colour space of the output=regrain positive (default: the config's scene_linear); "
          "only with output=regrain",
          colour_space_once("--ocolorspace", &CliArgs::ocolorspace) },
        { "--filmgrain", nullptr, "",
          "Simulate the film: expose, develop and scan a negative (modifiers below)",
          [](CliArgs& a, const std::string& flag, const char*) {
              if (Status s = once(a.has_filmgrain, "--filmgrain"); !s)
                  return s;
              a.has_filmgrain = true;
              return parse_filmgrain_modifiers(flag, a.filmgrain);
          },
          true },
        { "-d", nullptr, "half|float",
          "Output pixel type: half or float (default: float)",
          [](CliArgs& a, const std::string&, const char* v) {
              const std::string t = v;
              if (t == "float")
                  a.output_type = OutputType::float32;
              else if (t == "half")
                  a.output_type = OutputType::half16;
              else
                  return Status::errorf("-d ", t, ": unknown output type; expected half or float");
              return Status();
          } },
        { "-o", nullptr, "FILE.exr",
          "Output OpenEXR file (required to render; written atomically: created unnamed in "
          "its directory and linked into place when complete). Modifiers go on the option, "
          "as oiiotool's: -o:compression=NAME FILE.exr",
          [](CliArgs& a, const std::string& flag, const char* v) {
              if (Status s = once(!a.output.empty(), "-o"); !s)
                  return s;
              a.output = v;
              if (a.output.empty())
                  return Status::error("-o: empty file name");
              return parse_output_modifiers(flag, a.output_modifiers);
          },
          true },
        { "--frames", nullptr, "LIST",
          "Render a sequence: frame list such as 1001-1100 or 1-10,20,30-40x2 (as oiiotool). "
          "INPUT, -o, --stats and --preview are then frame patterns (name.####.exr, "
          "name.#.exr, name.@@@.exr, name.%04d.exr); frame N's grain is frame=N's (see "
          "Sequences below). Default: none (one image)",
          name_once("--frames", "frame list",
                    [](CliArgs& a) -> std::string& { return a.frames; }) },
        { "--skip-existing", nullptr, "",
          "Sequences: skip a frame whose outputs exist and were made with the same settings "
          "(filmgrain:settings_hash); re-render the others (resuming a stopped sequence). "
          "Default: off (every frame is rendered)",
          switch_on(&CliArgs::skip_existing) },
        { "--skip-missing", nullptr, "",
          "Sequences: a missing input frame is skipped with a warning and counted, instead of "
          "an error. Default: off (an error naming the frame)",
          switch_on(&CliArgs::skip_missing) },
        { "--dry-run", nullptr, "",
          "Render nothing: print on stdout, one JSON object per line, each image the command "
          "would render (frame, input, output, stats, preview, input_exists, error: what the "
          "render would refuse from the input's header, else null; settings_hash, up_to_date "
          "as --skip-existing judges it) and exit. For scripts and farms",
          switch_on(&CliArgs::dry_run) },
        { "--report-json", nullptr, "",
          "Print on stdout, one JSON object per line, what became of each image as it ends "
          "(frame: null for one image; output; outcome: rendered, up_to_date or missing_input; "
          "seconds). For scripts and farms. Default: off",
          switch_on(&CliArgs::report_json) },
        { "--stats", nullptr, "FILE.json",
          "Also write render statistics as JSON (timings, grain counts, input pixels)",
          name_once("--stats", "file name",
                    [](CliArgs& a) -> std::string& { return a.stats_path; }) },
        { "--preview", nullptr, "FILE.png",
          "Also write an 8-bit sRGB PNG positive for viewing (see Preview below)",
          name_once("--preview", "file name",
                    [](CliArgs& a) -> std::string& { return a.preview_path; }) },
        { "--threads", nullptr, "N",
          "Worker threads (default: 0 = all hardware threads)",
          [](CliArgs& a, const std::string&, const char* v) { return parse_threads(v, a.threads); } },
        { "--progress", nullptr, "",
          "Show progress on stderr even when it is not a terminal (default: only on a terminal)",
          switch_on(&CliArgs::progress) },
        { "-q", "--quiet", "", "Quiet: print nothing but errors",
          switch_on(&CliArgs::quiet) },
        { "--list-stocks", nullptr, "", "List the built-in stock presets and exit",
          switch_on(&CliArgs::list_stocks),
          false, true },
        { "--list-options", nullptr, "",
          "Print every option and modifier as JSON (name, value, default, help) and exit: "
          "what filmgrain-farm and studio tools read instead of parsing this help",
          switch_on(&CliArgs::list_options),
          false, true },
        { "--print-stock", nullptr, "NAME|FILE",
          "Print a stock (preset or file) as complete JSON, every key resolved, and exit",
          name_once("--print-stock", "stock name",
                    [](CliArgs& a) -> std::string& { return a.print_stock; }),
          false, true },
        { "--version", nullptr, "", "Print the version and exit",
          switch_on(&CliArgs::version),
          false, true },
        { "--help", "-h", "", "Print this help and exit",
          switch_on(&CliArgs::help),
          false, true },
    };
    return table;
}

Status parse_impl(int argc, const char** argv, CliArgs& out)
{
    CliArgs args;
    Status error;
    OIIO::ArgParse ap;
    ap.add_help(false).exit_on_error(false);
    ap.arg("filename").hidden().action([&](OIIO::cspan<const char*> a) {
        if (!error)
            return;
        if (!args.input.empty())
            error = Status::errorf("more than one INPUT ('", args.input, "' and '", a[0],
                                   "'): filmgrain reads one image");
        else if (a[0][0] == '\0')
            error = Status::error("empty INPUT file name");
        else
            args.input = a[0];
    });
    for (const OptionSpec& spec : option_table()) {
        const OptionSpec* sp = &spec;  // the table is static
        for (const char* name : { spec.flag, spec.alias }) {
            if (!name)
                continue;
            auto& arg = ap.arg(name).help(spec.help.c_str());
            if (*spec.metavar)
                arg.metavar(spec.metavar);
            arg.action([&args, &error, sp, name](OIIO::cspan<const char*> a) {
                if (!error)
                    return;
                const std::string word = a[0];
                if (!sp->takes_modifiers && word != base_flag(word)) {
                    error = Status::errorf(name, " takes no :modifiers (got '", word, "')");
                    return;
                }
                error = sp->handle(args, word, a.size() > 1 ? a[1] : nullptr);
            });
        }
    }
    if (ap.parse_args(argc, argv) < 0 || ap.has_error()) {
        std::string msg = ap.geterror();
        if (msg.empty())
            msg = "cannot parse the command line";
        return Status::errorf(msg, " (see filmgrain --help)");
    }
    if (!error)
        return error;
    out = std::move(args);
    return {};
}

std::string lowercase_extension(const std::string& path)
{
    std::string ext = fs::path(path).extension().string();
    for (char& c : ext)
        if (c >= 'A' && c <= 'Z')
            c = static_cast<char>(c - 'A' + 'a');
    return ext;
}

/// True when a and b name the same file (existing: same inode; else the
/// same normalised absolute path).
bool same_file(const std::string& a, const std::string& b)
{
    std::error_code ec;
    if (fs::equivalent(a, b, ec) && !ec)
        return true;
    const fs::path ca = fs::weakly_canonical(fs::absolute(a, ec), ec);
    if (ec)
        return false;
    const fs::path cb = fs::weakly_canonical(fs::absolute(b, ec), ec);
    if (ec)
        return false;
    return ca == cb;
}

void append_wrapped(std::ostringstream& out, const std::string& lead, const std::string& text,
                    size_t width = 78)
{
    // Words wrapped after `lead`, continuation lines indented like it.
    const size_t nl = lead.rfind('\n');
    const std::string indent(nl == std::string::npos ? lead.size() : lead.size() - nl - 1, ' ');
    std::string line = lead;
    std::istringstream words(text);
    std::string word;
    bool first = true;
    while (words >> word) {
        const size_t line_length = line.size() - (line.rfind('\n') + 1);
        if (!first && line_length + 1 + word.size() > width) {
            out << line << "\n";
            line  = indent + word;
            first = false;
            continue;
        }
        line += (first ? "" : " ") + word;
        first = false;
    }
    out << line << "\n";
}

std::string pad(std::string s, size_t width)
{
    if (s.size() + 2 > width)
        return s + "\n" + std::string(width, ' ');
    s.resize(width, ' ');
    return s;
}

}  // namespace

Status parse_command_line(int argc, const char** argv, CliArgs& out)
{
    try {
        return parse_impl(argc, argv, out);
    } catch (const std::exception& e) {
        return Status::errorf("cannot parse the command line: ", e.what());
    }
}

std::string options_json()
{
    using Json = nlohmann::ordered_json;
    Json options = Json::array();
    for (const OptionSpec& spec : option_table())
        options.push_back({ { "name", spec.flag },
                            { "aliases", spec.alias ? Json::array({ spec.alias }) : Json::array() },
                            { "value", spec.metavar },
                            { "modifiers", spec.takes_modifiers },
                            { "prints_and_exits", spec.prints_and_exits },
                            { "help", spec.help } });
    Json filmgrain = Json::array();
    for (const ModifierDoc& m : filmgrain_modifier_docs())
        filmgrain.push_back({ { "key", m.key },
                              { "value", m.form },
                              { "default", m.default_text },
                              { "help", m.help } });
    std::string comps;
    for (const auto& c : exr_compressions())
        comps += (comps.empty() ? "" : "|") + c;
    const Json output = Json::array({ { { "key", "compression" },
                                        { "value", comps },
                                        { "default", OutputModifiers().compression },
                                        { "help", "OpenEXR compression" } } });
    Json renamed = Json::object();
    for (const RenamedModifier& r : renamed_modifiers())
        renamed[r.old_key] = r.key;
    const Json doc = { { "options", options },
                       { "modifiers", { { "--filmgrain", filmgrain }, { "-o", output } } },
                       { "renamed_modifiers", { { "--filmgrain", renamed } } } };
    return doc.dump(2) + "\n";
}

bool wants_help(int argc, const char** argv)
{
    for (int i = 1; i < argc; ++i)
        if (!std::strcmp(argv[i], "--help") || !std::strcmp(argv[i], "-h"))
            return true;
    return false;
}

Status validate_render_args(const CliArgs& a)
{
    if (a.input.empty() && !a.wedge && !a.chart)
        return Status::error("no INPUT image (or --wedge or --chart) given (see filmgrain --help)");
    if (!a.input.empty() && a.wedge)
        return Status::errorf("both INPUT '", a.input,
                              "' and --wedge given: render one or the other");
    if (!a.input.empty() && a.chart)
        return Status::errorf("both INPUT '", a.input,
                              "' and --chart given: render one or the other");
    if (a.wedge && a.chart)
        return Status::error("both --wedge and --chart given: render one or the other");
    if (a.wedge && a.iscolorspace)
        return Status::error("--iscolorspace applies to INPUT; the --wedge is scene-linear");
    if (a.chart && a.iscolorspace)
        return Status::error("--iscolorspace applies to INPUT; the --chart is scene-linear");
    const InputSelection& sel = a.input_selection;
    if ((a.wedge || a.chart)
        && (!sel.subimage.empty() || !sel.view.empty() || !sel.channels.empty()))
        return Status::errorf("--subimage, --view and --ch choose what to read of INPUT; the ",
                              a.wedge ? "--wedge" : "--chart", " has one part, one view and ",
                              "its own channels");
    if (!a.has_filmgrain)
        return Status::error("no --filmgrain command given: nothing to do (--filmgrain alone "
                             "renders with the defaults)");
    if (a.ocolorspace && a.filmgrain.output != OutputKind::regrain)
        return Status::errorf("--ocolorspace ", *a.ocolorspace, " applies to output=regrain only "
                              "(the output is ", output_kind_name(a.filmgrain.output),
                              ": densities and ADX code values have no colour space to choose)");
    if (a.filmgrain.timing != AdxTiming::off && a.filmgrain.output != OutputKind::adx10
        && a.filmgrain.output != OutputKind::adx16)
        return Status::errorf("timing=", name_of(a.filmgrain.timing),
                              " applies to output=adx10 and adx16 only (the output is ",
                              output_kind_name(a.filmgrain.output),
                              "; --preview is always timed on grey)");
    if (a.output.empty())
        return Status::error("no output given: -o FILE.exr is required");
    if (a.dry_run && a.report_json)
        return Status::error("--report-json reports what each render became; --dry-run renders "
                             "nothing and prints its own JSON lines: give one or the other");
    // oiiotool's modifiers go on the option: -o:compression=zip out.exr.
    const size_t colon = a.output.find(':');
    if (colon != std::string::npos && lowercase_extension(a.output.substr(0, colon)) == ".exr")
        return Status::errorf("-o ", a.output, ": modifiers go on the option, before the file "
                              "name: -o", a.output.substr(colon), " ",
                              a.output.substr(0, colon));
    if (lowercase_extension(a.output) != ".exr")
        return Status::errorf("output '", a.output,
                              "' must be an OpenEXR file (.exr): it holds density data, "
                              "not a picture (use --preview FILE.png for one)");
    if (!a.preview_path.empty() && lowercase_extension(a.preview_path) != ".png")
        return Status::errorf("--preview '", a.preview_path, "' must be a .png file");

    const std::array<NamedFile, 4> paths = named_files(a);
    for (size_t i = 0; i < paths.size(); ++i)
        for (size_t j = i + 1; j < paths.size(); ++j)
            if (!paths[i].path->empty() && !paths[j].path->empty()
                && same_file(*paths[i].path, *paths[j].path))
                return Status::errorf(paths[i].what, " and ", paths[j].what,
                                      " name the same file '", *paths[j].path,
                                      "': refusing to overwrite it");
    return {};
}

std::array<NamedFile, 4> named_files(const CliArgs& a)
{
    return { { { "INPUT", &a.input },
               { "-o", &a.output },
               { "--stats", &a.stats_path },
               { "--preview", &a.preview_path } } };
}

std::string help_text()
{
    std::ostringstream out;
    out << "filmgrain " << version_string()
        << " -- physically based per-grain film simulation\n\n"
        << "Usage: filmgrain INPUT [--subimage N|NAME] [--view NAME] [--ch R,G,B|Y]\n"
        << "                 [--colorconfig FILE] [--iscolorspace NAME]\n"
        << "                 --filmgrain[:key=value...] [--ocolorspace NAME]\n"
        << "                 [-d half|float] -o[:compression=NAME] OUTPUT.exr\n"
        << "                 [--stats FILE.json] [--preview FILE.png] [--threads N]\n"
        << "                 [--progress] [-q]\n"
        << "       filmgrain PLATE.####.exr --frames LIST --filmgrain[:...] -o NEG.####.exr\n"
        << "                 [--skip-existing] [--skip-missing] [...]\n"
        << "       filmgrain --wedge --filmgrain[:key=value...] -o OUTPUT.exr [...]\n"
        << "       filmgrain --chart --filmgrain[:key=value...] -o OUTPUT.exr [...]\n"
        << "       filmgrain --list-stocks | --print-stock NAME|FILE | --list-options |\n"
        << "                 --version | --help\n\n"
        << "Options:\n";
    constexpr size_t kColumn = 28;
    append_wrapped(out, pad("    INPUT", kColumn),
                   "Input image, any format OpenImageIO reads (read as float): 1 channel "
                   "(grey) or >= 3 (R, G, B first; alpha and others ignored)");
    for (const OptionSpec& spec : option_table()) {
        std::string names = std::string("    ") + spec.flag;
        if (spec.alias)
            names += std::string(", ") + spec.alias;
        if (*spec.metavar)
            names += std::string(" ") + spec.metavar;
        append_wrapped(out, pad(names, kColumn), spec.help);
    }

    out << "\n--filmgrain modifiers (--filmgrain:key=value:key=value...):\n";
    for (const ModifierDoc& m : filmgrain_modifier_docs())
        append_wrapped(out, pad("    :" + m.key + "=" + m.form, kColumn),
                       m.help + ". Default: " + m.default_text + ".");
    std::string renamed;
    for (const RenamedModifier& r : renamed_modifiers())
        renamed += std::string(renamed.empty() ? "" : ", ") + r.old_key + " -> " + r.key;
    append_wrapped(out, "    ",
                   "Renamed (the old names are still read, with a warning): " + renamed + ".");

    out << "\n-o modifiers:\n";
    std::string comps;
    for (const auto& c : exr_compressions())
        comps += (comps.empty() ? "" : ", ") + c;
    append_wrapped(out, pad("    :compression=NAME", kColumn),
                   "OpenEXR compression: " + comps + ". Default: "
                       + OutputModifiers().compression + ".");

    out << "\nStock presets (--list-stocks describes them):\n";
    std::string presets;
    for (const auto& p : preset_names())
        presets += (presets.empty() ? "" : ", ") + p
                   + (p == default_preset_name() ? " (default)" : "");
    append_wrapped(out, "    ", presets);
    append_wrapped(out, "    ",
                   "A stock file is JSON of the same shape: filmgrain --print-stock "
                   + std::string(default_preset_name()) + " > my.json, edit, then "
                   "--filmgrain:stock=my.json.");

    out << "\nTable cache:\n";
    append_wrapped(out, "    ",
                   "The P(develop | N photons) tables that auto builds (seconds a stock) and "
                   "the pixel scale's statistics (about a CPU second a layer at 4K) are "
                   "kept on disk for the next run: in $FILMGRAIN_CACHE_DIR/tables and "
                   "/pixel-models, else under $XDG_CACHE_HOME/filmgrain, else under "
                   "~/.cache/filmgrain (FILMGRAIN_CACHE_DIR=off: none). A run reads a file "
                   "only if it was built by the same code, compiler and flags; the pixels "
                   "are the same read or built. Delete the directory to clear it. Now: "
                   + (table_cache_dir().empty() ? std::string("off") : table_cache_dir())
                   + ".");

    out << "\nColour:\n";
    append_wrapped(out, "    ",
                   "INPUT is converted to the OCIO config's scene_linear role. The config "
                   "is the first of:");
    out << "      1. --colorconfig FILE\n"
        << "      2. $OCIO, when set and not empty\n"
        << "      3. the embedded minimal config (scene-linear Rec.709 reference, ACEScg,\n"
        << "         ACES2065-1, ADX10, ADX16, sRGB, raw; display sRGB, views\n"
        << "         ACES 1.0 - SDR Video and Raw)\n";
    append_wrapped(out, "    ",
                   "INPUT's colour space is --iscolorspace NAME; else the file's "
                   "oiio:ColorSpace attribute (e.g. sRGB for PNG and JPEG, Linear for "
                   "OpenEXR), which must be known to the config; else scene_linear.");
    std::vector<std::string> spaces;
    if (ocio::list_colorspaces("", spaces)) {
        std::string list;
        for (const auto& s : spaces)
            list += (list.empty() ? "" : ", ") + s;
        append_wrapped(out, "    ", "Colour spaces and roles of the default config now: "
                                        + list + ".");
    }

    out << "\nOutput (--filmgrain:output=):\n";
    append_wrapped(out, "    ",
                   "density (default): one channel per stock layer, named after the layer: "
                   "negative density, -log10(transmittance) + the stock's base density. The full "
                   "(display) window is the whole scan, the data window the roi. Metadata: "
                   "filmgrain:output, filmgrain:quantity, filmgrain:stock (the stock as JSON), "
                   "filmgrain:stock_name, filmgrain:seed, filmgrain:frame and "
                   "filmgrain:static (sequences), filmgrain:grain_seed, "
                   "filmgrain:settings_hash, filmgrain:exposure_stops, "
                   "filmgrain:shutter_s, filmgrain:width_mm, filmgrain:engine, "
                   "filmgrain:version. Overscan (a data window beyond the display window) is "
                   "rendered too, at negative coordinates and beyond the scan.");
    append_wrapped(out, "    ",
                   "adx10, adx16: Academy Density Exchange (SMPTE ST 2065-3; MODEL.md 11), "
                   "channels R, G, B: code value = 95 + 500 CDD (adx10) or 1520 + 8000 CDD "
                   "(adx16), rounded, clamped to [0, 1023] or [0, 65535] (clamped values are "
                   "counted in a warning) and stored divided by 1023 or 65535, as OCIO's ADX10 / "
                   "ADX16 colour spaces (ACES configs, and the embedded one) read them to bring "
                   "the scan to ACES2065-1. CDD = k (APD - APD D-min), k = (1, 0.92, 0.95) "
                   "(S-2008-002 eq. 1): APD, the Academy Printing Density, is the stock's map "
                   "of its Status M layer densities (its key printing_density: APD = M StM + "
                   "o, S-2008-002 Annex C, published per stock; vision3-500t, no-remjet: "
                   "5219's, vision3-250d: 5207's); a stock without one reads APD = Status M. "
                   "D-min is each layer's expected density at zero exposure (base + fog, from "
                   "the model). R, G, B are the layers named R, G and B; a one-layer stock "
                   "gives R = G = B (its gains still apply, as an ADX scanner's would). "
                   "timing=grey adds per-channel printer lights that put the stock's own 18% "
                   "grey card (its expected densities at exposure offset 0) on CDD 0.70 "
                   "(ADX16 7120, ACES 0.18). Metadata: filmgrain:colorspace (and "
                   "oiio:ColorSpace in memory) ADX10 or ADX16, filmgrain:printing_density "
                   "(annex_c, or status_m (no map)), filmgrain:adx_dmin (Status M), "
                   "filmgrain:apd_dmin, filmgrain:adx_gains, filmgrain:adx_timing (off, or "
                   "the CDD added per channel).");
    append_wrapped(out, "    ",
                   "regrain: a scene-linear positive whose local mean is the input and whose "
                   "fluctuation is the film's grain, for comp to add to a clean element. Each "
                   "layer's density is mapped back through the inverse of the layer's expected "
                   "characteristic curve (the model's own mean curve at this shutter and "
                   "exposure), linearised at the input's expected transmittance, which keeps "
                   "the mean exactly (the plain inverse is biased by the grain: Jensen); the "
                   "layer exposures go back to RGB through the inverse of the stock's 3x3 "
                   "sensitivity matrix (a one-layer stock gives grey), then from scene_linear "
                   "to --ocolorspace. Needs the scan at the input's size (no scan=) and a one- "
                   "or three-layer stock whose populations have rate_area_exponent 0. Where the "
                   "curve flattens (toe, shoulder) the grain is limited to what a local gamma "
                   "of a tenth of the curve's steepest gives. Channels R, G, B; "
                   "filmgrain:colorspace names the colour space.");
    out << "\nPreview:\n";
    append_wrapped(out, "    ",
                   "The negative as a timed print through OCIO: density -> ADX16 as "
                   "output=adx16:timing=grey (unrounded; the stock's 18% grey lands on ACES "
                   "0.18 in every channel; a one-layer stock with gains 1, so silver stays "
                   "neutral) -> the config's ADX16 colour space (ADX10 without one) -> the "
                   "config's default display and its default view (embedded config: sRGB, "
                   "ACES 1.0 - SDR Video), 8-bit PNG. An exposure offset shows (the timing is "
                   "the stock's, not the frame's). Without an ADX colour space in the config, "
                   "or for a stock whose layers are not R, G, B (nor one layer), a plain "
                   "inversion, with a warning: p = clamp((D - base density) / (D_hi - base "
                   "density), 0, 1), D_hi the 99.9th percentile of the density over all layers, "
                   "encoded as p^(1/2.2).");
    out << "\nProgress and messages go to stderr; errors read 'filmgrain: error: ...'.\n"
        << "On any error or interruption no output file (-o, --stats, --preview) of the\n"
        << "image being rendered is created. Progress shows on a terminal once a run takes\n"
        << "a second (frames done, the frame's fraction, elapsed and estimated time left).\n"
        << "\nExit status:\n";
    append_wrapped(out, "    ",
                   "0 success; " + std::to_string(kExitError)
                       + " error (usage errors included); " + std::to_string(kExitSignalBase)
                       + "+N interrupted by signal N (130: SIGINT, 143: SIGTERM).");
    out << "\nExamples:\n"
        << "    filmgrain --wedge --filmgrain -o out/wedge.exr --preview out/wedge.png\n"
        << "    filmgrain --chart --filmgrain -o out/chart.exr --preview out/chart.png\n"
        << "    filmgrain photo.png --filmgrain:stock=paper:exposure_stops=1:seed=7 -d half -o "
           "photo_neg.exr\n";
    return out.str();
}

}  // namespace filmgrain::cli
