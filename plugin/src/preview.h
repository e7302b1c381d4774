// filmgrain CLI: the 8-bit preview positive of a density image (--preview).
// Plain buffers in and out; no OIIO (OCIO through filmgrain/ocio.h).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "filmgrain/printing_density.h"
#include "filmgrain/render.h"
#include "filmgrain/status.h"
#include "filmgrain/stock.h"

namespace filmgrain::cli {

/// The layers shown by the preview, as indices into the layer list: three
/// (R, G, B) when layers named R, G and B exist (taken by name) or when
/// there are at least three layers (the first three, stock order); else one
/// (grey: the first layer).
std::vector<int> preview_layers(const std::vector<std::string>& layer_names);

/// The q-quantile (q in [0, 1]) of the finite values of `values` (nearest
/// rank, floor(q * (n - 1))); 0 when there are none.
double quantile(std::vector<double> values, double q);

/// The percentile of the density that maps to white.
constexpr double kPreviewWhiteQuantile = 0.999;
/// The preview's display encoding: p^(1 / kPreviewGamma).
constexpr double kPreviewGamma = 2.2;

struct Preview {
    int64_t width = 0;
    int64_t height = 0;
    int channels = 0;  ///< 1 (grey) or 3 (RGB)
    std::vector<uint8_t> pixels;  ///< packed, row-major
};

/// p = clamp((D - base) / R, 0, 1), base the layer's base density and R
/// the 99.9th percentile of D - base over all pixels of all layers (one
/// scale for every channel, so no colour shift), stored as
/// round(255 * p^(1/2.2)). If R <= 0 (an unexposed film) every pixel is 0.
/// `density` holds width x height pixels of layer_names.size() interleaved
/// floats; `base_densities` one per layer.
Preview make_preview(const float* density, int64_t width, int64_t height,
                     const std::vector<std::string>& layer_names,
                     const std::vector<double>& base_densities);

/// The preview through OCIO (--help "Preview"), a timed print of the
/// negative (MODEL.md 11): each layer's density -> ADX16 code values of the
/// stock's printing densities, timed on the stock's own 18% grey
/// (stock_adx_transform with AdxTiming::grey: grey lands on CDD 0.70, ACES
/// 0.18, in every channel; a one-layer stock with gains 1, so that silver
/// stays neutral), unrounded -> the config's ADX16 colour space (ADX10
/// when it has no ADX16) -> the config's default display and view
/// (embedded: sRGB, ACES 1.0 - SDR Video) -> round(255 clamp(x, 0, 1)).
/// colorconfig: --colorconfig (empty: $OCIO, else the embedded config).
/// Falls back to make_preview (a plain inversion) and says why in
/// `warning` when the config has neither ADX colour space or the stock's
/// layers are not R, G, B (nor one layer); to an untimed ADX preview, with
/// a warning, when the stock's grey cannot be computed (a population with
/// rate_area_exponent != 0 has no single expected curve); otherwise
/// `warning` is empty.
/// cache: null, or shared by the frames of one run (the transform depends
/// on the stock and the shutter only): filled by the first call.
/// Errors: the config cannot be loaded, a display transform fails.
/// `density` holds width x height pixels of stock.layers.size() floats.
Status make_film_preview(const float* density, int64_t width, int64_t height,
                         const Stock& stock, const SceneSettings& scene,
                         const std::string& colorconfig, Preview& out, std::string& warning,
                         const std::shared_ptr<std::optional<AdxTransform>>& cache = nullptr);

}  // namespace filmgrain::cli
