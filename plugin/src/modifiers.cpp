// filmgrain CLI: parsing of the --filmgrain and -o modifiers (modifiers.h).
//
// One table lists every modifier with its value form, help, default printer
// and parser: --help, the "valid modifiers" list of errors and the parser
// all walk it, so a modifier cannot be documented under one name and parsed
// under another. Ranges of the scene settings are checked by the core's
// SceneSettings::validate(), the one place they are defined.
#include "modifiers.h"
#include "util/parse_number.h"

#include <charconv>
#include <climits>
#include <cmath>
#include <exception>
#include <sstream>
#include <string_view>
#include <system_error>
#include <utility>

namespace filmgrain::cli {

namespace {

/// Longest piece of user input quoted in a message.
constexpr size_t kMaxQuoted = 100;

/// `s` made safe to print: control and non-ASCII bytes as \xHH, truncated.
std::string printable(std::string_view s)
{
    static const char* hex = "0123456789abcdef";
    std::string out;
    for (size_t i = 0; i < s.size(); ++i) {
        if (i == kMaxQuoted) {
            out += "...";
            break;
        }
        const auto c = static_cast<unsigned char>(s[i]);
        if (c >= 0x20 && c < 0x7f) {
            out += static_cast<char>(c);
        } else {
            out += "\\x";
            out += hex[c >> 4];
            out += hex[c & 15];
        }
    }
    return out;
}

std::string format_number(double v)
{
    std::ostringstream out;
    out << v;  // 6 significant digits, like %g
    return out.str();
}

/// A whole number in [lo, hi] (lo >= 0).
bool parse_int_in(std::string_view s, int64_t lo, int64_t hi, int64_t& out, std::string& why)
{
    uint64_t v = 0;
    if (!parse_count(s, static_cast<uint64_t>(hi), v, why))
        return false;
    if (static_cast<int64_t>(v) < lo) {
        why = "must be at least " + std::to_string(lo);
        return false;
    }
    out = static_cast<int64_t>(v);
    return true;
}

/// Image sides and coordinates must fit OIIO's 32-bit ints.
constexpr int64_t kMaxPixels = INT_MAX;

/// How a value failed: a message and (optionally) nothing else.
using ParseFn   = bool (*)(std::string_view value, FilmgrainCommand& cmd, std::string& why);
using DefaultFn = std::string (*)(const FilmgrainCommand& defaults);

struct Modifier {
    const char* key;
    std::string form;
    const char* help;
    DefaultFn show_default;
    ParseFn parse;
};

bool parse_stock(std::string_view v, FilmgrainCommand& cmd, std::string&)
{
    cmd.stock = std::string(v);
    return true;
}

bool parse_exposure(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    return parse_decimal(v, cmd.scene.exposure_stops, why);
}

/// Seconds as a decimal number or a fraction N/D (shutter_s=1/48).
bool parse_shutter(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    const size_t slash = v.find('/');
    if (slash == std::string_view::npos)
        return parse_decimal(v, cmd.scene.shutter_s, why);
    double num = 0.0, den = 0.0;
    if (!parse_decimal(v.substr(0, slash), num, why)
        || !parse_decimal(v.substr(slash + 1), den, why)) {
        why = "not a number or a fraction N/D of two numbers";
        return false;
    }
    if (den == 0.0) {
        why = "division by zero";
        return false;
    }
    const double s = num / den;
    if (!std::isfinite(s)) {
        why = "not a finite number";
        return false;
    }
    cmd.scene.shutter_s = s;
    return true;
}

bool parse_seed(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    uint64_t seed = 0;
    if (!parse_count(v, UINT64_MAX, seed, why)) {
        why += "; a seed is a whole number in [0, 18446744073709551615]";
        return false;
    }
    cmd.scene.seed = seed;
    return true;
}

bool parse_frame(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    const bool negative = !v.empty() && v.front() == '-';
    uint64_t magnitude  = 0;
    if (!parse_count(negative ? v.substr(1) : v, static_cast<uint64_t>(kMaxFrameNumber),
                     magnitude, why)) {
        why += "; a frame number is a whole number in [" + std::to_string(-kMaxFrameNumber)
               + ", " + std::to_string(kMaxFrameNumber) + "]";
        return false;
    }
    const int64_t m = static_cast<int64_t>(magnitude);
    cmd.scene.frame = negative ? -m : m;
    return true;
}

bool parse_static(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    if (v != "0" && v != "1") {
        why = "must be 0 or 1";
        return false;
    }
    cmd.scene.static_grain = v == "1";
    return true;
}

bool parse_edge(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    if (!parse_name(v, cmd.scene.edge)) {
        why = "must be " + names_in(kFrameEdgeNames, " or ");
        return false;
    }
    return true;
}

bool parse_width_mm(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    cmd.has_width_mm = true;
    return parse_decimal(v, cmd.scene.width_mm, why);
}

bool parse_scan(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    const size_t x = v.find('x');
    int64_t w = 0, h = 0;
    if (!parse_int_in(v.substr(0, x), 1, kMaxPixels, w, why)) {
        why = "width: " + why;
        return false;
    }
    if (x != std::string_view::npos && !parse_int_in(v.substr(x + 1), 1, kMaxPixels, h, why)) {
        why = "height: " + why;
        return false;
    }
    cmd.scan_width  = w;
    cmd.scan_height = h;
    return true;
}

bool parse_roi(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    static const char* names[4] = { "x", "y", "width", "height" };
    int64_t values[4]           = { 0, 0, 0, 0 };
    for (int i = 0; i < 4; ++i) {
        const size_t comma = v.find(',');
        if ((i < 3) != (comma != std::string_view::npos)) {
            why = "must be four numbers separated by commas";
            return false;
        }
        std::string_view part = v.substr(0, comma);
        // x and y may be negative: the overscan of a plate whose data
        // window reaches beyond its display window lies there.
        const bool negative = i < 2 && !part.empty() && part.front() == '-';
        if (negative)
            part.remove_prefix(1);
        if (!parse_int_in(part, i < 2 ? 0 : 1, kMaxPixels, values[i], why)) {
            why = std::string(names[i]) + ": " + why;
            return false;
        }
        if (negative)
            values[i] = -values[i];
        v = i < 3 ? v.substr(comma + 1) : std::string_view();
    }
    if (values[0] + values[2] > kMaxPixels || values[1] + values[3] > kMaxPixels) {
        why = "x + width and y + height must be at most " + std::to_string(kMaxPixels);
        return false;
    }
    cmd.has_roi    = true;
    cmd.roi_x      = values[0];
    cmd.roi_y      = values[1];
    cmd.roi_width  = values[2];
    cmd.roi_height = values[3];
    return true;
}

bool parse_engine_value(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    if (!parse_name(v, cmd.engine_options.engine)) {
        why = "unknown engine (known: " + names_in(kEngineNames, ", ") + ")";
        return false;
    }
    return true;
}

bool parse_tolerance(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    double t = 0.0;
    if (!parse_decimal(v, t, why))
        return false;
    if (!(t > 0.0 && t <= 1.0)) {
        why = "must be in (0, 1] (a density error budget)";
        return false;
    }
    cmd.engine_options.tolerance = t;
    return true;
}

/// An expert override `key=NAME`: one of the names in `table`
/// (filmgrain/names.h).
template<typename E, size_t N>
bool parse_choice(std::string_view v, const Named<E> (&table)[N], const char* what,
                  std::optional<E>& out, std::string& why)
{
    E e {};
    if (value_in(table, v, e)) {
        out = e;
        return true;
    }
    why = std::string("unknown ") + what + " (known: " + names_in(table, "|") + ")";
    return false;
}

bool parse_kinetics_value(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    return parse_choice(v, kKineticsNames, "kinetics method", cmd.engine_options.kinetics, why);
}

bool parse_photons_value(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    return parse_choice(v, kExposureNames, "exposure sampling", cmd.engine_options.photons, why);
}

bool parse_coverage_value(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    return parse_choice(v, kCoverageNames, "coverage method", cmd.engine_options.coverage, why);
}

bool parse_grains_value(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    return parse_choice(v, kGrainNames, "grain method", cmd.engine_options.grains, why);
}

bool parse_scale_value(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    return parse_choice(v, kScaleNames, "scale", cmd.engine_options.scale, why);
}

bool parse_samples(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    int64_t n = 0;
    if (!parse_int_in(v, 1, 256, n, why))
        return false;
    cmd.engine_options.samples = static_cast<int>(n);
    return true;
}

bool parse_output_value(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    if (!parse_output_kind(v, cmd.output)) {
        why = "unknown output (known: density, adx10, adx16, regrain)";
        return false;
    }
    return true;
}

bool parse_timing_value(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    if (!parse_name(v, cmd.timing)) {
        why = "unknown timing (known: " + names_in(kAdxTimingNames, ", ") + ")";
        return false;
    }
    return true;
}

std::string engine_choice(const char* what) { return std::string("the engine's choice (") + what + ")"; }

/// RenderSettings::tile_size_px's documented range.
constexpr int64_t kMaxTile = 4096;

bool parse_tile(std::string_view v, FilmgrainCommand& cmd, std::string& why)
{
    int64_t t = 0;
    if (!parse_int_in(v, 1, kMaxTile, t, why))
        return false;
    cmd.tile_size_px = static_cast<int>(t);
    return true;
}

std::string default_shutter(const FilmgrainCommand& d)
{
    std::string s     = format_number(d.scene.shutter_s);
    const double recip = 1.0 / d.scene.shutter_s;
    if (recip > 1.0 && std::abs(recip - std::round(recip)) < 1e-9 * recip)
        s += " (1/" + format_number(std::round(recip)) + ")";
    return s;
}

std::string default_scan(const FilmgrainCommand& d)
{
    if (!d.scan_width && !d.scan_height)
        return "the input's size";
    return std::to_string(d.scan_width) + "x" + std::to_string(d.scan_height);
}

std::string default_roi(const FilmgrainCommand& d)
{
    if (!d.has_roi)
        return "the whole scan";
    return std::to_string(d.roi_x) + "," + std::to_string(d.roi_y) + ","
           + std::to_string(d.roi_width) + "," + std::to_string(d.roi_height);
}

const Modifier kModifiers[] = {
    { "stock", "NAME|FILE",
      "film stock: a built-in preset name or a stock JSON file (no ':' in the path)",
      [](const FilmgrainCommand& d) { return d.stock; }, parse_stock },
    { "exposure_stops", "STOPS", "exposure offset in stops relative to the stock's grey, [-64, 64]",
      [](const FilmgrainCommand& d) { return format_number(d.scene.exposure_stops); },
      parse_exposure },
    { "shutter_s", "SECONDS",
      "time the shutter is open, seconds or a fraction such as 1/48, (0, 1e7]",
      default_shutter, parse_shutter },
    { "seed", "N", "grain pattern: a whole number in [0, 2^64 - 1]",
      [](const FilmgrainCommand& d) { return std::to_string(d.scene.seed); }, parse_seed },
    { "frame", "N",
      "frame number: the grain of frame N is seed's frame_seed(seed, N) (docs/usage.md, \"Sequences\"), "
      "so a frame rendered alone equals the same frame of a --frames sequence",
      [](const FilmgrainCommand& d) {
          return d.scene.frame ? std::to_string(*d.scene.frame)
                               : std::string("none (a single image: the seed as is); "
                                             "--frames sets it per frame");
      },
      parse_frame },
    { "static_grain", "0|1", "1: the same grain on every frame (the seed as is, frame ignored)",
      [](const FilmgrainCommand& d) { return std::string(d.scene.static_grain ? "1" : "0"); },
      parse_static },
    { "edge", names_in(kFrameEdgeNames, "|"),
      "beyond the input's data window (MODEL.md 2): clamp = the scene continues, each point "
      "exposed as the nearest edge pixel (a plate is a crop of the picture the lens made); "
      "gate = no light (a frame's hard edge inside a camera gate)",
      [](const FilmgrainCommand& d) { return std::string(name_of(d.scene.edge)); },
      parse_edge },
    { "width_mm", "MM", "width of the film frame, millimetres, (0, 1e9]",
      [](const FilmgrainCommand& d) { return format_number(d.scene.width_mm); },
      parse_width_mm },
    { "scan", "WxH|W",
      "scan (output) size in pixels over the whole frame; W alone keeps the frame's aspect",
      default_scan, parse_scan },
    { "roi", "X,Y,W,H",
      "region of the scan to render, scan pixels from the display window's corner (must lie "
      "inside the scan and its overscan: a plate's data window beyond its display window is "
      "rendered too, at negative coordinates and beyond the scan)",
      default_roi, parse_roi },
    { "engine", names_in(kEngineNames, "|"),
      "simulation engine: exact is the reference (every photon, the latent-image chain until each "
      "grain is decided, exact coverage); "
      "auto runs the paths the scene needs within the tolerance; fast the fastest paths",
      [](const FilmgrainCommand& d) { return std::string(name_of(d.engine_options.engine)); },
      parse_engine_value },
    { "tolerance", "D", "density error budget of the approximate paths (auto), (0, 1]",
      [](const FilmgrainCommand& d) { return format_number(d.engine_options.tolerance); }, parse_tolerance },
    { "kinetics", names_in(kKineticsNames, "|"),
      "expert override (not with engine=exact): chain = exact's: every photon, the chain until "
      "the grain's fate is decided; early = the same, but no photons for a grain fog decides; "
      "table = P(develop|N) tabulated per scene; curve = the fast per-grain kernel: "
      "P(develop|mean photons) from that table, one uniform per grain; fog = for layers no light "
      "reaches (an error on a lit one): only the fog's developed grains are generated",
      [](const FilmgrainCommand&) {
          return engine_choice("fog where no light reaches a layer (its pixel scale where "
                               "that costs less); else curve where a table pays for itself "
                               "(large frames), else early; fast: curve where light reaches");
      },
      parse_kinetics_value },
    { "photons", names_in(kExposureNames, "|"),
      "expert override: exposure integrated over each grain's disc, or sampled at its centre",
      [](const FilmgrainCommand&) { return engine_choice("disc; fast: centre"); },
      parse_photons_value },
    { "coverage", names_in(kCoverageNames, "|"),
      "expert override: exact pixel coverage, chord unions on sub-scanlines, or a raster of 64 "
      "points across a pixel and `samples` rows down it",
      [](const FilmgrainCommand&) {
          return engine_choice("raster with kinetics=curve, else exact; fast: raster");
      },
      parse_coverage_value },
    { "grains", names_in(kGrainNames, "|"),
      "expert override: the reference's grain streams, or the fast kernel's (counter-based per "
      "cell, tabulated size quantiles: same distribution, other grains); grains=fast with "
      "kinetics=early runs the exact decisions on the kernel's grains (for measuring it)",
      [](const FilmgrainCommand&) { return engine_choice("fast with kinetics=curve, else exact"); },
      parse_grains_value },
    { "scale", names_in(kScaleNames, "|"),
      "expert override: every grain simulated, or each pixel's transmittance drawn from the "
      "Boolean model's pixel statistics (for grains far below the pixel), or mixed: the pixel "
      "statistics for each pixel whose exposure develops >= 3.9 grains, grains elsewhere",
      [](const FilmgrainCommand&) {
          return engine_choice("pixel where every grain is under a pixel and even fog "
                               "develops >= 3.9 grains per pixel; mixed where fog develops "
                               "fewer in a dye layer (its pixel law's shape sampled); else "
                               "grain");
      },
      parse_scale_value },
    { "samples", "N",
      "sub-scanlines per pixel row (scanline coverage), sample rows per pixel (raster), or a "
      "dye layer's sample rows (disc clouds) or points per axis (gaussian) per pixel, [1, 256]",
      [](const FilmgrainCommand&) {
          return engine_choice("scanline: 2 chords per smallest mean grain radius; raster: rows "
                               "for the tolerance, 21 per smallest mean radius at 0.002 (more "
                               "where grains are large against the pixel), at "
                               "most 256 (fast: 4); dye: 2 per smallest mean cloud radius, 2 to "
                               "16 (exact: 8 per radius, 4 to 64)");
      },
      parse_samples },
    { "tile", "N", "work tile side in scan pixels, [1, 4096]; speed only, never the output",
      [](const FilmgrainCommand& d) { return std::to_string(d.tile_size_px); }, parse_tile },
    { "output", "density|adx10|adx16|regrain",
      "what the EXR holds: density = negative density per layer; adx10 / adx16 = Academy "
      "Density Exchange code values (SMPTE ST 2065-3) / 1023 or / 65535, channels R, G, B, for "
      "an OCIO config's ADX10 / ADX16 colour space; regrain = a scene-linear positive, the input "
      "plus the film's grain, in --ocolorspace (see Output below)",
      [](const FilmgrainCommand& d) { return std::string(output_kind_name(d.output)); },
      parse_output_value },
    { "timing", names_in(kAdxTimingNames, "|"),
      "ADX's printer lights (output=adx10|adx16 only): off = the standard encoding, the "
      "stock's printing densities above D-min; grey = per-channel offsets that put the stock's "
      "own 18% grey card on CDD 0.70 (ADX16 7120, ACES 0.18) in every channel, as a lab times "
      "a negative (see Output below)",
      [](const FilmgrainCommand& d) { return std::string(name_of(d.timing)); },
      parse_timing_value },
};

/// Modifiers renamed so that each name is the one the C++ fields, --stats,
/// the EXR metadata and Python use, with its unit. The old names are still
/// read, with a notice (FilmgrainCommand::notices), so that scripts written
/// for them keep working; --help lists them.
constexpr RenamedModifier kRenamed[] = {
    { "exposure", "exposure_stops" },
    { "shutter", "shutter_s" },
    { "static", "static_grain" },
};

std::string modifier_list()
{
    std::string s;
    for (const Modifier& m : kModifiers)
        s += std::string(s.empty() ? "" : ", ") + m.key;
    return s;
}

/// One key=value of a command-line word.
struct KeyValue {
    std::string_view key;
    std::string_view value;
};

/// Splits `arg` into its option name (before the first ':') and its
/// key=value modifiers. Empty modifiers, missing '=' and repeated keys are
/// errors.
Status split_modifiers(std::string_view arg, std::string& option, std::vector<KeyValue>& out)
{
    out.clear();
    const size_t colon = arg.find(':');
    option             = printable(arg.substr(0, colon));
    if (colon == std::string_view::npos)
        return {};
    std::string_view rest = arg.substr(colon + 1);
    while (true) {
        const size_t next          = rest.find(':');
        const std::string_view mod = rest.substr(0, next);
        if (mod.empty())
            return Status::errorf(option, ": empty modifier in '", printable(arg),
                                  "'; modifiers are written :key=value");
        const size_t eq = mod.find('=');
        if (eq == std::string_view::npos)
            return Status::errorf(option, ": modifier '", printable(mod),
                                  "' has no value; modifiers are written :key=value");
        KeyValue kv { mod.substr(0, eq), mod.substr(eq + 1) };
        if (kv.key.empty())
            return Status::errorf(option, ": modifier '", printable(mod),
                                  "' has no key; modifiers are written :key=value");
        for (const KeyValue& prev : out)
            if (prev.key == kv.key)
                return Status::errorf(option, ": modifier '", printable(kv.key),
                                      "' given twice (", printable(kv.key), "=",
                                      printable(prev.value), " and ", printable(kv.key), "=",
                                      printable(kv.value), ")");
        out.push_back(kv);
        if (next == std::string_view::npos)
            break;
        rest = rest.substr(next + 1);
    }
    return {};
}

Status parse_filmgrain_impl(const std::string& arg, FilmgrainCommand& out)
{
    std::string option;
    std::vector<KeyValue> mods;
    if (Status s = split_modifiers(arg, option, mods); !s)
        return s;
    FilmgrainCommand cmd;
    std::vector<std::string_view> keys;  // as renamed, to refuse one given twice
    for (const KeyValue& given : mods) {
        KeyValue kv = given;
        for (const RenamedModifier& r : kRenamed)
            if (kv.key == r.old_key) {
                kv.key = r.key;
                cmd.notices.push_back(std::string(r.old_key) + "= is now " + r.key
                                      + "= (the old name is still read)");
            }
        for (std::string_view k : keys)
            if (k == kv.key)
                return Status::errorf(option, ": modifier '", kv.key,
                                      "' given twice (under its old and its new name)");
        keys.push_back(kv.key);
        const Modifier* mod = nullptr;
        for (const Modifier& m : kModifiers)
            if (kv.key == m.key)
                mod = &m;
        if (!mod)
            return Status::errorf(option, ": unknown modifier '", printable(kv.key),
                                  "'; valid modifiers: ", modifier_list());
        if (kv.value.empty())
            return Status::errorf(option, ": ", given.key, "= has an empty value; expected ",
                                  mod->key, "=", mod->form, " (", mod->help, ")");
        std::string why;
        if (!mod->parse(kv.value, cmd, why))
            return Status::errorf(option, ": ", given.key, "=", printable(kv.value), ": ", why,
                                  "; expected ", mod->key, "=", mod->form, " (", mod->help,
                                  ")");
    }
    if (Status s = cmd.scene.validate(); !s)
        return Status::errorf(option, ": ", s.message());
    out = std::move(cmd);
    return {};
}

}  // namespace

std::vector<ModifierDoc> filmgrain_modifier_docs()
{
    const FilmgrainCommand defaults;
    std::vector<ModifierDoc> docs;
    for (const Modifier& m : kModifiers)
        docs.push_back({ m.key, m.form, m.help, m.show_default(defaults) });
    return docs;
}

std::vector<RenamedModifier> renamed_modifiers()
{
    return { std::begin(kRenamed), std::end(kRenamed) };
}

Status parse_filmgrain_modifiers(const std::string& arg, FilmgrainCommand& out)
{
    try {
        return parse_filmgrain_impl(arg, out);
    } catch (const std::exception& e) {  // std::bad_alloc only
        return Status::errorf("--filmgrain: ", e.what());
    }
}

std::vector<std::string> exr_compressions()
{
    return { "none", "rle", "zips", "zip", "piz", "pxr24", "b44", "b44a", "dwaa", "dwab" };
}

Status parse_output_modifiers(const std::string& arg, OutputModifiers& out)
{
    try {
        std::string option;
        std::vector<KeyValue> mods;
        if (Status s = split_modifiers(arg, option, mods); !s)
            return s;
        OutputModifiers result;
        const std::vector<std::string> names = exr_compressions();
        std::string list;
        for (const auto& n : names)
            list += (list.empty() ? "" : ", ") + n;
        for (const KeyValue& kv : mods) {
            if (kv.key != "compression")
                return Status::errorf(option, ": unknown modifier '", printable(kv.key),
                                      "'; valid modifiers: compression");
            bool known = false;
            for (const auto& n : names)
                known |= kv.value == n;
            if (!known)
                return Status::errorf(option, ": compression=", printable(kv.value),
                                      ": unknown OpenEXR compression; expected one of ", list);
            result.compression = std::string(kv.value);
        }
        out = std::move(result);
        return {};
    } catch (const std::exception& e) {
        return Status::errorf("-o: ", e.what());
    }
}

}  // namespace filmgrain::cli
