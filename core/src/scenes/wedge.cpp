#include "filmgrain/wedge.h"

#include <cmath>

namespace filmgrain {

std::vector<float> make_step_wedge(const WedgeSpec& spec)
{
    const int64_t w = spec.width_px(), h = spec.height_px;
    std::vector<float> pixels(static_cast<size_t>(w * h));
    for (int64_t x = 0; x < w; ++x) {
        const int step = static_cast<int>(x / spec.step_width_px);
        const float v  = static_cast<float>(0.18 * std::exp2(spec.step_stops(step)));
        for (int64_t y = 0; y < h; ++y)
            pixels[static_cast<size_t>(y * w + x)] = v;
    }
    return pixels;
}

}  // namespace filmgrain
