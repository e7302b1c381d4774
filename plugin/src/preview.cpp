// filmgrain CLI: the preview positive (preview.h).
#include "preview.h"

#include <algorithm>
#include <cmath>

namespace filmgrain::cli {

std::vector<int> preview_layers(const std::vector<std::string>& names)
{
    const auto find = [&](const char* n) {
        const auto it = std::find(names.begin(), names.end(), n);
        return it == names.end() ? -1 : static_cast<int>(it - names.begin());
    };
    const int r = find("R"), g = find("G"), b = find("B");
    if (r >= 0 && g >= 0 && b >= 0)
        return { r, g, b };
    if (names.size() >= 3)
        return { 0, 1, 2 };
    return { 0 };
}

double quantile(std::vector<float> values, double q)
{
    values.erase(std::remove_if(values.begin(), values.end(),
                                [](float v) { return !std::isfinite(v); }),
                 values.end());
    if (values.empty())
        return 0.0;
    q              = std::clamp(q, 0.0, 1.0);
    const size_t k = static_cast<size_t>(std::floor(q * static_cast<double>(values.size() - 1)));
    std::nth_element(values.begin(), values.begin() + static_cast<long>(k), values.end());
    return values[k];
}

Preview make_preview(const float* density, int64_t width, int64_t height,
                     const std::vector<std::string>& layer_names, double base_density)
{
    Preview out;
    const std::vector<int> layers = preview_layers(layer_names);
    const size_t nl               = layer_names.size();
    const size_t npix             = static_cast<size_t>(width) * static_cast<size_t>(height);
    out.width                     = width;
    out.height                    = height;
    out.channels                  = static_cast<int>(layers.size());
    out.pixels.assign(npix * layers.size(), 0);

    // Densities are floats: compare them with the base as stored, so that
    // an unexposed film (every D == base) maps to black, not to noise.
    const double base  = static_cast<float>(base_density);
    const double d_hi  = quantile(std::vector<float>(density, density + npix * nl),
                                  kPreviewWhiteQuantile);
    const double range = d_hi - base;
    if (!(range > 0.0))
        return out;
    for (size_t i = 0; i < npix; ++i)
        for (size_t c = 0; c < layers.size(); ++c) {
            const double d = density[i * nl + static_cast<size_t>(layers[c])];
            double p       = std::isfinite(d) ? (d - base) / range : 0.0;
            p              = std::clamp(p, 0.0, 1.0);
            out.pixels[i * layers.size() + c]
                = static_cast<uint8_t>(std::lround(255.0 * std::pow(p, 1.0 / kPreviewGamma)));
        }
    return out;
}

}  // namespace filmgrain::cli
