// filmgrain CLI: the --stats JSON document.
//
// Its key names are a contract for scripts (tests/cli checks them):
//   engine, version, output (density|adx10|adx16|regrain), stock, seed,
//   frame (null for a single image), static,
//   grain_seed, exposure_stops, shutter_s, frame_width_mm,
//   seconds {read, color, simulate, write, total},
//   scan {width, height, pitch_x_um, pitch_y_um},
//   roi {x, y, width, height},
//   input {file, colorspace, pixels_read, nonfinite_pixels, nan_pixels,
//          saturated_pixels, negative_pixels, denormal_pixels},
//   layers [{name, grains, developed, absorbed_photons, kinetics_events,
//            decided_early, mean_density, path, reason, error_estimate,
//            setup_seconds, estimated_seconds}]
#pragma once

#include <cstdint>
#include <string>

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
    std::string input_file;  ///< path, or "wedge" or "chart"
    std::string input_colorspace;
    /// --filmgrain:output= (output_kind_name).
    std::string output = "density";
    RenderStats render;
    StageSeconds seconds;
};

/// The report as a pretty-printed JSON object (ends with a newline).
std::string stats_json(const RunReport& report);

}  // namespace filmgrain::cli
