// filmgrain: rendering a negative from a scene-linear image.
//
// Conventions shared by every entry point:
// - Units: film coordinates in micrometres, times in seconds, exposure in
//   lux-seconds; every physical name carries its unit.
// - Errors: a Status whose message names the field, its value and the rule.
// - Determinism: the output for a given (stock, scene, input, scan size) is
//   bit-identical for any thread count, tile size and ROI containing the
//   pixel; a different seed gives a different grain pattern.
// - Threads: nthreads = 0 means all hardware threads.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "filmgrain/image.h"
#include "filmgrain/names.h"
#include "filmgrain/status.h"
#include "filmgrain/stock.h"

namespace filmgrain {

/// Largest |frame number| of a sequence.
inline constexpr int64_t kMaxFrameNumber = 1000000000;

/// What lies beyond the input's pixels (MODEL.md 2).
enum class FrameEdge {
    clamp,  ///< the scene continues: each point beyond the input has the
            ///< exposure of the nearest edge pixel (OIIO's wrap=clamp), in
            ///< the disc integrals, the light spread and the inhibitors
    gate,   ///< no light beyond the input: the hard edge of a frame exposed
            ///< inside a camera gate
};
inline constexpr Named<FrameEdge> kFrameEdgeNames[] = { { FrameEdge::clamp, "clamp" },
                                                       { FrameEdge::gate, "gate" } };
constexpr const auto& names_of(FrameEdge) { return kFrameEdgeNames; }

/// The shot: how the scene is exposed onto the film (MODEL.md 1-2).
struct SceneSettings {
    /// Exposure offset in stops (2^stops on every exposure). [-64, 64].
    double exposure_stops = 0.0;
    /// Time the shutter is open, seconds; 1/48 s is a 180-degree shutter at
    /// 24 fps. (0, 1e7].
    double shutter_s = 1.0 / 48.0;
    /// Width of the film frame, millimetres (Super 35 by default). (0, 1e9].
    double width_mm = 24.89;
    /// Selects the grain pattern and every random outcome.
    uint64_t seed = 0;
    /// Frame number within a sequence; unset: a single image, whose grain
    /// comes from `seed` as is. Set: the grain comes from
    /// frame_seed(seed, frame), so that every frame has its own grain and a
    /// frame rendered alone equals the same frame in a sequence. [-1e9, 1e9].
    std::optional<int64_t> frame;
    /// With a frame: keep one grain pattern for every frame (`seed` as is).
    bool static_grain = false;
    /// Beyond the input's pixels: the scene continues (clamp, the default)
    /// or there is no light (gate).
    FrameEdge edge = FrameEdge::clamp;

    Status validate() const;
};

/// The seed of frame `frame` of a sequence rendered with `seed`:
/// hash_ids(seed, 0xf4a3e, frame) of core/src/util/rng.h, i.e. MurmurHash3's
/// 64-bit finaliser chained over (seed, a constant naming the purpose,
/// frame as a two's-complement 64-bit integer). Documented (docs/usage.md,
/// "Sequences") so that other tools can reproduce a frame's grain.
uint64_t frame_seed(uint64_t seed, int64_t frame);

/// The seed the grain of `scene` is drawn from: frame_seed(seed, *frame)
/// for a frame of a sequence unless static_grain, else `seed`.
uint64_t grain_seed(const SceneSettings& scene);

/// Which engine simulates the grains.
enum class Engine {
    exact,      ///< the reference: every grain's photons, its latent-image
                ///< events until its fate is decided (the full chain's
                ///< decision, bit for bit), exact pixel coverage; no knob
                ///< may change it
    fast,       ///< the fastest paths, whatever their error (reported)
    automatic,  ///< ("auto") per layer, the paths the scene needs within
                ///< the error budget `tolerance`; the default
};

/// How a grain's latent image decides its development (MODEL.md 3-4).
enum class KineticsMethod {
    chain,       ///< the reference: every grain's absorbed photons, its
                 ///< chain until its fate is decided (the develop uniform
                 ///< is drawn first and n4 never decreases, so the decision
                 ///< is exactly the full chain's, bit for bit)
    early_stop,  ///< as chain, but a grain that its develop uniform alone
                 ///< decides (fog) draws no photons (the same decisions)
    table,       ///< P(develop | N) tabulated once per scene by running the
                 ///< chain; grains sample it (Monte Carlo error, reported)
    curve,       ///< P(develop | mean photons): the table with the Poisson
                 ///< count folded in; one uniform per grain, in the fast
                 ///< per-grain kernel (disc exposure for auto, centre
                 ///< for fast; the table's error plus the curve's,
                 ///< reported)
    fog,         ///< a layer that no light reaches (every exposure value
                 ///< of the region the render reads is 0): every grain
                 ///< develops with the fog probability f alone (MODEL.md
                 ///< 4 with n4 = 0), so only the developed grains are
                 ///< generated, as the grain process thinned to f (a
                 ///< Poisson process of intensity f n: exact in
                 ///< distribution, other grains than the full process's);
                 ///< auto and fast choose it for such a layer unless its
                 ///< pixel scale costs less; asked for on a lit layer, an
                 ///< error
};

/// How a grain's absorbed photon count gets its mean (MODEL.md 2).
enum class ExposureMethod {
    disc,    ///< exposure integrated over the disc (box reconstruction)
    centre,  ///< exposure at the grain's centre times its area
};

/// How pixels get their coverage by developed discs (MODEL.md 5).
enum class CoverageMethod {
    exact,     ///< exact area of the union (Green's theorem)
    scanline,  ///< exact chord unions on sub-scanlines, sampled in y
    raster,    ///< a bit per point of a samples x samples grid per pixel
};

/// How a population's grains are drawn (MODEL.md 1). Both are the same
/// Poisson process of lognormal discs; they differ in their streams, so a
/// seed gives different grains with each.
enum class GrainMethod {
    exact,  ///< PCG streams per grain, sizes by inverting the normal CDF
            ///< (the reference's grains)
    fast,   ///< counter-based streams per cell, sizes from tabulated
            ///< quantiles (the fast kernel's; its error is reported)
};

/// At what scale a layer is simulated.
enum class ScaleMethod {
    grain,  ///< every grain generated and decided (MODEL.md 1-5 as written)
    pixel,  ///< each pixel's transmittance drawn from the Boolean model's
            ///< pixel statistics (mean, variance, neighbour correlation),
            ///< for grains far below the pixel (Gaussian approximation,
            ///< measured in docs/performance)
    mixed,  ///< pixel where a pixel's exposure develops enough grains for
            ///< its pixel statistics (what auto's pixel asks of a layer's
            ///< fog), grain elsewhere (measured in docs/performance)
};

/// Names as used on the command line, in metadata and statistics
/// (filmgrain/names.h reads them both ways); the default engine first.
inline constexpr Named<Engine> kEngineNames[] = { { Engine::automatic, "auto" },
                                                  { Engine::exact, "exact" },
                                                  { Engine::fast, "fast" } };
inline constexpr Named<KineticsMethod> kKineticsNames[] = {
    { KineticsMethod::chain, "chain" }, { KineticsMethod::early_stop, "early" },
    { KineticsMethod::table, "table" }, { KineticsMethod::curve, "curve" },
    { KineticsMethod::fog, "fog" }
};
inline constexpr Named<ExposureMethod> kExposureNames[] = { { ExposureMethod::disc, "disc" },
                                                            { ExposureMethod::centre, "centre" } };
inline constexpr Named<CoverageMethod> kCoverageNames[] = { { CoverageMethod::exact, "exact" },
                                                            { CoverageMethod::scanline,
                                                              "scanline" },
                                                            { CoverageMethod::raster,
                                                              "raster" } };
inline constexpr Named<GrainMethod> kGrainNames[] = { { GrainMethod::exact, "exact" },
                                                      { GrainMethod::fast, "fast" } };
inline constexpr Named<ScaleMethod> kScaleNames[] = { { ScaleMethod::grain, "grain" },
                                                      { ScaleMethod::pixel, "pixel" },
                                                      { ScaleMethod::mixed, "mixed" } };

constexpr const auto& names_of(Engine) { return kEngineNames; }
constexpr const auto& names_of(KineticsMethod) { return kKineticsNames; }
constexpr const auto& names_of(ExposureMethod) { return kExposureNames; }
constexpr const auto& names_of(CoverageMethod) { return kCoverageNames; }
constexpr const auto& names_of(GrainMethod) { return kGrainNames; }
constexpr const auto& names_of(ScaleMethod) { return kScaleNames; }

/// Reports progress in [0, 1]; return false to cancel the render. Called
/// from the thread that called render_negative, at most ~10 times a second.
using ProgressCallback = std::function<bool(double fraction_done)>;

/// The engine and its knobs, declared once: RenderSettings, the operator's
/// FilmgrainOptions and the CLI's command all carry this block.
struct EngineOptions {
    Engine engine = Engine::automatic;
    /// Density error budget of the approximate paths (auto): the largest
    /// bias of a patch-mean density that a path may add. (0, 1].
    double tolerance = 0.002;
    /// Expert overrides of the engine's choices (fast and auto only; the
    /// exact engine refuses them). Unset: the engine decides. Each is named
    /// as its --filmgrain modifier (and Python keyword).
    std::optional<KineticsMethod> kinetics;
    std::optional<ExposureMethod> photons;  ///< photons=: disc or centre
    std::optional<CoverageMethod> coverage;
    std::optional<GrainMethod> grains;
    std::optional<ScaleMethod> scale;
    /// samples=: sub-scanlines per pixel row for scanline coverage, sample
    /// rows per pixel for raster coverage, or a dye layer's samples per
    /// pixel; 0: the engine's. [0, 256].
    int samples = 0;
};

/// How to render: engine, scan resolution, region, threads.
struct RenderSettings : EngineOptions {
    /// Scan (output) width in pixels over the whole frame; 0: the input's.
    int64_t scan_width = 0;
    /// Scan height; 0: the frame's aspect at scan_width (or the input's).
    int64_t scan_height = 0;
    /// The input pixels (whole-image coordinates) that the scan_width x
    /// scan_height scan covers; empty: the whole input (the frame). Scan
    /// pixel (0, 0) is its corner, and the scan's grid continues beyond it
    /// at the same pitch over the rest of the frame, rounded outward to
    /// whole scan pixels (MODEL.md 2: a plate's data window beyond or
    /// inside its display window, the reference): a ROI may lie anywhere
    /// there, at negative coordinates too. Scan sizes and aspect (0 above)
    /// then follow the reference.
    Roi scan_reference;
    /// Region of the scan to render; empty: the scan of the reference
    /// ([0, width) x [0, height)).
    Roi roi;
    /// Worker threads; 0: all hardware threads.
    int nthreads = 0;
    /// Side of the square tiles the work is split into, scan pixels.
    /// Affects speed only, never the output. [1, 4096].
    int tile_size_px = 64;
    /// Optional progress reporting and cancellation.
    ProgressCallback progress;

    /// Ranges and combinations (e.g. overrides with the exact engine).
    Status validate() const;
};

/// The scan's geometry for a given input size (MODEL.md 1).
struct ScanGeometry {
    int64_t width          = 0;  ///< scan pixels across the reference (the frame)
    int64_t height         = 0;
    double frame_width_um  = 0.0;
    double frame_height_um = 0.0;
    double input_pitch_um  = 0.0;  ///< input pixel side
    double pitch_x_um      = 0.0;  ///< scan pixel width
    double pitch_y_um      = 0.0;  ///< scan pixel height
    /// The input pixels the width x height scan covers (settings'
    /// scan_reference, or the whole input).
    Roi reference;
    /// The scan pixels over the whole frame, rounded outward (where a ROI
    /// may lie): [0, width) x [0, height) without a reference.
    Roi frame_pixels;
};

/// The scan an input of input_width x input_height gives with `settings`.
Status scan_geometry(const SceneSettings& scene, int64_t input_width, int64_t input_height,
                     const RenderSettings& settings, ScanGeometry& out);

/// The scan pixels over a rectangle of input pixels (whole-image
/// coordinates, may reach beyond the input): its film rectangle rounded
/// outward to whole scan pixels, in the scan's coordinates. `exact`
/// (optional, 4 values x0, y0, x1, y1) receives the rectangle before the
/// rounding, in scan pixels. Exact integer arithmetic: an input rectangle
/// that falls on whole scan pixels gives them exactly.
Roi scan_pixels_over(const ScanGeometry& scan, const Roi& input_pixels, double* exact = nullptr);

/// The input pixels, in whole-image coordinates, that a render of
/// settings.roi (or the whole scan) reads: its film region grown by the
/// largest grain radius, clipped to the image. A caller that holds only part
/// of a large input (a 256x256 ROI of a 16K frame) reads, converts and
/// passes just this window (ImageView's origin and full size), so memory
/// and time follow the ROI. May be empty (a ROI beyond every input pixel).
Status required_input_window(const Stock& stock, const SceneSettings& scene,
                             int64_t input_width, int64_t input_height,
                             const RenderSettings& settings, Roi& out);

/// What happened in one layer. Grains are counted once each: those whose
/// centre lies in the rendered region (grains outside it that reach into it
/// are simulated but not counted).
struct LayerStats {
    std::string name;
    uint64_t grains           = 0;  ///< grains with centres in the region
    uint64_t developed        = 0;  ///< of those, developed (fog included)
    uint64_t absorbed_photons = 0;  ///< photons they absorbed
    uint64_t kinetics_events  = 0;  ///< latent-image events simulated for them
    /// Of the counted grains: decided before their photons were needed
    /// (the develop uniform alone settled it; their photons are not counted).
    uint64_t decided_early    = 0;
    double mean_density       = 0.0;  ///< mean output density of the region
    /// The paths that ran, e.g. "kinetics=table exposure=disc
    /// coverage=scanline:4", and why the engine chose them.
    std::string path;
    std::string reason;
    /// Bound on the bias of a patch-mean density from the approximate
    /// paths of this layer (0 for exact ones; see `reason`).
    double error_estimate = 0.0;
    /// Seconds spent building this layer's tables, before the tiles.
    double setup_seconds = 0.0;
    /// The seconds the planner estimated this layer's tiles would take on
    /// the render's threads, from a linear model of its path's work (grains
    /// generated, pixels written) measured on the project's reference
    /// machine (core/src/engine/path_cost.h); the planner compares such
    /// estimates where a layer could take either of two exact-enough paths.
    double estimated_seconds = 0.0;
};

/// What the input held, over the input pixels the render read.
struct InputStats {
    uint64_t pixels_read      = 0;
    uint64_t nonfinite_pixels = 0;  ///< a NaN or Inf channel
    uint64_t nan_pixels       = 0;  ///< a NaN channel: zero exposure (MODEL.md 2)
    /// Some layer's exposure at or past the largest the kinetics represent
    /// (+Inf included): clamped to it, the light saturates (MODEL.md 2).
    uint64_t saturated_pixels = 0;
    uint64_t negative_pixels  = 0;  ///< a negative channel (negative v: zero)
    uint64_t denormal_pixels  = 0;  ///< a subnormal channel (used as is)
};

/// Statistics of a render, for --stats and tests.
struct RenderStats {
    std::string engine;
    std::vector<LayerStats> layers;
    InputStats input;
    double simulate_seconds = 0.0;
};

/// Renders negative density (MODEL.md 1-5). `input` is scene-linear (1 or
/// >= 3 channels). `density` receives roi.width() x roi.height() pixels of
/// stock.layers.size() interleaved floats (layer order), row-major, where
/// roi is settings.roi or the whole scan. `stats` may be null.
/// Thread safety: reentrant; uses its own worker threads.
Status render_negative(const Stock& stock, const SceneSettings& scene, const ImageView& input,
                       const RenderSettings& settings, float* density, RenderStats* stats);

/// The directory of the on-disk cache of P(develop | N) tables and pixel
/// models (kept for other processes; core/src/engine/kinetics_table.h,
/// shared_pixel_model in engine_plan.cpp): $FILMGRAIN_CACHE_DIR if set
/// ("" or "off": no disk cache), else $XDG_CACHE_HOME/filmgrain, else
/// $HOME/.cache/filmgrain; "" when none (or when this build has no table
/// code id). Read from the environment at every call.
std::string table_cache_dir();

}  // namespace filmgrain
