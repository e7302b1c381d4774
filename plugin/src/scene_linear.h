// filmgrain CLI: INPUT to the OCIO config's scene_linear (MODEL.md 2's
// scene-linear values), from what the command line and the file say.
#pragma once

#include <OpenImageIO/imagebuf.h>

#include <optional>
#include <string>

#include "cli_args.h"
#include "console.h"
#include "filmgrain/ocio.h"
#include "filmgrain/status.h"

namespace filmgrain::cli {

/// Chooses INPUT's colour space, converts `src` in place to the config's
/// scene_linear and says which space was used: --iscolorspace, else the
/// file's oiio:ColorSpace when the config knows it and it names primaries,
/// else the file's chromaticities (an RGB image's), else scene_linear.
/// OIIO's OpenEXR reader says "Linear" for every file (EXR stores no colour
/// space name): linear light, primaries unsaid, so the chromaticities, when
/// the file has them, say which. `chosen` receives the colour space name, or
/// "chromaticities" when converted from them; `used_xy` the chromaticities
/// when they decided (converted, or found to be scene_linear's), else
/// nothing. 1-channel images stay grey when the conversion is a no-op, else
/// become (y, y, y) first.
Status convert_to_scene_linear(const CliArgs& a, const std::string& input_path,
                               OIIO::ImageBuf& src, const Console& con, std::string& chosen,
                               std::optional<ocio::Chromaticities>& used_xy);

}  // namespace filmgrain::cli
