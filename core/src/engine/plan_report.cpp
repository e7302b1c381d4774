// What a plan says (--stats: path, reason; plan_context.h): each layer's
// path in the modifiers' words and the whole of its reason, from the
// choices engine_plan.cpp and plan_tables.cpp made.
#include "engine/plan_context.h"

#include "kernels/grain_kernel.h"
#include "model/dye.h"
#include "model/light_spread.h"

namespace filmgrain::planning {

namespace {

/// The path and reason of what acts before the grains: light spread,
/// inhibition, a dye image.
void describe_layer_image(const PlanContext& c, size_t l, const LayerPlan& plan,
                          const InhibitionPlan& inhibition, std::ostringstream& path,
                          std::ostringstream& why)
{
    const Layer& layer = c.stock.layers[l];
    if (plan.spread) {
        path << "spread=fft ";
        why << "exposure spread (MODEL.md 9: scatter " << format_g(layer.scatter) << " sigma "
            << format_g(layer.scatter_sigma_um) << " um, halation " << format_g(layer.halation)
            << " " << halation_kernel_name(layer.halation_kernel);
        if (layer.halation_kernel == HalationKernel::base)
            why << " (a " << format_g(c.stock.base_thickness_um) << " um base of index "
                << format_g(c.stock.base_refractive_index) << ", rear face "
                << rear_face_name(c.stock.rear_face) << ", reach "
                << format_g(layer_halation(c.stock, layer).reach_um()) << " um)";
        else
            why << " radius " << format_g(layer.halation_radius_um) << " um";
        why << ") over the whole frame, by its exact mean over each input pixel; ";
    }
    if (plan.inhibition) {
        path << "inhibition ";
        why << "development inhibited (MODEL.md 10: inhibitor diffusion "
            << format_g(c.stock.inhibitor_diffusion_um)
            << " um; expected densities from the expected curves, error of the log factor <= "
            << format_g(inhibition.error) << "); ";
    }
    if (layer.image == LayerImage::dye) {
        // MODEL.md 8: per grain, the mean of 10^-D over each pixel; at
        // pixel scale, the clouds' blocking area and overlap.
        path << "image=dye";
        why << "dye clouds (MODEL.md 8: " << cloud_profile_name(layer.cloud_profile)
            << ", diameter ratio " << format_g(layer.cloud_diameter_ratio) << ", density "
            << format_g(layer.cloud_density) << "): ";
        std::string limited;  // docs/model.md: coupler-limited populations
        for (size_t p = 0; p < layer.populations.size(); ++p)
            if (layer.populations[p].coupler_limited())
                limited += (limited.empty() ? "" : ", ") + std::to_string(p) + " at "
                           + format_g(layer.populations[p].max_dye_density);
        if (!limited.empty())
            why << "coupler-limited populations " << limited
                << " (their clouds fill to that density, docs/model.md); ";
        if (plan.dye_samples > 0) {
            path << ":" << plan.dye_samples;
            why << "10^-D "
                << (layer.cloud_profile == CloudProfile::disc ? "exact along " : "sampled at ")
                << plan.dye_samples
                << (layer.cloud_profile == CloudProfile::disc
                        ? " rows"
                        : "x" + std::to_string(plan.dye_samples) + " points")
                << " per pixel (per-pixel density error measured in core "
                   "Dye.SamplingConverges, not in the error estimate); ";
        } else {
            why << "their blocking area and overlap in the pixel statistics; ";
        }
        path << " ";
    }
}

/// The path and reason of the per-grain pipeline: kinetics, grains,
/// exposure and coverage.
void describe_grain_path(const PlanContext& c, const LayerPlan& plan, std::ostringstream& path,
                         std::ostringstream& why)
{
    path << "kinetics=";
    for (size_t p = 0; p < plan.populations.size(); ++p)
        path << (p ? "," : "") << kinetics_method_name(plan.populations[p].kinetics);
    const ExposureMethod exposure = plan.populations.front().exposure;
    const bool mixed = std::any_of(plan.populations.begin(), plan.populations.end(),
                                   [&](const PopulationPlan& pp) { return pp.exposure != exposure; });
    if (plan.populations.front().fast)
        path << " grains=fast";
    if (!plan.unlit) {  // a layer no light reaches reads no exposure
        path << " photons=";  // the modifier that chooses it
        if (mixed)  // per population, as kinetics
            for (size_t p = 0; p < plan.populations.size(); ++p)
                path << (p ? "," : "") << exposure_method_name(plan.populations[p].exposure);
        else
            path << exposure_method_name(exposure);
    }
    if (plan.dye_samples == 0)  // a dye layer's image is above, not a coverage
        path << " coverage=" << coverage_method_name(plan.coverage);
    if (plan.dye_samples == 0
        && (plan.coverage == CoverageMethod::scanline || plan.coverage == CoverageMethod::raster))
        path << " samples=" << plan.coverage_samples;
    if (c.exact) {
        why << "the reference engine: every photon, each chain until its grain is decided, "
            << (plan.dye_samples > 0 ? "the dye image as above" : "exact coverage");
        return;
    }
    // A layer no light reaches reads no exposure.
    if (!plan.unlit && (exposure == ExposureMethod::centre || mixed))
        why << "exposure sampled at grain centres"
            << (mixed ? " for the populations above marked so" : "")
            << " (error at image edges, measured in docs/); ";
    if (!plan.unlit && exposure == ExposureMethod::disc
        && std::any_of(plan.populations.begin(), plan.populations.end(),
                       [](const PopulationPlan& pp) { return pp.fast != nullptr; }))
        why << "exposure integrated over each grain's disc (the kernel's: segment "
               "areas tabulated to "
            << format_g(SegmentTable::shared().max_error()) << " of r^2, float exposure values); ";
    if (plan.coverage == CoverageMethod::scanline)
        why << "coverage on " << plan.coverage_samples
            << " sub-scanlines per pixel row (unbiased in the mean transmittance, noisy "
               "per pixel); ";
    if (plan.coverage == CoverageMethod::raster)
        why << "coverage at 64x" << plan.coverage_samples
            << " points per pixel (unbiased in the mean transmittance, noisy per pixel: "
               "its bias of the mean of pixel densities, modelled from docs/performance, "
               "is in the error estimate); ";
    why << "error estimate = patch-mean density bias bound at 2 sigma from the tables, "
           "plus the raster's modelled bias";
}

}  // namespace

/// Every layer's path and the whole of its reason.
void describe(const PlanContext& c, const InhibitionPlan& inhibition, std::vector<LayerPlan>& out)
{
    for (size_t l = 0; l < out.size(); ++l) {
        LayerPlan& plan = out[l];
        std::ostringstream path, why;
        describe_layer_image(c, l, plan, inhibition, path, why);
        if (plan.pixel_model) {
            // Each pixel's exposure is its input pixel's mean: no photons=.
            path << (plan.unlit ? "scale=pixel kinetics=fog" : "scale=pixel kinetics=curve");
            plan.path   = path.str();
            plan.reason = why.str() + plan.reason;
            continue;
        }
        describe_grain_path(c, plan, path, why);
        plan.path = path.str();
        plan.reason += why.str();
    }
}

}  // namespace filmgrain::planning
