// filmgrain CLI: the --filmgrain:output= transforms of the rendered negative
// (output_kind.h): Academy Density Exchange code values and the regrain
// positive. The maths runs on plain buffers (tested directly); apply_output
// is the thin OIIO/OCIO adapter the CLI calls after the operator.
//
// ADX (SMPTE ST 2065-3; the ACES ADX10 / ADX16 input transforms, ACESlib
// ADX_to_ACES): code value = 95 + 500 D (10 bits, [0, 1023]) or 1520 +
// 8000 D (16 bits, [0, 65535]), D the printing density above D-min. Here D
// is a layer's density minus that layer's expected density at zero exposure
// (base + fog: expected_curves, fog_only), R, G, B the layers named R, G, B
// (a one-layer stock: R = G = B). Code values are rounded and clamped to
// their range (the clamped values are counted) and stored / 1023 or / 65535,
// as OCIO's ADX10 / ADX16 colour spaces read them.
//
// Regrain: per layer, the density is mapped back to the layer's exposure
// value through the inverse of its expected curve, linearised at the
// input's expected transmittance T(v_in) (v_in: the layer's value of the
// input pixel times 1 + halation, what halation makes of a uniform field,
// MODEL.md 9; v_out - v_in is then divided by that gain):
//   v_out = v_in - v_in / (T(v_in) g) (T_pixel - T(v_in)),
//   g = max(gamma(v_in), kRegrainMinGammaFraction * the curve's largest
//   gamma),
// which is -(T_pixel - T(v_in)) / T'(v_in) where the curve is steep
// enough. E[T_pixel] = T(v_in) (MODEL.md 5: the curve is the patch's
// expected transmittance), so E[v_out] = v_in exactly for any gain: no
// Jensen bias, unlike the plain inverse v(D_pixel), whose mean exceeds v_in
// by about exp(0.5 (ln 10 sigma_D / gamma)^2) - 1. The RGB output is
// rgb_in + M^-1 (v_out - v_in), M the 3x3 matrix of the layers'
// sensitivities (rows in stock order); a one-layer stock adds the same
// grain to R, G and B.
#pragma once

#include <OpenImageIO/half.h>

#include <OpenImageIO/imagebuf.h>

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "filmgrain/expected_curve.h"
#include "filmgrain/imagebufalgo_filmgrain.h"
#include "filmgrain/status.h"
#include "filmgrain/stock.h"
#include "output_kind.h"

namespace filmgrain::cli {

// --- ADX -------------------------------------------------------------------

/// One ADX encoding: code value = offset + scale * D in [0, max_code].
struct AdxEncoding {
    const char* colorspace;  ///< the OCIO colour space name: "ADX10", "ADX16"
    double offset;           ///< code value of D-min
    double scale;            ///< code values per unit density
    double max_code;         ///< 1023 or 65535 (also the stored divisor)
};

/// The encoding of OutputKind::adx10 or adx16 (others: adx16's).
AdxEncoding adx_encoding(OutputKind kind);

/// The layers that give ADX's R, G and B: the layers named R, G and B, or
/// layer 0 three times for a one-layer stock. Other stocks: an error naming
/// the layers.
Status adx_layers(const std::vector<std::string>& layer_names, std::array<int, 3>& out);

/// Encodes npixels of nlayers interleaved densities into packed RGB code
/// values / max_code: rgb[3 i + c] = clamp(round(offset + scale (density[i
/// nlayers + layers[c]] - d_min[layers[c]])), 0, max_code) / max_code. A
/// non-finite density gives 0. Returns the number of values clamped
/// (non-finite ones included).
uint64_t encode_adx(const float* density, size_t npixels, int nlayers,
                    const std::array<int, 3>& layers, const std::vector<double>& d_min,
                    const AdxEncoding& enc, float* rgb);

// --- Regrain ---------------------------------------------------------------

/// Where the curve is flatter than this fraction of its steepest gamma, the
/// regrain gain is that of this gamma (the grain of a flat toe or shoulder
/// would otherwise grow without bound: there the density says almost
/// nothing about the exposure).
inline constexpr double kRegrainMinGammaFraction = 0.1;

/// What regrain needs of the stock, prepared once.
struct RegrainModel {
    std::vector<ExpectedCurve> curves;             ///< per layer (stock order)
    std::vector<std::array<double, 3>> sensitivity;  ///< per layer
    /// Per layer, Layer::uniform_field_gain: the curves' value is the
    /// exposure the grains get, after MODEL.md 9's spread, which on the
    /// local mean a pixel stands for is the input's value times this.
    std::vector<double> uniform_field_gain;
    std::vector<double> min_gamma;                 ///< per layer
    /// M^-1 (3 layers) or, for one layer, each row (1 / sum of weights).
    std::array<std::array<double, 3>, 3> to_rgb {};
};

/// Checks the stock (one or three layers, an invertible sensitivity
/// matrix) and takes its curves (expected_curves, stock order).
Status make_regrain_model(const Stock& stock, std::vector<ExpectedCurve> curves,
                          RegrainModel& out);

/// One pixel: rgb_in (scene-linear, 3 floats), its layers' densities
/// (nlayers floats) -> rgb_out (3 floats, may alias rgb_in). A non-finite
/// input or density leaves rgb_out = rgb_in.
void regrain_pixel(const RegrainModel& model, const float* rgb_in, const float* density,
                   float* rgb_out);

/// The layer's exposure value v = dot(sensitivity, rgb) as the core reads it
/// (MODEL.md 2): 0 when not finite or negative.
double layer_value(const std::array<double, 3>& sensitivity, const float* rgb);

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
};

/// What apply_output did.
struct OutputReport {
    /// The colour space the output is in ("" for density).
    std::string colorspace;
    /// ADX: per layer D-min used; regrain: unused.
    std::vector<double> d_min;
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
/// or --ocolorspace resolved), for adx filmgrain:adx_dmin (per channel).
/// Errors name the offending value (stock layers, colour space, sizes).
Status apply_output(const OutputRequest& request, const FilmgrainOptions& opts,
                    const OIIO::ImageBuf& scene_linear_input, const OIIO::ImageBuf& density,
                    OIIO::ImageBuf& out, OutputReport& report);

}  // namespace filmgrain::cli
