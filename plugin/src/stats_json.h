// filmgrain CLI: the --stats JSON document.
//
// Its key names are a contract for scripts (tests/cli checks them):
//   engine, version, output (density|adx10|adx16|regrain), stock, seed,
//   frame (null for a single image), static_grain,
//   grain_seed, exposure_stops, shutter_s, width_mm,
//   seconds {read, color, simulate, write, total},
//   scan {width, height, pitch_x_um, pitch_y_um},
//   roi {x, y, width, height},
//   data_window {x, y, width, height, exact [x0, y0, x1, y1], rounded},
//   input {file, colorspace, chromaticities, pixels_read, nonfinite_pixels,
//          nan_pixels, saturated_pixels, negative_pixels, denormal_pixels},
//   layers [{name, grains, developed, absorbed_photons, kinetics_events,
//            decided_early, mean_density, path, reason, error_estimate,
//            setup_seconds, estimated_seconds}]
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "filmgrain/imagebufalgo_filmgrain.h"
#include "filmgrain/render.h"

namespace filmgrain::cli {

/// Wall-clock seconds of the stages of a run.
struct StageSeconds {
    double read     = 0.0;  ///< reading INPUT (or making the wedge or chart)
    double color    = 0.0;  ///< OCIO conversion to scene_linear
    double simulate = 0.0;  ///< the operator (render_negative)
    double write    = 0.0;  ///< writing the EXR and the preview
    double total    = 0.0;  ///< the whole run up to writing the stats
};

/// What a run did: everything --stats reports.
struct RunReport {
    std::string stock_name;
    SceneSettings scene;
    ScanGeometry scan;
    Roi roi;
    /// The input's data window in scan pixels, rounded outward
    /// (IBA::data_window_scan), and before the rounding.
    Roi data_window;
    double data_window_exact[4] = { 0.0, 0.0, 0.0, 0.0 };
    bool data_window_rounded    = false;
    std::string input_file;  ///< path, or "wedge" or "chart"
    /// The OCIO colour space INPUT was read as ("scene_linear" for the wedge
    /// and the chart), or "chromaticities" when converted from the file's.
    std::string input_colorspace;
    /// The file's chromaticities (red x, y, green x, y, blue x, y, white x,
    /// y) when they decided its colour: converted from, or found to be
    /// scene_linear's. Unset when it has none or a colour space name
    /// (--iscolorspace, oiio:ColorSpace) decided.
    std::optional<std::array<double, 8>> input_chromaticities;
    /// --filmgrain:output= (output_kind_name).
    std::string output = "density";
    RenderStats render;
    StageSeconds seconds;
};

/// The report as a pretty-printed JSON object (ends with a newline).
std::string stats_json(const RunReport& report);

/// A frame number as the JSON documents give it (--stats, the settings hash,
/// --dry-run and --report-json lines): the number, or null when there is
/// none (a single image). Json is nlohmann::ordered_json: a template, so that
/// this header needs no JSON library.
template<typename Json, typename Int> Json frame_json(const std::optional<Int>& frame)
{
    return frame ? Json(*frame) : Json(nullptr);
}

/// Fills report.scan (the display window's scan) and report.data_window*
/// (IBA::data_window_scan) for an input of header `spec` rendered with
/// `opts`: what the CLI and the Python module report alike.
Status report_scan(const OIIO::ImageSpec& spec, const FilmgrainOptions& opts, RunReport& report);

}  // namespace filmgrain::cli
