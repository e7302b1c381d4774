// filmgrain CLI: the preview positive (preview.h).
#include "preview.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>

#include "filmgrain/ocio.h"

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

double quantile(std::vector<double> values, double q)
{
    values.erase(std::remove_if(values.begin(), values.end(),
                                [](double v) { return !std::isfinite(v); }),
                 values.end());
    if (values.empty())
        return 0.0;
    q              = std::clamp(q, 0.0, 1.0);
    const size_t k = static_cast<size_t>(std::floor(q * static_cast<double>(values.size() - 1)));
    std::nth_element(values.begin(), values.begin() + static_cast<long>(k), values.end());
    return values[k];
}

Preview make_preview(const float* density, int64_t width, int64_t height,
                     const std::vector<std::string>& layer_names,
                     const std::vector<double>& base_densities)
{
    Preview out;
    const std::vector<int> layers = preview_layers(layer_names);
    const size_t nl               = layer_names.size();
    const size_t npix             = static_cast<size_t>(width) * static_cast<size_t>(height);
    out.width                     = width;
    out.height                    = height;
    out.channels                  = static_cast<int>(layers.size());
    out.pixels.assign(npix * layers.size(), 0);

    // Densities are floats: compare them with the bases as stored (float),
    // so that an unexposed film (every D == its layer's base) maps to
    // black, not to noise; the difference of two floats is exact in double.
    // One range for all layers (above each one's base): neutral.
    std::vector<double> above(npix * nl);
    for (size_t i = 0; i < npix; ++i)
        for (size_t l = 0; l < nl; ++l)
            above[i * nl + l] = static_cast<double>(density[i * nl + l])
                                - static_cast<double>(static_cast<float>(base_densities[l]));
    const double range = quantile(above, kPreviewWhiteQuantile);
    if (!(range > 0.0))
        return out;
    for (size_t i = 0; i < npix; ++i)
        for (size_t c = 0; c < layers.size(); ++c) {
            const double d = above[i * nl + static_cast<size_t>(layers[c])];
            double p       = std::isfinite(d) ? d / range : 0.0;
            p              = std::clamp(p, 0.0, 1.0);
            out.pixels[i * layers.size() + c]
                = static_cast<uint8_t>(std::lround(255.0 * std::pow(p, 1.0 / kPreviewGamma)));
        }
    return out;
}

Status make_film_preview(const float* density, int64_t width, int64_t height,
                         const Stock& stock, const SceneSettings& scene,
                         const std::string& colorconfig, Preview& out, std::string& warning,
                         const std::shared_ptr<std::optional<AdxTransform>>& cache)
{
    warning.clear();
    std::vector<std::string> names;
    for (const Layer& l : stock.layers)
        names.push_back(l.name);
    const auto fallback = [&](const std::string& why) {
        warning = "preview: " + why + "; the preview is a plain inversion of the density";
        std::vector<double> bases;
        for (size_t l = 0; l < stock.layers.size(); ++l)
            bases.push_back(stock.layer_base_density(l));
        out = make_preview(density, width, height, names, bases);
        return Status();
    };
    std::array<int, 3> layers {};
    if (Status s = printing_density_layers(names, layers); !s)
        return fallback(s.message());
    // ADX16 (finer code values; the preview passes them unrounded anyway),
    // else ADX10.
    AdxEncoding enc = kAdx16;
    std::string adx;
    if (Status s = ocio::find_colorspace(colorconfig, enc.colorspace, adx); !s)
        return s;
    if (adx.empty()) {
        enc = kAdx10;
        if (Status s = ocio::find_colorspace(colorconfig, enc.colorspace, adx); !s)
            return s;
    }
    if (adx.empty())
        return fallback("the OCIO config has no ADX16 or ADX10 colour space");
    std::unique_ptr<ocio::Converter> conv;
    if (Status s = ocio::Converter::create_display_view(colorconfig, adx, "", "", conv); !s)
        return Status::errorf("preview: ", s.message());

    // The timed print (MODEL.md 11), once per run.
    AdxTransform transform;
    if (cache && cache->has_value()) {
        transform = **cache;
    } else {
        AdxOptions o;
        o.timing            = AdxTiming::grey;
        o.neutral_one_layer = true;
        if (Status s = stock_adx_transform(stock, scene, o, transform); !s) {
            o.timing = AdxTiming::off;
            if (Status u = stock_adx_transform(stock, scene, o, transform); !u)
                return Status::errorf("preview: ", u.message());
            warning = "preview: not timed (" + s.message()
                      + "): the ADX encoding as it is, whose grey need not be neutral";
        }
        if (cache)
            *cache = transform;
    }

    const size_t npix = static_cast<size_t>(width) * static_cast<size_t>(height);
    std::vector<float> rgb(npix * 3);
    encode_adx(transform, enc, density, npix, static_cast<int>(names.size()), false, rgb.data());
    conv->apply_rgb(rgb.data(), npix);
    out          = Preview();
    out.width    = width;
    out.height   = height;
    out.channels = 3;
    out.pixels.resize(npix * 3);
    for (size_t i = 0; i < npix * 3; ++i) {
        const float v = std::isfinite(rgb[i]) ? std::clamp(rgb[i], 0.0f, 1.0f) : 0.0f;
        out.pixels[i] = static_cast<uint8_t>(std::lround(255.0 * v));
    }
    return {};
}

}  // namespace filmgrain::cli
