// Test helper: a layer made a dye layer (MODEL.md 8), as the dye, pixel
// statistics and Boolean-model tests set one up.
#pragma once

#include "filmgrain/stock.h"

namespace filmgrain {

/// `layer`'s image becomes dye clouds of `profile`, diameter_ratio times
/// their grain's diameter, of peak density `density`.
inline void make_dye(Layer& layer, CloudProfile profile, double diameter_ratio, double density)
{
    layer.image                = LayerImage::dye;
    layer.cloud_profile        = profile;
    layer.cloud_diameter_ratio = diameter_ratio;
    layer.cloud_density        = density;
}

}  // namespace filmgrain
