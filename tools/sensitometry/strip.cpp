// Test strips and patch budgets.
#include "strip.h"

#include <algorithm>
#include <cmath>

#include "model/exposure.h"
#include "util/rng.h"

namespace filmgrain::sensitometry {

double estimated_cost_s_per_um2(const Stock& stock, double exposure_lxs, double shutter_s)
{
    const double per_photon_s = shutter_s < 1e-4 ? 2.4e-7 : 1.2e-7;
    double cost = 0.0;
    for (const Layer& layer : stock.layers) {
        double sens = 0.0;
        for (double w : layer.sensitivity)
            sens += w;
        for (const Population& pop : layer.populations) {
            const double s         = pop.diameter_log_sigma;
            const double mean_area = M_PI / 4.0 * pop.diameter_um * pop.diameter_um * std::exp(s * s);
            const double photons   = pop.quantum_efficiency * kPhotonsPerUm2PerLxs * exposure_lxs
                                   * sens * mean_area;
            cost += pop.grains_per_um2 * (0.5e-6 + per_photon_s * photons);
        }
    }
    return cost;
}

PatchSpec plan_patch(const Stock& stock, double exposure_lxs, double shutter_s,
                     const PatchBudget& budget, uint64_t seed)
{
    PatchSpec p;
    p.exposure_lxs = exposure_lxs;
    p.shutter_s    = shutter_s;
    p.seed         = seed;
    double pitch   = budget.pitch_um;
    if (pitch <= 0.0) {
        double d = 0.0;
        for (const Layer& layer : stock.layers)
            for (const Population& pop : layer.populations)
                d = std::max(d, pop.diameter_um);
        pitch = std::clamp(3.5 * d, 6.0, 25.0);
    }
    const double area = std::clamp(budget.max_cost_s
                                       / estimated_cost_s_per_um2(stock, exposure_lxs, shutter_s),
                                   budget.min_area_um2, budget.max_area_um2);
    // A whole number of pixels, divisible into the 4 x 4 batch-means blocks.
    const double side_px = std::max(8.0, 4.0 * std::round(std::sqrt(area) / pitch / 4.0));
    p.pitch_um = pitch;
    p.side_um  = side_px * pitch;
    p.blocks   = 4;
    return p;
}

uint64_t patch_seed(uint64_t seed, uint64_t index) { return hash_ids(seed, 0x5e7517, index); }

Status expose_strip(const Stock& stock, const StripSpec& spec, const MeasureSettings& settings,
                    Curve& out)
{
    if (!(spec.log10_h_step > 0.0) || !(spec.log10_h_max >= spec.log10_h_min))
        return Status::errorf("strip log10 H range [", spec.log10_h_min, ", ", spec.log10_h_max,
                              "] step ", spec.log10_h_step, ": need max >= min, step > 0");
    out            = Curve {};
    out.shutter_s  = spec.shutter_s;
    out.engine     = name_of(settings.engine);
    out.layers.resize(stock.layers.size());
    // Base + fog: an unexposed patch (no photons: cheap, so large).
    PatchSpec fog = plan_patch(stock, 0.0, spec.shutter_s, spec.budget, patch_seed(spec.seed, 0));
    // Unexposed grains cost little, but a dense multilayer stock still has
    // many: at most four patch budgets.
    const double fog_area = std::min(spec.fog_area_um2,
                                     4.0 * spec.budget.max_cost_s
                                         / estimated_cost_s_per_um2(stock, 0.0, spec.shutter_s));
    const double fog_side_px = std::max(8.0, 4.0 * std::round(std::sqrt(fog_area) / fog.pitch_um / 4.0));
    fog.side_um = fog_side_px * fog.pitch_um;
    PatchReading r;
    if (Status s = expose_patch(stock, fog, settings, r); !s)
        return s;
    out.seconds += r.seconds;
    out.engine = r.engine;
    for (size_t l = 0; l < r.layers.size(); ++l) {
        out.layers[l].name           = r.layers[l].name;
        out.layers[l].fog_density    = r.layers[l].density;
        out.layers[l].fog_density_se = r.layers[l].density_se;
        out.clamped_pixels += r.layers[l].clamped_pixels;
        out.clamp_density_bound = std::max(out.clamp_density_bound, r.layers[l].clamp_density_bound);
    }
    const int n = static_cast<int>(std::floor((spec.log10_h_max - spec.log10_h_min) / spec.log10_h_step + 1e-9)) + 1;
    for (int i = 0; i < n; ++i) {
        const double log10_h = spec.log10_h_min + i * spec.log10_h_step;
        const PatchSpec p = plan_patch(stock, std::pow(10.0, log10_h), spec.shutter_s,
                                       spec.budget, patch_seed(spec.seed, static_cast<uint64_t>(i + 1)));
        if (Status s = expose_patch(stock, p, settings, r); !s)
            return s;
        out.seconds += r.seconds;
        out.area_um2.push_back(p.side_um * p.side_um);
        for (size_t l = 0; l < r.layers.size(); ++l) {
            out.layers[l].log10_h.push_back(std::log10(r.layers[l].exposure_lxs));
            out.layers[l].density.push_back(r.layers[l].density);
            out.layers[l].density_se.push_back(r.layers[l].density_se);
            out.clamped_pixels += r.layers[l].clamped_pixels;
            out.clamp_density_bound = std::max(out.clamp_density_bound, r.layers[l].clamp_density_bound);
        }
    }
    return {};
}

}  // namespace filmgrain::sensitometry
