// Printing density and ADX (MODEL.md 11; filmgrain/printing_density.h).
#include "filmgrain/printing_density.h"

#include <algorithm>
#include <cmath>

#include "filmgrain/expected_curve.h"

namespace filmgrain {

Density3 status_m_to_apd(const StatusMToApd& map, const Density3& d)
{
    Density3 apd {};
    for (size_t r = 0; r < 3; ++r)
        apd[r] = map.matrix[r][0] * d[0] + map.matrix[r][1] * d[1] + map.matrix[r][2] * d[2]
                 + map.offset[r];
    return apd;
}

Status printing_density_layers(const std::vector<std::string>& names, std::array<int, 3>& out)
{
    if (names.size() == 1) {
        out = { 0, 0, 0 };
        return {};
    }
    const char* rgb[3] = { "R", "G", "B" };
    std::array<int, 3> found {};
    for (size_t c = 0; c < 3; ++c) {
        const auto it = std::find(names.begin(), names.end(), rgb[c]);
        if (it == names.end()) {
            std::string list;
            for (const std::string& n : names)
                list += (list.empty() ? "" : ", ") + n;
            return Status::errorf("ADX needs the layers named R, G and B (the red-, green- and "
                                  "blue-sensitive layers, whose densities stand for the "
                                  "printing densities) or a single layer; the stock's layers "
                                  "are ", list, " (no layer ", rgb[c], ")");
        }
        found[c] = static_cast<int>(it - names.begin());
    }
    out = found;
    return {};
}

Density3 AdxTransform::cdd(const Density3& d) const
{
    // M (d - dmin): the map's offset cancels in APD - APD_Dmin, and the
    // difference is taken before the matrix (no cancellation of the
    // absolute densities' digits).
    const Density3 above = { d[0] - status_m_dmin[0], d[1] - status_m_dmin[1],
                             d[2] - status_m_dmin[2] };
    Density3 out {};
    for (size_t c = 0; c < 3; ++c) {
        // Without a map each channel is its own layer's (a non-finite
        // density stays in its channel); a map mixes them.
        const double apd = has_map ? map.matrix[c][0] * above[0] + map.matrix[c][1] * above[1]
                                         + map.matrix[c][2] * above[2]
                                   : above[c];
        out[c] = gains[c] * apd + timing_cdd[c];
    }
    return out;
}

AdxTransform make_adx_transform(const StatusMToApd* map, const std::array<int, 3>& layers,
                                const Density3& status_m_dmin, const Density3& gains,
                                const Density3* status_m_grey)
{
    AdxTransform t;
    t.layers  = layers;
    t.has_map = map != nullptr;
    if (map)
        t.map = *map;
    t.status_m_dmin = status_m_dmin;
    t.apd_dmin      = status_m_to_apd(t.map, status_m_dmin);
    t.gains         = gains;
    if (status_m_grey) {
        t.timing        = AdxTiming::grey;
        t.status_m_grey = *status_m_grey;
        const Density3 untimed = t.cdd(*status_m_grey);  // timing_cdd is 0 here
        for (size_t c = 0; c < 3; ++c)
            t.timing_cdd[c] = kAdxGreyCdd - untimed[c];
    }
    return t;
}

Status stock_adx_transform(const Stock& stock, const SceneSettings& scene,
                           const AdxOptions& options, AdxTransform& out)
{
    std::vector<std::string> names;
    for (const Layer& l : stock.layers)
        names.push_back(l.name);
    std::array<int, 3> layers {};
    if (Status s = printing_density_layers(names, layers); !s)
        return s;
    const bool one_layer = stock.layers.size() == 1;
    const Density3 gains = one_layer && options.neutral_one_layer ? Density3 { 1.0, 1.0, 1.0 }
                                                                  : kAdxGains;
    const StatusMToApd* map = stock.status_m_to_apd ? &*stock.status_m_to_apd : nullptr;

    // The grey card is timed at exposure offset 0: the stock's own grey.
    SceneSettings at_grey  = scene;
    at_grey.exposure_stops = 0.0;
    ExpectedCurveOptions o;
    o.fog_only = options.timing == AdxTiming::off;  // D-min alone: no chain runs
    o.nthreads = options.nthreads;
    o.cancel   = options.cancel;
    std::vector<ExpectedCurve> curves;
    if (Status s = expected_curves(stock, at_grey, o, curves); !s)
        return s;
    Density3 dmin {}, grey {};
    for (size_t c = 0; c < 3; ++c) {
        const size_t l = static_cast<size_t>(layers[c]);
        dmin[c]        = curves[l].min_density();
        if (options.timing == AdxTiming::grey)
            grey[c] = curves[l].density_at(kGreyValue * stock.layers[l].neutral_weight());
    }
    out = make_adx_transform(map, layers, dmin, gains,
                             options.timing == AdxTiming::grey ? &grey : nullptr);
    return {};
}

uint64_t encode_adx(const AdxTransform& t, const AdxEncoding& enc, const float* density,
                    size_t npixels, int nlayers, bool round, float* rgb)
{
    uint64_t clamped = 0;
    const size_t nl  = static_cast<size_t>(nlayers);
    for (size_t i = 0; i < npixels; ++i) {
        const float* px = density + i * nl;
        const Density3 d = { px[t.layers[0]], px[t.layers[1]], px[t.layers[2]] };
        const Density3 cdd = t.cdd(d);
        for (size_t c = 0; c < 3; ++c) {
            double code = adx_code_value(enc, cdd[c]);
            if (!std::isfinite(code)) {
                code = 0.0;
                clamped += round ? 1 : 0;
            } else if (round) {
                code = std::round(code);
                if (code < 0.0 || code > enc.max_code) {
                    ++clamped;
                    code = std::clamp(code, 0.0, enc.max_code);
                }
            }
            rgb[i * 3 + c] = static_cast<float>(code / enc.max_code);
        }
    }
    return clamped;
}

std::string printing_density_source(const AdxTransform& t)
{
    return t.has_map ? "annex_c" : "status_m (no map)";
}

}  // namespace filmgrain
