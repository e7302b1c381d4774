// filmgrain: choosing, once per render and layer, the paths a scene needs
// (OCIO's "renderer chosen once" pattern): which kinetics, exposure and
// coverage methods run, the tables they use, and the error they add.
#pragma once

#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "model/development.h"
#include "expect/develop_curve.h"
#include "model/exposure.h"
#include "filmgrain/render.h"
#include "model/geometry.h"
#include "model/inhibition.h"
#include "kernels/grain_kernel.h"
#include "model/kinetics.h"
#include "engine/kinetics_table.h"
#include "kernels/pixel_model.h"

namespace filmgrain {

/// Everything a tile needs about one population, prepared once.
struct PopulationPlan {
    PopulationGrains grains;
    /// Mean absorbed photons per (value x square micrometre):
    /// quantum_efficiency * 4.09e3 * H per unit value (MODEL.md 2).
    double photons_per_value_um2 = 0.0;
    KineticsRates rates;
    double rate_area_exponent = 0.0;
    KineticsMethod kinetics   = KineticsMethod::chain;
    ExposureMethod exposure   = ExposureMethod::disc;
    /// For KineticsMethod::table and curve; grains beyond its range use
    /// early_stop.
    std::shared_ptr<const DevelopTable> table;
    /// For KineticsMethod::curve: P(develop | mean photons) from `table`,
    /// and the fast generator of the population's grains.
    std::shared_ptr<const DevelopCurve> curve;
    std::shared_ptr<const FastGrains> fast;
};

/// Why the choosers chose a layer's paths, as they found it: the --stats
/// reason is written from these once (plan_report.cpp), with the plan.
struct PlanNotes {
    /// A population's kinetics, in the order the choosers decided them.
    struct Kinetics {
        enum class Kind {
            size_dependent,  ///< rate_area_exponent != 0: no table, the chain
            table_refused,   ///< a table would cost more than the chains
            table,           ///< tabulated (and maybe folded into a curve)
        };
        Kind kind          = Kind::table;
        size_t population  = 0;
        size_t table       = 0;      ///< table: which (the requests' order)
        bool capped        = false;  ///< table: brighter grains run the chain
        double grain_steps = 0.0;    ///< table_refused: what the grains need
    };
    std::vector<Kinetics> kinetics;
    /// No light reaches the layer: fog alone, its grains thinned to f.
    bool fog_alone = false;
    /// A layer no light reaches, its scale chosen by the whole scan's
    /// estimated seconds per path.
    struct UnlitScale {
        double grain_s = 0.0, pixel_s = 0.0;
    };
    std::optional<UnlitScale> unlit_scale;
    /// The pixel scale taken: the scan's pitch, developed grains per pixel
    /// at zero exposure, the inhibitors' largest log factor tabulated.
    struct PixelScale {
        double pitch_um = 0.0, fog_grains = 0.0, max_log_factor = 0.0;
    };
    std::optional<PixelScale> pixel_scale;
};

/// Everything a tile needs about one layer.
struct LayerPlan {
    LayerExposure exposure;
    std::vector<PopulationPlan> populations;
    CoverageMethod coverage = CoverageMethod::exact;
    int coverage_samples    = 0;
    /// Largest grain radius of the layer: how far beyond a tile its grains'
    /// centres (and so the exposure they read) may lie.
    double margin_um = 0.0;
    /// ScaleMethod::pixel: the layer's pixel statistics, and the key of its
    /// pixels' normals (no grains are generated).
    std::shared_ptr<const PixelModel> pixel_model;
    uint64_t pixel_key = 0;
    /// For the statistics: what runs, why (written from `notes`), its
    /// error bound, setup time.
    std::string path;
    std::string reason;
    PlanNotes notes;
    double error_estimate = 0.0;
    double setup_seconds  = 0.0;
    /// MODEL.md 9: the layer's spread exposure value over the whole input
    /// frame (light_spread.h), which `exposure` then views; null when the
    /// layer spreads no light (`exposure` views the input).
    std::shared_ptr<const std::vector<float>> spread;
    /// MODEL.md 10: the layer's log development factor per input pixel
    /// (inhibition.h); null when nothing inhibits the layer.
    std::shared_ptr<const FramePlane> inhibition;
    /// MODEL.md 8: how far a developed grain's image reaches in grain radii
    /// (1: silver), and for a dye layer the samples per pixel axis of its
    /// image (0: silver, whose coverage method is above).
    double image_reach = 1.0;
    int dye_samples    = 0;
    /// The seconds its tiles are estimated to take over the rendered region
    /// on the render's workers (engine/path_cost.h), for the statistics.
    double estimated_seconds = 0.0;
    /// No light reaches the layer anywhere in the region the render reads
    /// (read_region): its grains develop by fog alone (KineticsMethod::fog).
    bool unlit = false;
    /// With pixel_model (above), 0: every pixel at pixel scale. > 0
    /// (scale=mixed on a layer whose fog develops too few grains per pixel
    /// for its pixel statistics): only the pixels whose expected developed
    /// grains (the model's developed_per_pixel at the pixel's exposure and
    /// log factor) reach it are drawn from the model; the others are
    /// rendered grain by grain, with the layer's grain paths above.
    double min_developed_per_pixel = 0.0;
};

/// Empties the process's cache of pixel models (plan_layers builds a
/// layer's PixelModel once per process for the same stock, scene and scan;
/// frames of a sequence share it). Returns how many it held. For tests.
size_t clear_pixel_model_cache();

/// Decides the paths for every layer and builds what they need. `roi` is
/// the scan region that will be rendered (tables cover the photon counts
/// the input region under it can produce). `cancel` (optional), set by
/// another thread: the plan stops within a table batch, a frame row or
/// between its steps (a transform of light spread or inhibitor diffusion
/// takes ~0.5 s at 4K) and returns the error "render cancelled".
Status plan_layers(const Stock& stock, const SceneSettings& scene, const ImageView& input,
                   const FrameGeometry& frame, const Roi& roi, const RenderSettings& settings,
                   std::vector<LayerPlan>& out, const std::atomic<bool>* cancel = nullptr);

/// The input pixel rectangle [x0, x1) x [y0, y1) that a render of `roi`
/// reads: the ROI's film rectangle grown by `margin_um`, clipped.
struct InputRegion {
    int64_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};
InputRegion input_region(const ImageView& input, const FrameGeometry& frame, const Roi& roi,
                         double margin_um);

/// The input pixels a render of `roi` reads: the ROI's film rectangle
/// grown by the largest grain's diameter (a grain that touches the ROI
/// integrates its exposure over its disc), or the whole frame when a layer
/// spreads light or inhibition acts (MODEL.md 9, 10: the spread exposure
/// and the blurred densities are computed over the whole frame, so that a
/// ROI reads exactly the values a full render does). With the scene
/// continued beyond the image (scene.edge clamp) it holds at least the
/// image pixels nearest the ROI. The planner's choices that look at the
/// pixels (whether light reaches a layer) look at these.
InputRegion read_region(const Stock& stock, const SceneSettings& scene, const ImageView& input,
                        const FrameGeometry& frame, const Roi& roi);

}  // namespace filmgrain
