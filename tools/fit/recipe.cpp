#include "recipe.h"

#include <algorithm>
#include <cstdio>
#include <map>

namespace filmgrain::fit {

namespace sm = sensitometry;

double granularity_spread_across_layers(const sm::Datasheet& sheet)
{
    if (sheet.layers.size() < 2)
        return 1.0;
    // The net densities every layer has a target at, with each layer's RMS.
    std::map<double, std::vector<double>> at;
    for (const sm::LayerTargets& l : sheet.layers)
        for (const sm::GranularityTarget& g : l.granularity)
            if (g.net)
                at[g.density].push_back(g.rms);
    for (const auto& [density, rms] : at)  // lowest density first
        if (rms.size() == sheet.layers.size())
            return *std::max_element(rms.begin(), rms.end())
                   / *std::min_element(rms.begin(), rms.end());
    return 1.0;
}

FitRecipe recipe_for(const sm::Datasheet& sheet)
{
    FitRecipe r;
    FitOptions& o = r.options;
    if (sheet.kind != "bw-negative" && sheet.kind != "colour-negative") {
        r.reasons.push_back("datasheet kind '" + sheet.kind
                            + "' has no recipe: the library's defaults");
        return r;
    }
    o.populations = 4;
    if (sheet.kind == "bw-negative") {
        o.rounds = 3;
        r.reasons.push_back("black-and-white negative: 4 silver populations a layer, 3 rounds "
                            "of (populations, rates) (Tri-X's reciprocity needs the third)");
        return r;
    }
    o.starts           = 4;
    o.population_evals = 1500;
    o.max_log_sigma    = 0.7;
    o.cloud_profile    = CloudProfile::disc;
    o.coupler_limited  = 2;
    r.reasons.push_back(
        "colour negative: 4 populations a layer of disc dye clouds, the 2 largest "
        "coupler-limited (their clouds fill: granularity that falls with density), diameter "
        "log sigma at most 0.7 (the pixel scale keeps such grains in a 4K scan), 4 starts of "
        "1500 evaluations");
    const double spread = granularity_spread_across_layers(sheet);
    char buf[160];
    if (spread >= kBigCloudGranularitySpread) {
        o.start_cloud_ratio = 2.0;
        std::snprintf(buf, sizeof buf,
                      "dye clouds start at twice their grain: one layer is %.2g times as grainy "
                      "as another at the same density (>= %.2g)",
                      spread, kBigCloudGranularitySpread);
    } else {
        std::snprintf(buf, sizeof buf,
                      "dye clouds start at their grain's size: the layers' granularities differ "
                      "at most %.2g times at the same density (< %.2g)",
                      spread, kBigCloudGranularitySpread);
    }
    r.reasons.push_back(buf);
    // VISION3's construction (docs/stocks): scatter in the emulsion, and
    // halation from a 125 um base whose rem-jet backing absorbs what
    // reaches the rear (docs/model.md, "Halation from the base").
    const struct {
        const char* layer;
        double scatter, halation;
    } kSpread[] = { { "R", 0.3, 0.02 }, { "G", 0.25, 0.004 }, { "B", 0.2, 0.0 } };
    for (const auto& s : kSpread) {
        const bool in_sheet
            = std::any_of(sheet.layers.begin(), sheet.layers.end(),
                          [&](const sm::LayerTargets& t) { return t.name == s.layer; });
        if (!in_sheet)
            continue;
        FitOptions::LayerSpread& ls = o.light_spread[s.layer];
        ls.scatter                  = s.scatter;
        ls.scatter_sigma_um         = 5.0;
        ls.halation                 = s.halation;
        if (s.halation > 0.0)
            ls.halation_kernel = HalationKernel::base;
    }
    FitOptions::FilmBase base;
    base.thickness_um     = 125.0;
    base.refractive_index = 1.48;
    base.rear_face        = RearFace::remjet;
    o.film_base           = base;
    r.reasons.push_back(
        "light spread of a motion-picture negative (no figure measures it): scatter R 0.3, "
        "G 0.25, B 0.2 (sigma 5 um), halation R 0.02, G 0.004 from a 125 um base (index "
        "1.48) with a rem-jet backing; --no-light-spread for none");
    return r;
}

}  // namespace filmgrain::fit
