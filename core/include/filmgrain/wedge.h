// filmgrain: the built-in step wedge, the paper's Figure 1 scene.
#pragma once

#include <cstdint>
#include <vector>

namespace filmgrain {

/// A grey step wedge: `steps` vertical bars, left to right from dark to
/// bright, step i having scene-linear value 0.18 * 2^(first_stop + i *
/// stops_per_step). The default spans -8 to +7 stops around grey in 21
/// steps of 3/4 stop: from the film's fog to its shoulder.
///
/// The wedge is a sensitometric test strip, not a camera frame: it is
/// exposed on a strip `strip_width_mm` wide (steps of 0.3 mm, pixels of
/// 6.25 um), so that single grains are visible in its scan and the default
/// job stays quick. A render may still put it on any width.
struct WedgeSpec {
    int steps              = 21;
    double first_stop      = -8.0;
    double stops_per_step  = 0.75;
    int64_t step_width_px  = 48;
    int64_t height_px      = 96;
    double strip_width_mm  = 6.3;

    int64_t width_px() const { return steps * step_width_px; }
    /// Exposure offset of step i, stops relative to grey.
    double step_stops(int i) const { return first_stop + i * stops_per_step; }
};

/// The wedge as a packed single-channel scene-linear image
/// (width_px() x height_px floats).
std::vector<float> make_step_wedge(const WedgeSpec& spec);

}  // namespace filmgrain
