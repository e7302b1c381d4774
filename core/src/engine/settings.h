// What settings.cpp gives the engine besides filmgrain/render.h's
// declarations.
#pragma once

#include <cstdint>

#include "filmgrain/render.h"
#include "model/geometry.h"

namespace filmgrain {

/// The frame and its scan for an input of input_width x input_height
/// pixels with these settings: FrameGeometry::make with the scene's frame
/// width and the settings' scan size and reference.
Status frame_geometry(const SceneSettings& scene, int64_t input_width, int64_t input_height,
                      const RenderSettings& settings, FrameGeometry& out);

}  // namespace filmgrain
