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
        const bool direct = spread_method(c.spread_asked(), layer_halation(c.stock, layer).on())
                            == SpreadMethod::direct;
        path << (direct ? "spread=direct " : "spread=fft ");
        why << "exposure spread (MODEL.md 9: scatter " << format_g(layer.scatter) << " sigma "
            << format_g(layer.scatter_sigma_um) << " um, halation " << format_g(layer.halation)
            << " " << name_of(layer.halation_kernel);
        if (layer.halation_kernel == HalationKernel::base)
            why << " (a " << format_g(c.stock.base_thickness_um) << " um base of index "
                << format_g(c.stock.base_refractive_index) << ", rear face "
                << name_of(c.stock.rear_face) << ", reach "
                << format_g(layer_halation(c.stock, layer).reach_um()) << " um)";
        else
            why << " radius " << format_g(layer.halation_radius_um) << " um";
        why << ") over the whole frame, by its exact mean over each input pixel ("
            << (direct ? "a separable convolution" : "an FFT convolution") << "); ";
    }
    if (plan.inhibition) {
        path << "inhibition ";
        why << "development inhibited (MODEL.md 10: inhibitor diffusion "
            << format_g(c.stock.inhibitor_diffusion_um) << " um, "
            << (c.spread_asked() == SpreadMethod::direct ? "a separable convolution"
                                                         : "an FFT convolution")
            << "; expected densities from the expected curves, error of the log factor <= "
            << format_g(inhibition.error) << "); ";
    }
    if (layer.image == LayerImage::dye) {
        // MODEL.md 8: per grain, the mean of 10^-D over each pixel; at
        // pixel scale, the clouds' blocking area and overlap.
        path << "image=dye";
        why << "dye clouds (MODEL.md 8: " << name_of(layer.cloud_profile)
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
        path << (p ? "," : "") << name_of(plan.populations[p].kinetics);
    const ExposureMethod exposure = plan.populations.front().exposure;
    const bool mixed = std::any_of(plan.populations.begin(), plan.populations.end(),
                                   [&](const PopulationPlan& pp) { return pp.exposure != exposure; });
    if (plan.populations.front().fast)
        path << " grains=fast";
    if (!plan.unlit) {  // a layer no light reaches reads no exposure
        path << " photons=";  // the modifier that chooses it
        if (mixed)  // per population, as kinetics
            for (size_t p = 0; p < plan.populations.size(); ++p)
                path << (p ? "," : "") << name_of(plan.populations[p].exposure);
        else
            path << name_of(exposure);
    }
    if (plan.dye_samples == 0)  // a dye layer's image is above, not a coverage
        path << " coverage=" << name_of(plan.coverage);
    if (plan.dye_samples == 0
        && (plan.coverage == CoverageMethod::scanline || plan.coverage == CoverageMethod::raster))
        path << " samples=" << plan.coverage_samples;
    if (plan.pixel_model)  // the pixel scale where pixels develop enough
        path << " scale=" << name_of(ScaleMethod::mixed);
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

/// What the choosers found (plan.notes), in the order they found it:
/// kinetics per population, fog alone, the scale.
void describe_notes(const PlanContext& c, const Layer& layer, const LayerPlan& plan,
                    std::ostringstream& why)
{
    using Kind = PlanNotes::Kinetics::Kind;
    for (const PlanNotes::Kinetics& k : plan.notes.kinetics) {
        why << "population " << k.population;
        if (k.kind == Kind::size_dependent) {
            why << ": rate_area_exponent != 0 makes P(develop|N) depend on grain size, "
                   "so no table: the chain runs until each outcome is decided; ";
            continue;
        }
        if (k.kind == Kind::table_refused) {
            why << ": a table of P(develop|N) would cost more chain steps than the ~"
                << format_g(k.grain_steps)
                << " its grains need (their chains and the per-grain work a table saves): "
                   "the chain runs until each outcome is decided; ";
            continue;
        }
        const PopulationPlan& pp = plan.populations[k.population];
        why << ": P(develop|N) tabulated for N <= " << pp.table->max_photons() << " (table "
            << k.table << ": " << pp.table->node_count() << " nodes, "
            << pp.table->total_runs() << " chain runs, largest node error "
            << format_g(pp.table->max_standard_error()) << ", interpolation "
            << format_g(pp.table->max_interpolation_error()) << ")"
            << (k.capped ? "; brighter grains run the chain" : "");
        if (pp.curve)
            why << "; folded into P(develop|mean photons) for means <= "
                << format_g(pp.curve->lambda_max()) << " (" << pp.curve->node_count()
                << " nodes, interpolation error " << format_g(pp.curve->max_interpolation_error())
                << "; radii from tabulated quantiles: relative error of the mean area "
                << format_g(pp.fast->mean_area_relative_error()) << ")";
        if (pp.curve && pp.fast && (!plan.pixel_model || plan.min_developed_per_pixel > 0.0)
            && !plan.notes.fog_alone)
            why << "; a grain whose uniform cannot reach the curve's bound at the brightest "
                   "pixel its disc can touch cannot develop: counted, not positioned (the same "
                   "grains develop)";
        why << "; ";
    }
    if (plan.notes.fog_alone)
        why << "no light reaches the layer (every exposure value the render reads is 0; NaN and "
               "negative values expose nothing): its grains develop by fog alone, P = f = "
            << format_g(c.development.fog_probability())
            << " each (MODEL.md 4), so only the developed ones are generated, the grain process "
               "thinned to f (exact in distribution); ";
    if (const auto& u = plan.notes.unlit_scale)
        why << "whole scan estimated " << format_g(u->grain_s) << " s grain by grain (the "
            << "fog's grains), " << format_g(u->pixel_s) << " s at pixel scale (with its "
            << "model's build): "
            << (u->grain_s <= u->pixel_s
                    ? "grain by grain; "
                    : "the pixel scale where its statistics describe the layer; ");
    if (plan.pixel_model && plan.min_developed_per_pixel > 0.0)
        why << "pixel scale where a pixel's expected developed grains (at its exposure and log "
               "factor) reach "
            << format_g(plan.min_developed_per_pixel) << ", grain by grain elsewhere; ";
    if (const auto& px = plan.notes.pixel_scale) {
        const PixelModel& pm = *plan.pixel_model;
        why << "pixel scale: " << (layer.image == LayerImage::dye ? "dye clouds" : "grains")
            << " in " << format_g(px->pitch_um) << " um pixels, " << format_g(px->fog_grains)
            << " developed per pixel at zero exposure; pixel statistics tabulated over exposure "
               "(interpolation error: mean "
            << format_g(pm.max_mean_error()) << ", sd " << format_g(pm.max_sd_error())
            << "), "
            << (pm.shaped()
                    ? "the law's shape sampled from " + std::to_string(pm.shapes_sampled())
                          + " windows of " + std::to_string(kShapeWindow) + "x"
                          + std::to_string(kShapeWindow)
                          + " pixels of developed grains (pixel_shape.h)"
                    : std::string("two Gamma laws (covered and open part) weighted by the mean"))
            << " through a Gaussian copula with the correlations to "
            << pm.lags()
            << " pixels each way (" << format_g(100.0 * pm.max_dropped_correlation())
            << "% of their sum beyond; its filter on " << filter_lags(pm.lags())
            << " lags, correlation error " << format_g(pm.max_copula_error()) << ")"
            << (plan.inhibition ? ", every P thinned by the inhibitors' factor at the pixel's "
                                  "centre (tabulated to log factor "
                                      + format_g(px->max_log_factor) + ")"
                                : "")
            << "; ";
    }
}

}  // namespace

/// Every layer's path and the whole of its reason.
void describe(const PlanContext& c, const InhibitionPlan& inhibition, std::vector<LayerPlan>& out)
{
    for (size_t l = 0; l < out.size(); ++l) {
        LayerPlan& plan = out[l];
        std::ostringstream notes, path, why;
        describe_notes(c, c.stock.layers[l], plan, notes);
        describe_layer_image(c, l, plan, inhibition, path, why);
        if (plan.pixel_model && plan.min_developed_per_pixel == 0.0) {
            // Each pixel's exposure is its input pixel's mean: no photons=.
            path << (plan.unlit ? "scale=pixel kinetics=fog" : "scale=pixel kinetics=curve");
            plan.path   = path.str();
            plan.reason = why.str() + notes.str();
            continue;
        }
        describe_grain_path(c, plan, path, why);
        plan.path   = path.str();
        plan.reason = notes.str() + why.str();
    }
}

}  // namespace filmgrain::planning
