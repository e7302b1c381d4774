// filmgrain CLI: the --filmgrain:output= transforms of the rendered negative
// (output_kind.h): Academy Density Exchange code values and the regrain
// positive. The maths runs on plain buffers (tested directly); apply_output
// is the thin OIIO/OCIO adapter the CLI calls after the operator.
//
// ADX (MODEL.md 11; SMPTE ST 2065-3; the ACES ADX10 / ADX16 input
// transforms): the core's printing density chain (filmgrain/
// printing_density.h), applied here: each layer's Status M density -> APD
// through the stock's Annex C map (none: APD = Status M) -> CDD = k (APD -
// APD_Dmin) (+ the grey timing with timing=grey) -> code value 95 + 500 CDD
// (10 bits) or 1520 + 8000 CDD (16 bits), rounded, clamped to [0, 1023] or
// [0, 65535] (the clamped values are counted) and stored / 1023 or / 65535,
// as OCIO's ADX10 / ADX16 colour spaces read them. D-min is each layer's
// expected density at zero exposure (base + fog); R, G, B are the layers
// named R, G, B (a one-layer stock: R = G = B).
//
#pragma once

#include <OpenImageIO/half.h>

#include <OpenImageIO/imagebuf.h>

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "filmgrain/expected_curve.h"
#include "filmgrain/imagebufalgo_filmgrain.h"
#include "filmgrain/printing_density.h"
#include "filmgrain/regrain.h"
#include "filmgrain/status.h"
#include "filmgrain/stock.h"
#include "output_kind.h"

namespace filmgrain::cli {

// --- ADX -------------------------------------------------------------------

/// The core's encoding of OutputKind::adx10 or adx16 (others: adx16's).
AdxEncoding adx_encoding(OutputKind kind);

// --- The CLI's adapter -----------------------------------------------------

/// What --filmgrain:output= and its options ask for.
struct OutputRequest {
    OutputKind kind = OutputKind::density;
    /// --colorconfig (empty: $OCIO, else the embedded config).
    std::string colorconfig;
    /// --ocolorspace (regrain only; empty: the config's scene_linear).
    std::string ocolorspace;
    /// Regrain's expected curves, shared by the frames of one run: they
    /// depend on the stock, the exposure and the shutter, never on the seed
    /// or the frame, and take seconds to build. Null: built for this call
    /// only; else filled by the first call and reused by the next.
    std::shared_ptr<std::vector<ExpectedCurve>> curves_cache;
    /// `timing=` (ADX only; off: the standard encoding; grey: printer
    /// lights that put the stock's 18% grey on CDD 0.70, MODEL.md 11).
    AdxTiming timing = AdxTiming::off;
    /// ADX's transform, shared by the frames of one run as curves_cache
    /// (it depends on the stock, the shutter and the timing). Null: built
    /// for this call only; else filled by the first call and reused.
    std::shared_ptr<std::optional<AdxTransform>> adx_cache;
};

/// What apply_output did.
struct OutputReport {
    /// The colour space the output is in ("" for density).
    std::string colorspace;
    /// ADX: the transform applied (D-min, map, gains, timing); regrain:
    /// unset.
    std::optional<AdxTransform> adx;
    /// ADX: code values clamped to the range (non-finite densities too).
    uint64_t clamped_values = 0;
    /// Messages for the user (warnings), already worded.
    std::vector<std::string> warnings;
};

/// Turns the operator's density image into the requested output.
/// density: the operator's dst (one float channel per layer, full window =
///   the scan, data window = the roi). out: receives the output (may be the
///   same ImageBuf as density). scene_linear_input: the operator's src (1
///   or >= 3 channels, scene-linear; regrain reads the pixel under each
///   scan pixel and needs the scan at the input frame's size).
/// Metadata added to out: filmgrain:output (the kind's name),
/// filmgrain:quantity (what the values mean), and for adx / regrain
/// filmgrain:colorspace and oiio:ColorSpace (the config's ADX10 / ADX16,
/// or --ocolorspace resolved); for adx (MODEL.md 11)
/// filmgrain:printing_density ("annex_c": the stock's Status M -> APD map;
/// "status_m (no map)": APD = Status M), filmgrain:adx_dmin (Status M D-min
/// per channel, "R x, G y, B z"), filmgrain:apd_dmin (the same in APD),
/// filmgrain:adx_gains (k) and filmgrain:adx_timing ("off", or "grey: R t,
/// G t, B t", the CDD added per channel). timing=grey with any other output
/// is an error.
/// Errors name the offending value (stock layers, colour space, sizes).
Status apply_output(const OutputRequest& request, const FilmgrainOptions& opts,
                    const OIIO::ImageBuf& scene_linear_input, const OIIO::ImageBuf& density,
                    OIIO::ImageBuf& out, OutputReport& report);

}  // namespace filmgrain::cli
