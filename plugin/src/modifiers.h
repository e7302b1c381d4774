// filmgrain CLI: the `:key=value` modifiers of --filmgrain and -o.
//
// Pure string parsing, no I/O: this is the part of the command line that will
// get a libFuzzer target, so every function here is total: no exception
// escapes, no undefined behaviour on any byte sequence, every failure is a
// Status whose message names the modifier, its value and the allowed form or
// range.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "filmgrain/printing_density.h"
#include "filmgrain/render.h"
#include "filmgrain/status.h"
#include "filmgrain/stock.h"
#include "output_kind.h"

namespace filmgrain::cli {

/// What `--filmgrain[:key=value...]` asks for. Every default is the
/// library's own (the default preset, SceneSettings, RenderSettings), so
/// `--filmgrain` alone renders with the documented defaults.
struct FilmgrainCommand {
    /// `stock=NAME|FILE`: a built-in preset name or a stock JSON file path
    /// (a path cannot contain ':', the modifier separator).
    std::string stock = default_preset_name();
    /// `exposure_stops=`, `shutter_s=`, `seed=`, `frame=`, `static_grain=`,
    /// `edge=`, `width_mm=`.
    SceneSettings scene;
    /// Whether `width_mm=` was given (the --wedge and --chart strips have
    /// their own widths).
    bool has_width_mm = false;
    /// `engine=`, `tolerance=`, and the expert overrides `kinetics=`,
    /// `photons=`, `coverage=`, `grains=`, `samples=`.
    EngineOptions engine_options;
    /// `scan=WxH|W`: scan pixels over the whole frame; 0 = the input's size
    /// (scan_height 0 with scan_width set: the frame's aspect).
    int64_t scan_width  = 0;
    int64_t scan_height = 0;
    /// `roi=X,Y,W,H`: the region of the scan to render, scan pixels.
    bool has_roi       = false;
    int64_t roi_x      = 0;
    int64_t roi_y      = 0;
    int64_t roi_width  = 0;
    int64_t roi_height = 0;
    /// `tile=N`: work tile side, scan pixels (speed only).
    int tile_size_px = RenderSettings().tile_size_px;
    /// `output=density|adx10|adx16|regrain`: what the EXR holds
    /// (output_transform.h).
    OutputKind output = OutputKind::density;
    /// `timing=off|grey`: ADX's printer lights (MODEL.md 11); grey puts the
    /// stock's own 18% grey on CDD 0.70 in every channel. Only with
    /// output=adx10|adx16 (apply_output refuses it otherwise).
    AdxTiming timing = AdxTiming::off;
    /// What the caller should tell the user: a renamed modifier read under
    /// its old name (renamed_modifiers()).
    std::vector<std::string> notices;
};

/// One modifier as documented by --help: its key, the form of its value,
/// what it means and its default (printed from a default FilmgrainCommand).
struct ModifierDoc {
    std::string key;
    std::string form;
    std::string help;
    std::string default_text;
};

/// Every --filmgrain modifier, in the order --help lists them.
std::vector<ModifierDoc> filmgrain_modifier_docs();

/// A modifier's old name, still read (with a notice), and its name now.
struct RenamedModifier {
    const char* old_key;
    const char* key;
};

/// The renamed modifiers: exposure -> exposure_stops, shutter -> shutter_s,
/// static -> static_grain (each name now carries its unit, as in C++,
/// --stats, the EXR metadata and Python).
std::vector<RenamedModifier> renamed_modifiers();

/// Parses one command-line word `--filmgrain[:key=value[:key=value...]]`.
/// The part before the first ':' is the option's name and is not examined;
/// the rest is a ':'-separated list of key=value modifiers. No modifiers
/// means all defaults. Strict: unknown keys, repeated keys, empty values,
/// malformed or out-of-range values (NaN and Inf included) are errors.
/// Numbers: decimal, locale-independent, fully consumed (std::from_chars).
/// On success `out` is replaced by the defaults overridden by the
/// modifiers; on failure it is left unchanged.
/// Never throws; no undefined behaviour on any input.
Status parse_filmgrain_modifiers(const std::string& arg, FilmgrainCommand& out);

/// What `-o[:compression=NAME] FILE` asks for.
struct OutputModifiers {
    /// OpenEXR compression. PIZ (lossless wavelet), OpenEXR's choice for
    /// grainy images: on a 4096x3112 three-layer density frame 111 MB
    /// against zip's 140 MB, written ~3.5 times faster (zip compresses on
    /// one thread here).
    std::string compression = "piz";
};

/// The OpenEXR compressions -o:compression accepts.
std::vector<std::string> exr_compressions();

/// Parses `-o[:compression=NAME]` (same rules as above). Never throws.
Status parse_output_modifiers(const std::string& arg, OutputModifiers& out);

}  // namespace filmgrain::cli
