// The render's settings: their validation, the seeds, and the scan geometry
// they ask for (their names: filmgrain/render.h's tables).
#include "engine/settings.h"

#include <cmath>
#include <string>
#include <vector>

#include "model/geometry.h"
#include "util/rng.h"

namespace filmgrain {

Status SceneSettings::validate() const
{
    if (!std::isfinite(exposure_stops) || exposure_stops < -64.0 || exposure_stops > 64.0)
        return Status::errorf("exposure_stops = ", exposure_stops, ": must be in [-64, 64]");
    if (!std::isfinite(shutter_s) || shutter_s <= 0.0 || shutter_s > 1e7)
        return Status::errorf("shutter_s = ", shutter_s, ": must be in (0, 1e7]");
    if (!std::isfinite(width_mm) || width_mm <= 0.0 || width_mm > 1e9)
        return Status::errorf("width_mm = ", width_mm, ": must be in (0, 1e9]");
    if (frame && (*frame < -kMaxFrameNumber || *frame > kMaxFrameNumber))
        return Status::errorf("frame = ", *frame, ": must be in [", -kMaxFrameNumber, ", ",
                              kMaxFrameNumber, "]");
    return {};
}

uint64_t frame_seed(uint64_t seed, int64_t frame)
{
    return hash_ids(seed, 0xf4a3eULL, static_cast<uint64_t>(frame));
}

uint64_t grain_seed(const SceneSettings& scene)
{
    return scene.frame && !scene.static_grain ? frame_seed(scene.seed, *scene.frame) : scene.seed;
}

Status RenderSettings::validate() const
{
    if (!(tolerance > 0.0 && tolerance <= 1.0))
        return Status::errorf("tolerance = ", tolerance, ": must be in (0, 1]");
    if (samples < 0 || samples > 256)
        return Status::errorf("samples = ", samples, ": must be in [0, 256]");
    if (tile_size_px < 1 || tile_size_px > 4096)
        return Status::errorf("tile size = ", tile_size_px, ": must be in [1, 4096]");
    if (nthreads < 0)
        return Status::errorf("nthreads = ", nthreads, ": must be >= 0");
    if (engine == Engine::exact
        && (kinetics || photons || coverage || samples || grains || scale))
        return Status::error("the exact engine is the reference: its kinetics, exposure, "
                             "coverage, grain and scale methods cannot be overridden (use engine=fast "
                             "or auto)");
    if (kinetics == KineticsMethod::curve && grains == GrainMethod::exact)
        return Status::error("kinetics=curve runs in the fast per-grain kernel, which draws "
                             "grains=fast");
    return {};
}

Status frame_geometry(const SceneSettings& scene, int64_t input_width, int64_t input_height,
                      const RenderSettings& settings, FrameGeometry& out)
{
    return FrameGeometry::make(scene.width_mm, input_width, input_height,
                               settings.scan_width, settings.scan_height, out,
                               settings.scan_reference);
}

Status scan_geometry(const SceneSettings& scene, int64_t input_width, int64_t input_height,
                     const RenderSettings& settings, ScanGeometry& out)
{
    FrameGeometry g;
    if (Status s = frame_geometry(scene, input_width, input_height, settings, g); !s)
        return s;
    out.width           = g.scan_width;
    out.height          = g.scan_height;
    out.frame_width_um  = g.width_um;
    out.frame_height_um = g.height_um;
    out.input_pitch_um  = g.input_pitch_um;
    out.pitch_x_um      = g.scan_pitch_x_um;
    out.pitch_y_um      = g.scan_pitch_y_um;
    out.reference       = g.scan_reference;
    out.frame_pixels    = g.frame_scan_pixels();
    return {};
}

Roi scan_pixels_over(const ScanGeometry& scan, const Roi& input_pixels, double* exact)
{
    const Roi& r = scan.reference;
    if (exact) {
        const double sx = static_cast<double>(scan.width) / static_cast<double>(r.width());
        const double sy = static_cast<double>(scan.height) / static_cast<double>(r.height());
        exact[0] = static_cast<double>(input_pixels.x_begin - r.x_begin) * sx;
        exact[1] = static_cast<double>(input_pixels.y_begin - r.y_begin) * sy;
        exact[2] = static_cast<double>(input_pixels.x_end - r.x_begin) * sx;
        exact[3] = static_cast<double>(input_pixels.y_end - r.y_begin) * sy;
    }
    return scan_pixels_over(r, scan.width, scan.height, input_pixels);
}

}  // namespace filmgrain
