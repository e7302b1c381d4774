// filmgrain CLI: one image rendered, from its input to its outputs written
// all or nothing: read (or the built-in wedge and chart), colour, the
// operator, the output transform, write; and what --skip-existing and
// --dry-run ask of a frame.
#pragma once

#include <OpenImageIO/imagebuf.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cli_args.h"
#include "console.h"
#include "filmgrain/expected_curve.h"
#include "filmgrain/imagebufalgo_filmgrain.h"
#include "output_transform.h"
#include "sequence.h"

namespace filmgrain::cli {

/// What one image's render needs besides its files: the options shared by
/// every frame (stock loaded once).
struct RenderContext {
    const CliArgs& args;
    const Console& con;
    FilmgrainOptions opts;  ///< scene.frame is set per frame
    /// output=regrain's expected curves, built by the first frame.
    std::shared_ptr<std::vector<ExpectedCurve>> regrain_curves
        = std::make_shared<std::vector<ExpectedCurve>>();
    /// output=adx10|adx16's and the preview's printing density transforms
    /// (MODEL.md 11), built by the first frame.
    std::shared_ptr<std::optional<AdxTransform>> adx_transform
        = std::make_shared<std::optional<AdxTransform>>();
    std::shared_ptr<std::optional<AdxTransform>> preview_transform
        = std::make_shared<std::optional<AdxTransform>>();
};

/// Refuses, before any work, an output region larger than the limits.
Status check_output_size(const FilmgrainOptions& opts, const OIIO::ImageSpec& input,
                         const FilmgrainCommand& cmd);

/// The files the render reads besides INPUT (a stock JSON, an OCIO config)
/// must not be any of its outputs: --stats can have any name.
Status check_outputs_spare_inputs(const CliArgs& a, const FrameJob& job);

/// Identifies what an output was made from, for --skip-existing: a SHA-1
/// (OpenImageIO's) of the settings that decide the pixels, as canonical
/// JSON: version, stock (complete), scene (frame included), engine options,
/// scan, roi, pixel type, compression, colour conversion, and the input
/// file's path, size and modification time. Not the tile size or thread
/// count (they never change the output).
std::string settings_hash(const RenderContext& ctx, const FilmgrainOptions& opts,
                          const FrameJob& job);

/// --skip-existing: the job's EXR exists and says it was made with `hash`,
/// and its --stats and --preview files exist when asked for.
bool up_to_date(const FrameJob& job, const std::string& hash);

enum class FrameOutcome { rendered, up_to_date, missing };

/// The outcome as --report-json names it: rendered, up_to_date, missing_input.
inline constexpr Named<FrameOutcome> kFrameOutcomeNames[] = {
    { FrameOutcome::rendered, "rendered" },
    { FrameOutcome::up_to_date, "up_to_date" },
    { FrameOutcome::missing, "missing_input" }
};
constexpr const auto& names_of(FrameOutcome) { return kFrameOutcomeNames; }

/// Renders one image (a single image, or one frame of a sequence) and
/// writes its outputs all-or-nothing. Errors are returned; an interruption
/// is reported as Status "interrupted" (the caller checks interrupted()).
Status render_one(const RenderContext& ctx, const FrameJob& job, FrameOutcome& outcome);

/// Seconds as the summaries print them: 3 significant digits.
std::string format_seconds(double s);

}  // namespace filmgrain::cli
