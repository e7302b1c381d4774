// filmgrain: what the planner's parts share. engine_plan.cpp chooses the
// paths of a render, plan_tables.cpp the kinetics and the P(develop | N)
// tables they read (MODEL.md 3-4), plan_report.cpp says what a plan runs
// and why (--stats: path, reason); each reads the render's arguments as
// one PlanContext. Private to core/src/engine.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "engine/engine_plan.h"
#include "model/light_spread.h"
#include "model/image_formation.h"
#include "model/inhibition.h"
#include "util/parallel.h"

namespace filmgrain::planning {

/// How auto shares its density error budget (tolerance): the tables (and
/// the curves folded from them) are built for three quarters; raster
/// coverage gets what the layer's tables and curves leave of the tolerance
/// by their error bounds, and at least the last quarter.
constexpr double kTableShare  = 0.75;
constexpr double kRasterShare = 0.25;

/// What every chooser reads: the render's arguments and what follows from
/// them alone.
struct PlanContext {
    PlanContext(const Stock& stock_, const SceneSettings& scene_, const ImageView& input_,
                const FrameGeometry& frame_, const Roi& roi_, const RenderSettings& settings_,
                const std::atomic<bool>* cancel_)
        : stock(stock_)
        , scene(scene_)
        , input(input_)
        , frame(frame_)
        , roi(roi_)
        , settings(settings_)
        , cancel(cancel_)
        , lxs_per_value(exposure_lxs_per_unit_value(stock_.exposure_at_grey_lxs,
                                                    scene_.exposure_stops))
        , exact(settings_.engine == Engine::exact)
        , fast(settings_.engine == Engine::fast)
        , forced_table(settings_.kinetics.has_value() || settings_.scale == ScaleMethod::pixel
                       || settings_.scale == ScaleMethod::mixed)
        , development(stock_)
        , region(read_region(stock_, scene_, input_, frame_, roi_))
        , workers(parallel_workers(std::numeric_limits<int64_t>::max(), settings_.nthreads))
    {
    }

    const Stock& stock;
    const SceneSettings& scene;
    const ImageView& input;
    const FrameGeometry& frame;
    const Roi& roi;
    const RenderSettings& settings;
    const std::atomic<bool>* cancel;
    /// Exposure (lxs) per unit of input value (MODEL.md 2).
    double lxs_per_value;
    bool exact, fast;
    /// A table asked for (kinetics=table or curve), or needed by
    /// scale=pixel: built whatever it costs.
    bool forced_table;
    Development development;
    /// The input pixels the render reads (read_region).
    InputRegion region;
    /// The render's worker threads (the cost estimates share work among
    /// them).
    int workers;

    bool cancelled() const { return cancel_requested(cancel); }

    /// How the frame's Gaussian spreads are convolved (MODEL.md 9, 10): by
    /// FFT in the exact engine (the reference), directly elsewhere (the
    /// same values to rounding, light_spread.h); spread_method() says what
    /// a layer with or without a halo then runs.
    SpreadMethod spread_asked() const { return exact ? SpreadMethod::fft : SpreadMethod::direct; }
    /// Film area of the whole scan and of the ROI, square micrometres, and
    /// their pixels: choices compare costs over the whole scan (so that a
    /// ROI decides as the full frame does); estimates are of the ROI.
    double frame_area_um2() const { return frame.width_um * frame.height_um; }
    double frame_pixels() const
    {
        const Roi all = frame.frame_scan_pixels();
        return static_cast<double>(all.width()) * static_cast<double>(all.height());
    }
    double roi_pixels() const { return static_cast<double>(roi.npixels()); }
    double roi_area_um2() const
    {
        return roi_pixels() * frame.scan_pitch_x_um * frame.scan_pitch_y_um;
    }
};

/// The smallest mean grain radius of a layer's populations.
inline double smallest_mean_radius_um(const Layer& layer)
{
    double r_um = 1e300;
    for (const Population& pop : layer.populations)
        r_um = std::min(r_um, 0.5 * pop.diameter_um);
    return r_um;
}

inline double seconds_since(std::chrono::steady_clock::time_point t0)
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// A number as the reasons print it: 3 significant digits.
inline std::string format_g(double v)
{
    std::ostringstream o;
    o.precision(3);
    o << v;
    return o.str();
}

/// A table depends only on the rates (the shutter and development are the
/// scene's): populations with the same rates share one, built once for the
/// largest photon count and the smallest error any of them needs.
struct TableRequest {
    KineticsRates rates;
    DevelopTable::Options options;
    std::shared_ptr<const DevelopTable> table;
    double seconds = 0.0;
    /// Chain steps the grains it serves would cost without it.
    double grain_steps = 0.0;
};
/// A population that asked for a table: which request serves it, the
/// largest exposure value of its layer's region, and whether its brightest
/// grains pass the table's photon cap.
struct TableNeed {
    size_t layer, population, request;
    double value_max;
    bool capped;
};
struct TableRequests {
    std::vector<TableRequest> requests;
    std::vector<TableNeed> needs;
};

/// The kinetics chooser, per population of layer l (plan_tables.cpp).
Status choose_kinetics(const PlanContext& c, size_t l, LayerPlan& plan, TableRequests& tables);
/// Builds the requested tables that pay for themselves (plan_tables.cpp).
Status build_tables(const PlanContext& c, TableRequests& tables);
/// Gives each population its table or the chain, the fast kernel's curve
/// where it runs, and the layers' error bounds; returns each layer's
/// kinetics bound (plan_tables.cpp).
std::vector<double> attach_tables(const PlanContext& c, const TableRequests& tables,
                                  std::vector<LayerPlan>& out);
/// grains=fast without the curve (plan_tables.cpp).
void choose_grains(const PlanContext& c, std::vector<LayerPlan>& out);
/// Every layer's path and the whole of its reason (plan_report.cpp).
void describe(const PlanContext& c, const InhibitionPlan& inhibition, std::vector<LayerPlan>& out);

}  // namespace filmgrain::planning
