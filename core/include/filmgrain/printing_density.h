// filmgrain: reading the negative as a printer does (MODEL.md 11): Status M
// densities -> Academy Printing Density (APD, SMPTE ST 2065-2) -> ADX code
// values (SMPTE ST 2065-3; A.M.P.A.S. S-2008-002 v1.1), and the timing
// (printer lights) that puts a stock's own grey card on ADX's grey.
//
// Plain functions on densities and packed float buffers: no OpenImageIO,
// no OpenColorIO. The CLI's output=adx10|adx16 and its --preview, the Python
// module (through the CLI's output transform) and studio tools share them.
//
// The chain, per pixel, for the layers named R, G and B (channel c):
//   APD    = M * StM + o          (the stock's Annex C map; none: APD = StM)
//   CDD_c  = k_c (APD_c - APD_Dmin_c) + t_c
//          = k_c (M (StM - StM_Dmin))_c + t_c   (o cancels: ADX is relative)
//   ADX10  = 95 + 500 CDD,  ADX16 = 1520 + 8000 CDD   (S-2008-002 eq. 1)
// k = kAdxGains; StM_Dmin = each layer's expected density at zero exposure
// (base + fog: ExpectedCurve::min_density); t = 0 (the standard encoding)
// or the grey timing: t_c = 0.70 - k_c (APD_grey - APD_Dmin)_c, APD_grey the
// stock's expected densities on a neutral 18% grey card, mapped.
//
// Not done: the spectral route (S-2008-002 eq. 6 and Annex A: the dyes'
// spectral densities and the D-min spectrum integrated against the APD
// responsivities). No datasheet here gives dye spectra; a stock with no
// Annex C map reads APD = Status M.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "filmgrain/render.h"
#include "filmgrain/status.h"
#include "filmgrain/stock.h"

namespace filmgrain {

/// Three densities (or gains), channels R, G, B.
using Density3 = std::array<double, 3>;

/// APD = matrix * status_m + offset (absolute densities, MODEL.md 11).
/// Pure; any finite input.
Density3 status_m_to_apd(const StatusMToApd& map, const Density3& status_m);

/// ADX's per-channel gains k (SMPTE ST 2065-3; S-2008-002 eq. 1): CDD =
/// k (APD - APD_Dmin), channels R, G, B.
inline constexpr Density3 kAdxGains = { 1.00, 0.92, 0.95 };

/// The channel dependent density (CDD) that ACES's ADX input transform reads
/// as scene-linear 0.18 in every channel: ADX16 7120, ADX10 445.
inline constexpr double kAdxGreyCdd = 0.70;

/// One ADX encoding: code value = offset + scale * CDD, in [0, max_code],
/// stored as code value / max_code (what OCIO's ADX10 / ADX16 colour spaces
/// read).
struct AdxEncoding {
    const char* colorspace;  ///< the OCIO colour space name: "ADX10", "ADX16"
    double offset;           ///< code value of CDD 0 (D-min)
    double scale;            ///< code values per unit density
    double max_code;         ///< 1023 or 65535 (also the stored divisor)
};
inline constexpr AdxEncoding kAdx10 = { "ADX10", 95.0, 500.0, 1023.0 };
inline constexpr AdxEncoding kAdx16 = { "ADX16", 1520.0, 8000.0, 65535.0 };

/// offset + scale * cdd, not rounded. Pure.
inline double adx_code_value(const AdxEncoding& enc, double cdd)
{
    return enc.offset + enc.scale * cdd;
}

/// Printer lights (MODEL.md 11): none (the standard ADX encoding), or
/// per-channel offsets that put the stock's own 18% grey on CDD 0.70.
enum class AdxTiming { off, grey };

inline constexpr Named<AdxTiming> kAdxTimingNames[] = { { AdxTiming::off, "off" },
                                                       { AdxTiming::grey, "grey" } };
constexpr const auto& names_of(AdxTiming) { return kAdxTimingNames; }

/// The layers that give R, G and B: the layers named R, G and B, or layer
/// 0 three times for a one-layer stock. Other stocks: an error naming the
/// layers.
Status printing_density_layers(const std::vector<std::string>& layer_names,
                               std::array<int, 3>& out);

/// What ADX makes of one stock's densities, prepared once; cdd() and
/// encode_adx() then run it per pixel.
/// Thread safety: a value type; const members may be called concurrently.
struct AdxTransform {
    /// The stock's layers giving R, G, B (printing_density_layers).
    std::array<int, 3> layers = { 0, 1, 2 };
    /// Whether the stock has a Status M -> APD map (else APD = Status M).
    bool has_map = false;
    /// The map (identity matrix, zero offset without one).
    StatusMToApd map = { { { { 1.0, 0.0, 0.0 }, { 0.0, 1.0, 0.0 }, { 0.0, 0.0, 1.0 } } },
                         { 0.0, 0.0, 0.0 } };
    /// D-min of the layers R, G, B (Status M, base + fog).
    Density3 status_m_dmin = { 0.0, 0.0, 0.0 };
    /// status_m_to_apd(map, status_m_dmin).
    Density3 apd_dmin = { 0.0, 0.0, 0.0 };
    /// k: kAdxGains, or (1, 1, 1) where asked for (AdxOptions::neutral_one_layer).
    Density3 gains = kAdxGains;
    AdxTiming timing = AdxTiming::off;
    /// With timing grey: the stock's expected Status M densities of its 18%
    /// grey card (R, G, B); else 0.
    Density3 status_m_grey = { 0.0, 0.0, 0.0 };
    /// Added to every CDD (t); 0 without timing.
    Density3 timing_cdd = { 0.0, 0.0, 0.0 };

    /// CDD of absolute Status M densities of R, G, B: k (M (d - dmin)) + t
    /// (without a map: k (d - dmin) + t, channel by channel).
    Density3 cdd(const Density3& status_m) const;
};

/// The transform from given densities (pure; the unit tests' entry).
/// map: the stock's, or null (APD = Status M). status_m_grey: null for no
/// timing; else the grey card's Status M densities, and timing_cdd = 0.70 -
/// the untimed CDD of the grey (channel by channel).
AdxTransform make_adx_transform(const StatusMToApd* map, const std::array<int, 3>& layers,
                                const Density3& status_m_dmin, const Density3& gains,
                                const Density3* status_m_grey);

/// Options of stock_adx_transform.
struct AdxOptions {
    AdxTiming timing = AdxTiming::off;
    /// A one-layer (silver) stock with gains (1, 1, 1) instead of kAdxGains,
    /// so that its neutral densities stay neutral through ACES (the
    /// preview). False: ADX's own gains (output=adx: what an ADX scanner
    /// writes of a silver negative, whose APD is the same in R, G and B).
    bool neutral_one_layer = false;
    /// Worker threads for the expected curves (0: all).
    int nthreads = 0;
    /// Optional: set by another thread to stop the curves' build.
    const std::atomic<bool>* cancel = nullptr;
};

/// The stock's transform: its R, G, B layers, its map, D-min from the
/// expected curves at v = 0 (fog only: exact, cheap), and with timing grey
/// the expected densities of a neutral 18% grey card on a large uniform
/// field: each layer's curve at 0.18 * Layer::neutral_weight() (its
/// sensitivities' sum times the halation's uniform-field gain; inhibition
/// of a neutral patch included, MODEL.md 10), at the scene's shutter and
/// exposure offset 0 (the lab times the stock, not the frame: an exposure
/// offset still shows). Timing builds the full curves: about 3 s per
/// distinct set of rates on one core (less when the P(develop | N) tables
/// are in the disk cache). Errors: the stock's layers (printing_density_
/// layers), expected_curves' errors (e.g. rate_area_exponent != 0 with
/// timing). Thread safety: reentrant.
Status stock_adx_transform(const Stock& stock, const SceneSettings& scene,
                           const AdxOptions& options, AdxTransform& out);

/// Encodes npixels of nlayers interleaved Status M densities into packed
/// R, G, B code values / enc.max_code: code = offset + scale * cdd (the
/// transform's). round: code values rounded to integers and clamped to
/// [0, max_code] (an ADX file); else left as they are (a preview that goes
/// on in float). A non-finite code value is stored as 0: a non-finite
/// density makes its own channel's, and with a map (which mixes the
/// channels) all three. Returns the number of values clamped, non-finite
/// ones included (round only).
uint64_t encode_adx(const AdxTransform& transform, const AdxEncoding& enc,
                    const float* density, size_t npixels, int nlayers, bool round,
                    float* rgb);

/// The metadata words for the outputs: "annex_c" when the stock has a map,
/// else "status_m (no map)".
std::string printing_density_source(const AdxTransform& transform);

}  // namespace filmgrain
