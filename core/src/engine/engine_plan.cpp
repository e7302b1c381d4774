// Choosing the paths of a render, once per layer (the kinetics and their
// tables: plan_tables.cpp; what --stats says of a plan: plan_report.cpp).
#include "engine/engine_plan.h"
#include "engine/plan_context.h"

#include "kernels/grain_kernel.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>

#include "model/dye.h"
#include "engine/path_cost.h"
#include "expect/grain_counts.h"
#include "model/inhibition.h"
#include "model/light_spread.h"
#include "util/parallel.h"
#include "util/cache_file.h"
#include "util/process_cache.h"
#include "util/rng.h"
#include "util/sampling.h"

namespace filmgrain {

using namespace planning;

namespace {

/// Sample rows (disc clouds) or points per axis (gaussian) per smallest
/// mean cloud radius of a dye layer's image: the exact engine's, and the
/// others'. Measured (core Dye.SamplingConverges, 12.5 um pixels, 3 um
/// disc clouds): RMS per-pixel density difference from 64 rows per pixel
/// 0.039 at 8 rows, 0.015 at 16.
constexpr double kDyeSamplesPerRadiusExact = 8.0;
constexpr double kDyeSamplesPerRadiusFast  = 2.0;

/// Developed grain centres per pixel, at zero exposure (fog), that the
/// pixel scale needs (auto): below, the per-grain kernel runs. Measured
/// against the per-grain kernel (docs/performance/pixel_scale*.md, 8 seeds
/// of the wedge) at 3.9 and 5.2 (fine-color at 5.46 and 6.25 um pixels)
/// and 26 (real-scale) developed per pixel at fog: mean density within its
/// CI of the kernel's up to D = 2.2 (-0.004 +- 0.003 at D = 1.45 with 3.9),
/// pixel density sd 3-8% low above D ~ 0.7. The floor is the smallest
/// measured; fewer per pixel is not measured.
constexpr double kMinDevelopedPerPixel = 3.9;

/// How much larger the raster's bias is where grains are large against the
/// pixel than on the colour wedge its model was measured on (smallest mean
/// radius / pitch 1.5 / 6.25 = 0.24): the bias of the mean of pixel
/// densities comes from the per-pixel sampling noise of the open area
/// relative to it, which grows as a pixel holds fewer holes. Measured at
/// 16 rows per radius: the paper wedge (radius / pitch 0.48) 4x the
/// model, a natural image under 1.5 um pixels and paper's 6 um grains
/// (2.0) 6.9x; (ratio / 0.24)^2 covers both (4x and 69x: conservative
/// for the second), 1 below the calibration.
double raster_size_factor(double pitch_um, double smallest_radius_um)
{
    constexpr double kCalibrationRadiusPerPitch = 0.24;
    const double q = smallest_radius_um / pitch_um / kCalibrationRadiusPerPitch;
    return std::max(1.0, q * q);
}

/// The bias model of raster_samples (below): the largest step bias of the
/// mean of pixel densities with `rows` per pixel.
double raster_bias(int rows, double pitch_um, double smallest_radius_um)
{
    const double rows_per_radius = rows * smallest_radius_um / pitch_um;
    return 0.52 * raster_size_factor(pitch_um, smallest_radius_um)
           * std::pow(rows_per_radius, -2.3);
}

/// Rows of raster coverage per pixel (its points across a pixel are 64):
/// enough rows across the smallest mean grain radius for the tolerance, at
/// most 256. The per-pixel sampling noise biases the mean of pixel
/// densities (the log is convex), most where few points are uncovered.
/// Measured on the colour wedge (6.25 um pixels, docs/performance): the
/// largest step bias falls as (rows per radius)^-2.3 and is 0.0009 at 16
/// rows per radius (raster_bias()), times raster_size_factor where grains
/// are larger against the pixel; rows are chosen to keep it below
/// `budget`, the density error the raster may add: rows per radius =
/// (0.52 f / budget)^(1 / 2.3), 21 at 0.0005 (a quarter of the default
/// tolerance) and f = 1, 13.4 at 0.0013. The fast engine takes 4 rows per
/// radius, whatever the bias (~0.02-0.05).
int raster_samples(double pitch_um, double smallest_radius_um, double budget, bool fast)
{
    const double f = raster_size_factor(pitch_um, smallest_radius_um);
    const double rows_per_radius = fast ? 4.0 : std::pow(0.52 * f / budget, 1.0 / 2.3);
    const double want = std::ceil(rows_per_radius * pitch_um / smallest_radius_um);
    int rows = static_cast<int>(std::clamp(want, 1.0, 256.0));
    // The bias model evaluated as error_estimate adds it (raster_bias):
    // within the budget to the last bit, where the formula's rounding
    // would leave it a hair above.
    while (!fast && rows < 256 && raster_bias(rows, pitch_um, smallest_radius_um) > budget)
        ++rows;
    return rows;
}

/// shared_pixel_model's models (0.2 MB each without inhibition, ~5 MB with
/// VISION3 500T's 27 log-factor rows).
ProcessCache<std::string, PixelModel>& pixel_model_cache()
{
    static ProcessCache<std::string, PixelModel> cache(8);
    return cache;
}

#ifdef FILMGRAIN_PIXEL_MODEL_CODE_ID
/// A pixel model's cache file starts with the format, the build's pixel
/// model code id and the model's whole key (so a file is read only for
/// this key, by a build of the same code, compiler and flags).
std::string pixel_model_file_header(const std::string& key)
{
    return std::string("filmgrain pixel model 1\n") + FILMGRAIN_PIXEL_MODEL_CODE_ID + '\n' + key;
}
#endif

/// The pixel model kept on disk for `key` (table_cache_dir()/pixel-models,
/// cache_file.h), or null.
std::shared_ptr<const PixelModel> read_cached_pixel_model(const std::string& key)
{
#ifdef FILMGRAIN_PIXEL_MODEL_CODE_ID
    const std::string dir = table_cache_dir();
    if (dir.empty())
        return nullptr;
    const std::string header = pixel_model_file_header(key);
    const std::optional<std::string> body
        = read_cache_file(cache_file_path(dir, "pixel-models", "pixel-model", header), header);
    return body ? PixelModel::deserialize(*body) : nullptr;
#else
    (void)key;
    return nullptr;
#endif
}

void write_cached_pixel_model(const std::string& key, const PixelModel& model)
{
#ifdef FILMGRAIN_PIXEL_MODEL_CODE_ID
    const std::string dir = table_cache_dir();
    if (dir.empty())
        return;
    const std::string header = pixel_model_file_header(key);
    write_cache_file(cache_file_path(dir, "pixel-models", "pixel-model", header), header,
                     model.serialize());
#else
    (void)key, (void)model;
#endif
}

/// The layer's pixel model (PixelModel's arguments; `shape_samples` > 0:
/// its law's shape sampled, the dye image on that many rows or points a
/// pixel), built once per
/// process for the same arguments: a sequence's frames share it, as they
/// share their tables. It depends on the stock, scene and scan, never on
/// the pixels, and is the same for any thread count, so a model from the
/// cache is the one a new build would give. Keyed by the bytes of every
/// value the build reads (each population's size law, density, coupler
/// limit and photons per value, its table's serialization and its curve's
/// extent, the image,
/// the pitch, the log-factor range, the density clamp and the dye image's
/// rows a pixel its law's shape is sampled with, 0 for none), compared in
/// full. Kept on disk too, as the tables are (kinetics_table.h): another
/// process (a farm's next frame) reads it instead of building it.
std::shared_ptr<const PixelModel> shared_pixel_model(const std::vector<PixelPopulation>& pops,
                                                     double px_um, double py_um,
                                                     const Layer& layer,
                                                     const ImageOverlap& image,
                                                     double max_log_factor, int nthreads,
                                                     double max_density, int shape_samples)
{
    std::string key;
    const auto put = [&key](auto v) {
        key.append(reinterpret_cast<const char*>(&v), sizeof(v));
    };
    put(px_um);
    put(py_um);
    put(max_log_factor);
    put(max_density);
    put(shape_samples);
    put(static_cast<int>(layer.image));
    put(static_cast<int>(layer.cloud_profile));
    put(layer.cloud_diameter_ratio);
    put(layer.cloud_density);
    for (const PixelPopulation& p : pops) {
        put(p.population->max_dye_density);
        put(p.population->grains_per_um2);
        put(p.population->diameter_um);
        put(p.population->diameter_log_sigma);
        put(p.photons_per_value_um2);
        put(p.curve->lambda_max());
        put(p.curve->node_count());
        const std::string table = p.table->serialize();
        put(table.size());
        key += table;
    }
    if (std::shared_ptr<const PixelModel> kept = pixel_model_cache().find(key))
        return kept;
    std::shared_ptr<const PixelModel> model = read_cached_pixel_model(key);
    if (!model) {
        const PixelModel::ShapeSampling shape { &layer, shape_samples };
        model = std::make_shared<const PixelModel>(pops, px_um, py_um, image, max_log_factor,
                                                   nthreads, max_density,
                                                   shape_samples > 0 ? &shape : nullptr);
        write_cached_pixel_model(key, *model);
    }
    pixel_model_cache().put(std::move(key), model);
    return model;
}

/// Whether every population of a layer runs the fast kernel's curve.
bool all_curves(const LayerPlan& plan)
{
    return std::all_of(plan.populations.begin(), plan.populations.end(),
                       [](const PopulationPlan& p) { return p.curve != nullptr; });
}

/// The spread exposure of a layer (row by row over the whole frame) as a
/// one-channel image: LayerExposure reads it with weight 1.
ImageView spread_view(const std::vector<float>& values, const ImageView& input)
{
    ImageView v;
    v.pixels   = values.data();
    v.width    = input.frame_width();
    v.height   = input.frame_height();
    v.channels = 1;
    return v;
}

}  // namespace

size_t clear_pixel_model_cache() { return pixel_model_cache().clear(); }

InputRegion input_region(const ImageView& input, const FrameGeometry& frame, const Roi& roi,
                         double margin_um)
{
    const RectUm r  = frame.scan_rect(roi.x_begin, roi.y_begin, roi.x_end, roi.y_end);
    const double p  = frame.input_pitch_um;
    const auto clip = [](double v, int64_t n) {
        return std::clamp<int64_t>(static_cast<int64_t>(std::clamp(std::floor(v), -1.0, 9e18)), 0, n);
    };
    InputRegion out;
    out.x0 = clip((r.x0_um - margin_um) / p, input.frame_width());
    out.x1 = clip((r.x1_um + margin_um) / p + 1, input.frame_width());
    out.y0 = clip((r.y0_um - margin_um) / p, input.frame_height());
    out.y1 = clip((r.y1_um + margin_um) / p + 1, input.frame_height());
    return out;
}

namespace {

/// The largest grain radius any population of the stock generates (times
/// its clouds' reach on a dye layer, MODEL.md 8): the margin around a region
/// within which grains can reach into it.
double max_radius_um(const Stock& stock, const SceneSettings& scene)
{
    double r = 0.0;
    for (size_t l = 0; l < stock.layers.size(); ++l)
        for (size_t p = 0; p < stock.layers[l].populations.size(); ++p)
            r = std::max(r, std::max(1.0, image_reach_factor(stock.layers[l]))
                                * PopulationGrains(stock.layers[l].populations[p],
                                                   grain_seed(scene), static_cast<uint32_t>(l),
                                                   static_cast<uint32_t>(p))
                                      .max_radius_um());
    return r;
}

}  // namespace

InputRegion read_region(const Stock& stock, const SceneSettings& scene, const ImageView& input,
                        const FrameGeometry& frame, const Roi& roi)
{
    bool whole_frame = stock.inhibits();  // MODEL.md 10's blur: computed the same way
    for (const Layer& layer : stock.layers)
        whole_frame = whole_frame || layer.spreads_light();
    if (whole_frame)
        return InputRegion { 0, 0, input.frame_width(), input.frame_height() };
    InputRegion r = input_region(input, frame, roi, 2.0 * max_radius_um(stock, scene));
    if (scene.edge == FrameEdge::clamp) {
        // Beyond the image the nearest edge pixels are read: a region past
        // an edge holds them (MODEL.md 2).
        r.x0 = std::min(r.x0, input.frame_width() - 1);
        r.y0 = std::min(r.y0, input.frame_height() - 1);
        r.x1 = std::max(r.x1, r.x0 + 1);
        r.y1 = std::max(r.y1, r.y0 + 1);
    }
    return r;
}

namespace {

// ---- Light spread and inhibition (MODEL.md 9, 10): the exposure every
// later choice reads.

/// Layer l's exposure value straight from the input (MODEL.md 2), before
/// any spread.
LayerExposure direct_exposure(const PlanContext& c, size_t l)
{
    const Layer& layer = c.stock.layers[l];
    return LayerExposure(c.input, layer.sensitivity, c.frame.input_pitch_um,
                         saturation_value(layer, c.lxs_per_value), c.scene.edge);
}

/// The spread exposure of every layer that spreads light (null for the
/// others), one layer per worker, and the seconds each took; each is a pure
/// function of the layer and the whole input frame.
struct SpreadLight {
    std::vector<std::shared_ptr<const std::vector<float>>> values;
    std::vector<double> seconds;
};
SpreadLight spread_light(const PlanContext& c)
{
    const size_t n = c.stock.layers.size();
    SpreadLight out { std::vector<std::shared_ptr<const std::vector<float>>>(n),
                      std::vector<double>(n, 0.0) };
    std::vector<size_t> spreading;
    for (size_t l = 0; l < n; ++l)
        if (c.stock.layers[l].spreads_light())
            spreading.push_back(l);
    std::atomic<bool> stop { false };
    // The layers' halos share their transform where their kernels agree.
    HaloTransforms halos;
    parallel_for(static_cast<int64_t>(spreading.size()), c.settings.nthreads, stop,
                 [&](int, int64_t i) {
        if (c.cancelled())
            return;
        const auto t0      = std::chrono::steady_clock::now();
        const size_t l     = spreading[static_cast<size_t>(i)];
        const Layer& layer = c.stock.layers[l];
        out.values[l]      = std::make_shared<const std::vector<float>>(spread_exposure(
            c.stock, layer, direct_exposure(c, l), c.input.frame_width(),
            c.input.frame_height(), c.frame.input_pitch_um, c.spread_asked(), &halos));
        out.seconds[l] = seconds_since(t0);
    });
    return out;
}

/// Each layer's exposure value: the spread one, or the input's, both
/// saturating at the layer's saturation_value (MODEL.md 2: the spread
/// light of a saturated pixel is that of the clamped value, and the spread
/// exposure saturates as the direct one does).
std::vector<LayerExposure> layer_exposures(const PlanContext& c, const SpreadLight& spread)
{
    std::vector<LayerExposure> exposures;
    for (size_t l = 0; l < c.stock.layers.size(); ++l)
        exposures.push_back(spread.values[l]
                                ? LayerExposure(spread_view(*spread.values[l], c.input),
                                                { 1.0, 0.0, 0.0 }, c.frame.input_pitch_um,
                                                direct_exposure(c, l).max_value(), c.scene.edge)
                                : direct_exposure(c, l));
    return exposures;
}

/// Development inhibitors (MODEL.md 10), from the layers' exposures.
Status plan_inhibitors(const PlanContext& c, const std::vector<LayerExposure>& exposures,
                       InhibitionPlan& inhibition, double& seconds)
{
    if (!c.stock.inhibits())
        return {};
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<const LayerExposure*> views;
    for (const LayerExposure& e : exposures)
        views.push_back(&e);
    if (Status s = plan_inhibition(c.stock, c.scene, views, c.input.frame_width(),
                                   c.input.frame_height(), c.frame.input_pitch_um,
                                   c.settings.nthreads, inhibition, c.cancel,
                                   c.spread_asked());
        !s)
        return s;
    seconds = seconds_since(t0);
    return {};
}

// ---- A layer's grains, exposure (MODEL.md 1-2) and first coverage.

/// The exposure chooser (MODEL.md 2): over each grain's disc, but at its
/// centre in the fast engine, unless the settings say.
ExposureMethod choose_exposure(const PlanContext& c)
{
    if (c.settings.photons)
        return *c.settings.photons;
    return c.fast ? ExposureMethod::centre : ExposureMethod::disc;
}

/// The coverage chooser (MODEL.md 5), before the kinetics are known: exact
/// (scanlines in the fast engine) unless the settings say; the raster is
/// chosen later, where every grain runs the kernel (choose_raster).
/// Sub-scanlines are spaced by a fraction of the smallest mean grain radius
/// (not of the pixel): the sampling error of a disc's area depends on how
/// many chords cross it, so every grain is crossed by about
/// 2 * chords_per_radius chords whatever the scan resolution. Auto keeps
/// the exact coverage: scanline sampling is unbiased in mean transmittance
/// but its per-pixel noise biases the mean of per-pixel densities (the log
/// is convex), and exact coverage per block (grid_coverage) costs little
/// more.
void choose_first_coverage(const PlanContext& c, const Layer& layer, LayerPlan& plan)
{
    const double chords_per_radius = 2.0;
    plan.coverage = c.fast ? CoverageMethod::scanline : CoverageMethod::exact;
    plan.coverage_samples = static_cast<int>(std::clamp(
        std::ceil(chords_per_radius * c.frame.scan_pitch_y_um / smallest_mean_radius_um(layer)),
        1.0, 256.0));
    if (c.settings.coverage)
        plan.coverage = *c.settings.coverage;
    if (c.settings.samples > 0)
        plan.coverage_samples = c.settings.samples;
}

/// A layer's plan before its kinetics: its populations' grains and rates,
/// how far their images reach, the exposure and first coverage methods.
LayerPlan start_layer(const PlanContext& c, size_t l, const LayerExposure& exposure,
                      double setup_seconds, std::shared_ptr<const std::vector<float>> spread,
                      std::shared_ptr<const FramePlane> log_factor)
{
    const Layer& layer = c.stock.layers[l];
    LayerPlan plan { exposure, {}, CoverageMethod::exact, 0, 0.0, nullptr, 0, "", "", {}, 0.0,
                     setup_seconds, std::move(spread), std::move(log_factor) };
    const ExposureMethod method = choose_exposure(c);
    double margin_um            = 0.0;
    for (size_t p = 0; p < layer.populations.size(); ++p) {
        const Population& pop = layer.populations[p];
        PopulationPlan pp { PopulationGrains(pop, grain_seed(c.scene), static_cast<uint32_t>(l),
                                             static_cast<uint32_t>(p)),
                            pop.quantum_efficiency * kPhotonsPerUm2PerLxs * c.lxs_per_value,
                            { pop.k_pair_per_s, pop.k_join_per_s, pop.k_loss_per_s },
                            pop.rate_area_exponent,
                            KineticsMethod::chain,
                            method,
                            nullptr, nullptr, nullptr };
        margin_um = std::max(margin_um, std::max(1.0, image_reach_factor(layer))
                                            * pp.grains.max_radius_um());
        plan.populations.push_back(std::move(pp));
    }
    plan.margin_um   = margin_um;
    plan.image_reach = image_reach_factor(layer);
    choose_first_coverage(c, layer, plan);
    return plan;
}

// ---- Layers no light reaches (MODEL.md 4 with n4 = 0: fog alone).

/// Stream key of the fog's thinned grain processes (apart from the full
/// processes' streams).
constexpr uint64_t kFogGrainStream = 0xf06;

/// A layer that no light reaches: every grain develops with probability f
/// (MODEL.md 4: P = 1 - (1 - f)(1 - d)^0), independently, so its developed
/// grains are the grain process thinned to f: a Poisson process of
/// intensity f n with the same sizes, which each population here generates
/// instead of the full one (every grain it generates develops; an
/// inhibited layer keeps each with probability exp(-log factor), MODEL.md
/// 10). Exact in distribution, at f times the grains. For the pixel scale
/// (choose_scale compares its cost), P(develop | N) of the fog: a table of
/// N <= 3, where the chain cannot build a 4-centre and P = f exactly, and
/// its curve, exact at mean 0, the only exposure such a layer has.
void plan_unlit_layers(const PlanContext& c, std::vector<LayerPlan>& out)
{
    std::shared_ptr<const DevelopTable> table;
    std::shared_ptr<const DevelopCurve> curve;
    const double f = c.development.fog_probability();
    for (size_t l = 0; l < out.size(); ++l) {
        LayerPlan& plan = out[l];
        if (!plan.unlit)
            continue;
        if (!table) {
            DevelopTable::Options fog;
            fog.max_photons = 3;
            fog.nthreads    = 1;
            table = std::make_shared<const DevelopTable>(KineticsRates {}, c.scene.shutter_s,
                                                         c.development, fog);
            curve = std::make_shared<const DevelopCurve>(*table);
        }
        for (size_t p = 0; p < plan.populations.size(); ++p) {
            PopulationPlan& pp = plan.populations[p];
            Population thinned = c.stock.layers[l].populations[p];
            thinned.grains_per_um2 *= f;
            pp.grains = PopulationGrains(thinned, hash_ids(grain_seed(c.scene), kFogGrainStream),
                                         static_cast<uint32_t>(l), static_cast<uint32_t>(p));
            pp.table = table;
            pp.curve = curve;
            if (c.settings.grains != GrainMethod::exact)
                pp.fast = std::make_shared<const FastGrains>(pp.grains);
        }
        plan.notes.fog_alone = true;
    }
}

/// Grains a layer's per-grain path generates per square micrometre: the
/// fog's thinned processes for a layer no light reaches, else every grain.
double generated_grains_per_um2(const PlanContext& c, size_t l, const LayerPlan& plan)
{
    double n = 0.0;
    for (const Population& pop : c.stock.layers[l].populations)
        n += pop.grains_per_um2;
    return plan.unlit ? n * c.development.fog_probability() : n;
}

/// Estimated seconds of a layer's tiles grain by grain over `area_um2` and
/// `pixels` (engine/path_cost.h).
double grain_path_seconds(const PlanContext& c, size_t l, const LayerPlan& plan,
                          double area_um2, double pixels)
{
    const bool fast = std::all_of(plan.populations.begin(), plan.populations.end(),
                                  [](const PopulationPlan& pp) { return pp.fast != nullptr; });
    const double grains = generated_grains_per_um2(c, l, plan) * area_um2;
    const double per_grain = plan.unlit ? path_cost::kFogGrainSeconds
                             : fast     ? path_cost::kFastGrainSeconds
                                        : path_cost::kExactGrainSeconds;
    return path_cost::shared_seconds(grains, per_grain, c.workers)
           + path_cost::shared_seconds(pixels, path_cost::kGrainPixelSeconds, c.workers);
}

/// Estimated seconds of a layer's tiles at pixel scale over `pixels`.
double pixel_path_seconds(const PlanContext& c, double pixels)
{
    return path_cost::shared_seconds(pixels, path_cost::kPixelSeconds, c.workers);
}

// ---- The developed grains' image (MODEL.md 5, 8).

/// Dye layers (MODEL.md 8): their image is the mean of 10^-D over each
/// pixel, sampled on rows (disc clouds: exact along each) or points
/// (gaussian) spaced by a fraction of the smallest mean cloud radius. The
/// tables' and curves' error bounds scale with the clouds' blocking area.
void choose_dye_image(const PlanContext& c, std::vector<LayerPlan>& out)
{
    for (size_t l = 0; l < out.size(); ++l) {
        const Layer& layer = c.stock.layers[l];
        if (layer.image != LayerImage::dye)
            continue;
        LayerPlan& plan = out[l];
        const double smallest_cloud_um = smallest_mean_radius_um(layer) * layer.cloud_diameter_ratio;
        const double per_radius = c.exact ? kDyeSamplesPerRadiusExact : kDyeSamplesPerRadiusFast;
        plan.dye_samples = static_cast<int>(std::clamp(
            std::ceil(per_radius * std::max(c.frame.scan_pitch_x_um, c.frame.scan_pitch_y_um)
                      / smallest_cloud_um),
            c.exact ? 4.0 : 2.0, c.exact ? 64.0 : 16.0));
        if (c.settings.samples > 0)  // samples=N (not for exact: validated)
            plan.dye_samples = c.settings.samples;
        plan.error_estimate *= cloud_area_factor(layer);
    }
}

/// The raster chooser: coverage of the per-grain layers whose grains all
/// run the fast kernel (and of every layer of the fast engine) on a raster
/// where its sampling resolves the grains, with rows for the tolerance the
/// layer's tables and curves leave (kinetics_bound), and at least the
/// raster's share; else the coverage chosen first.
void choose_raster(const PlanContext& c, const std::vector<double>& kinetics_bound,
                   std::vector<LayerPlan>& out)
{
    for (size_t l = 0; l < out.size() && !c.exact; ++l) {
        LayerPlan& plan = out[l];
        const bool pixels_only = plan.pixel_model && plan.min_developed_per_pixel == 0.0;
        if (plan.dye_samples > 0 || pixels_only)  // no coverage to choose
            continue;
        const double smallest_radius_um = smallest_mean_radius_um(c.stock.layers[l]);
        const double budget = std::max(kRasterShare * c.settings.tolerance,
                                       c.settings.tolerance - kinetics_bound[l]);
        const double pitch_um = std::max(c.frame.scan_pitch_x_um, c.frame.scan_pitch_y_um);
        if (!c.settings.coverage && (all_curves(plan) || c.fast))
            plan.coverage = CoverageMethod::raster;
        if (plan.coverage != CoverageMethod::raster)
            continue;
        plan.coverage_samples = c.settings.samples > 0
                                    ? c.settings.samples
                                    : raster_samples(pitch_um, smallest_radius_um, budget, c.fast);
        plan.error_estimate += raster_bias(plan.coverage_samples, pitch_um, smallest_radius_um);
    }
}

// ---- Scale (MODEL.md 5 at pixel scale).

/// The scale chooser: a layer whose grains all run the kernel is drawn
/// from its pixel statistics where they describe it: pixel correlations
/// that end within kMaxLag pixels (at most 1% of their sum beyond), and
/// enough developed grains per pixel even at zero exposure (fog) for its
/// skewed law, or else a sampled law's shape and the per-grain kernel for
/// the pixels that develop too few (measured in docs/performance).
Status choose_scale(const PlanContext& c, const InhibitionPlan& inhibition,
                    std::vector<LayerPlan>& out)
{
    for (size_t l = 0; l < out.size() && !c.exact; ++l) {
        LayerPlan& plan    = out[l];
        const Layer& layer = c.stock.layers[l];
        const bool curves  = all_curves(plan);
        const std::optional<ScaleMethod>& asked = c.settings.scale;
        if (asked == ScaleMethod::grain || (!asked && !curves))
            continue;
        // A layer no light reaches: its fog grains are exact and cost in
        // proportion to the few that develop; the pixel scale is taken
        // only where it is estimated cheaper over the whole scan (with
        // its model's build), the same for every ROI.
        if (plan.unlit && !asked) {
            const double grains_s = grain_path_seconds(c, l, plan, c.frame_area_um2(),
                                                       c.frame_pixels());
            const double pixel_s  = path_cost::kPixelModelSeconds
                                   + pixel_path_seconds(c, c.frame_pixels());
            plan.notes.unlit_scale = PlanNotes::UnlitScale { grains_s, pixel_s };
            if (grains_s <= pixel_s)
                continue;
        }
        const char* asked_name = asked == ScaleMethod::mixed ? "scale=mixed" : "scale=pixel";
        if (!curves)
            return Status::errorf(asked_name, ": layer '", layer.name,
                                  "' needs P(develop | mean photons) for every population, which "
                                  "kinetics=chain|early|table, grains=exact and populations with "
                                  "rate_area_exponent != 0 do not have: use scale=grain");
        // Each developed grain's image (MODEL.md 5 or 8): its blocking area
        // and overlap enter the statistics and make the pixel correlations.
        const ImageOverlap image(layer);
        double median_range_um = 0.0;
        for (const PopulationPlan& pp : plan.populations)
            median_range_um = std::max(median_range_um,
                                       image.correlation_range_um(pp.grains.radius_at_z_um(0.0)));
        const double pitch_um = std::min(c.frame.scan_pitch_x_um, c.frame.scan_pitch_y_um);
        // Cheap refusals first (auto): a median grain's image reaching past
        // the lags kept, or too few developed grains at fog.
        if (!asked && median_range_um > (kMaxLag + 1) * pitch_um)
            continue;
        const auto t0 = std::chrono::steady_clock::now();
        std::vector<PixelPopulation> pops;
        for (size_t p = 0; p < plan.populations.size(); ++p)
            pops.push_back({ &layer.populations[p], &plan.populations[p].grains,
                             plan.populations[p].photons_per_value_um2,
                             plan.populations[p].curve.get(), plan.populations[p].table.get() });
        const double fog_grains = PixelModel::compute(pops, c.frame.scan_pitch_x_um,
                                                      c.frame.scan_pitch_y_um, 0.0, image)
                                      .developed_per_pixel;
        // An inhibited layer (MODEL.md 10): its statistics over the log
        // factor too, up to the stock's bound on it.
        const double max_log_factor = plan.inhibition ? inhibition.max_log_factor[l] : 0.0;
        // Too few at fog (sparse): the two-moment law is off there (for
        // 500T's blue in 3 um pixels 1.3-2.3x the grains' spread of
        // density, docs/performance), so the law's shape is sampled where
        // it can be (a dye layer: pixel_shape.h), with the image its
        // grains would have; where it cannot, auto keeps the grains. Auto
        // and scale=mixed draw a sparse layer's pixels from the pixel
        // scale where their exposure develops enough, the rest grain by
        // grain.
        const bool sparse   = fog_grains < kMinDevelopedPerPixel;
        const bool sampled  = sparse && can_sample_pixel_shape(layer);
        if (!asked && sparse && !sampled)
            continue;
        const bool mixed        = sparse && asked != ScaleMethod::pixel;
        const int shape_samples = sampled ? plan.dye_samples : 0;
        auto model = shared_pixel_model(pops, c.frame.scan_pitch_x_um, c.frame.scan_pitch_y_um,
                                        layer, image, max_log_factor, c.settings.nthreads,
                                        c.stock.max_density, shape_samples);
        plan.setup_seconds += seconds_since(t0);
        if (c.cancelled())
            return Status::error("render cancelled");
        if (model->lags() < 0) {
            if (!asked)
                continue;
            return Status::errorf(asked_name, ": layer '", layer.name,
                                  "': its pixels' correlations reach beyond ", kMaxLag,
                                  " pixels (", format_g(100.0 * model->max_dropped_correlation()),
                                  "% of their sum left out there: grains or clouds too large "
                                  "for ", format_g(pitch_um), " um pixels): use scale=grain");
        }
        plan.pixel_model = std::move(model);
        plan.pixel_key   = hash_ids(grain_seed(c.scene), 0x9133, l);
        if (mixed)
            plan.min_developed_per_pixel = kMinDevelopedPerPixel;
        else
            plan.dye_samples = 0;  // no per-grain image
        const PixelModel& pm = *plan.pixel_model;
        // The table's interpolation error of the mean transmittance, as
        // density.
        plan.error_estimate += kLog10E * pm.max_mean_error();
        plan.notes.pixel_scale = PlanNotes::PixelScale { pitch_um, fog_grains, max_log_factor };
    }
    return {};
}

}  // namespace

Status plan_layers(const Stock& stock, const SceneSettings& scene, const ImageView& input,
                   const FrameGeometry& frame, const Roi& roi, const RenderSettings& settings,
                   std::vector<LayerPlan>& out, const std::atomic<bool>* cancel)
{
    out.clear();
    const PlanContext c(stock, scene, input, frame, roi, settings, cancel);

    // The exposure every later choice reads (MODEL.md 9, 10).
    const SpreadLight spread = spread_light(c);
    if (c.cancelled())
        return Status::error("render cancelled");
    const std::vector<LayerExposure> exposures = layer_exposures(c, spread);
    InhibitionPlan inhibition;
    double inhibition_seconds = 0.0;
    if (Status s = plan_inhibitors(c, exposures, inhibition, inhibition_seconds); !s)
        return s;

    // Grains, exposure, first coverage and kinetics, layer by layer (tables
    // requested in that order: their streams are keyed by it).
    TableRequests tables;
    for (size_t l = 0; l < stock.layers.size(); ++l) {
        LayerPlan plan = start_layer(
            c, l, exposures[l], spread.seconds[l] + inhibition_seconds / stock.layers.size(),
            spread.values[l], inhibition.log_factor.empty() ? nullptr : inhibition.log_factor[l]);
        if (Status s = choose_kinetics(c, l, plan, tables); !s)
            return s;
        out.push_back(std::move(plan));
    }
    if (Status s = build_tables(c, tables); !s)
        return s;
    const std::vector<double> kinetics_bound = attach_tables(c, tables, out);
    plan_unlit_layers(c, out);
    choose_grains(c, out);
    choose_dye_image(c, out);
    // The pixel scale first: a layer drawn from its pixel statistics has
    // no coverage, and its error estimate no raster bias.
    if (Status s = choose_scale(c, inhibition, out); !s)
        return s;
    choose_raster(c, kinetics_bound, out);
    // (A mixed layer's estimate is an upper bound: as if every pixel took
    // both paths.)
    for (size_t l = 0; l < out.size(); ++l)
        out[l].estimated_seconds
            = (!out[l].pixel_model || out[l].min_developed_per_pixel > 0.0
                   ? grain_path_seconds(c, l, out[l], c.roi_area_um2(), c.roi_pixels())
                   : 0.0)
              + (out[l].pixel_model ? pixel_path_seconds(c, c.roi_pixels()) : 0.0);
    describe(c, inhibition, out);
    return {};
}

}  // namespace filmgrain
