// filmgrain CLI: the --stats JSON document (stats_json.h).
#include "stats_json.h"

#include <nlohmann/json.hpp>

#include "filmgrain/version.h"

namespace filmgrain::cli {

std::string stats_json(const RunReport& r)
{
    using Json = nlohmann::ordered_json;
    Json j;
    j["engine"]         = r.render.engine;
    j["version"]        = version_string();
    j["output"]         = r.output;
    j["stock"]          = r.stock_name;
    j["seed"]           = r.scene.seed;
    j["frame"]          = frame_json<Json>(r.scene.frame);
    j["static_grain"]   = r.scene.static_grain;
    j["grain_seed"]     = grain_seed(r.scene);
    j["exposure_stops"] = r.scene.exposure_stops;
    j["shutter_s"]      = r.scene.shutter_s;
    j["width_mm"]       = r.scene.width_mm;
    j["seconds"]        = { { "read", r.seconds.read },
                            { "color", r.seconds.color },
                            { "simulate", r.seconds.simulate },
                            { "write", r.seconds.write },
                            { "total", r.seconds.total } };
    j["scan"]           = { { "width", r.scan.width },
                            { "height", r.scan.height },
                            { "pitch_x_um", r.scan.pitch_x_um },
                            { "pitch_y_um", r.scan.pitch_y_um } };
    j["roi"]            = { { "x", r.roi.x_begin },
                            { "y", r.roi.y_begin },
                            { "width", r.roi.width() },
                            { "height", r.roi.height() } };
    const double* e     = r.data_window_exact;
    j["data_window"]    = { { "x", r.data_window.x_begin },
                            { "y", r.data_window.y_begin },
                            { "width", r.data_window.width() },
                            { "height", r.data_window.height() },
                            { "exact", { e[0], e[1], e[2], e[3] } },
                            { "rounded", r.data_window_rounded } };
    j["input"]          = { { "file", r.input_file },
                            { "colorspace", r.input_colorspace },
                            { "chromaticities", r.input_chromaticities
                                                    ? Json(*r.input_chromaticities)
                                                    : Json(nullptr) },
                            { "pixels_read", r.render.input.pixels_read },
                            { "nonfinite_pixels", r.render.input.nonfinite_pixels },
                            { "nan_pixels", r.render.input.nan_pixels },
                            { "saturated_pixels", r.render.input.saturated_pixels },
                            { "negative_pixels", r.render.input.negative_pixels },
                            { "denormal_pixels", r.render.input.denormal_pixels } };
    Json layers = Json::array();
    for (const LayerStats& l : r.render.layers)
        layers.push_back({ { "name", l.name },
                           { "grains", l.grains },
                           { "developed", l.developed },
                           { "absorbed_photons", l.absorbed_photons },
                           { "kinetics_events", l.kinetics_events },
                           { "decided_early", l.decided_early },
                           { "mean_density", l.mean_density },
                           { "path", l.path },
                           { "reason", l.reason },
                           { "error_estimate", l.error_estimate },
                           { "setup_seconds", l.setup_seconds },
                           { "estimated_seconds", l.estimated_seconds } });
    j["layers"] = std::move(layers);
    // Non-UTF-8 bytes in names (file paths) are replaced, never thrown on.
    return j.dump(2, ' ', false, Json::error_handler_t::replace) + "\n";
}

Status report_scan(const OIIO::ImageSpec& spec, const FilmgrainOptions& opts, RunReport& report)
{
    if (Status s = frame_scan(spec, opts, report.scan); !s)
        return s;
    return IBA::data_window_scan(spec, opts, report.data_window, report.data_window_exact,
                                 &report.data_window_rounded);
}

}  // namespace filmgrain::cli
