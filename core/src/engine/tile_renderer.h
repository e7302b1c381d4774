// filmgrain: rendering one tile of the scan with the paths a plan chose,
// per layer: grain by grain (MODEL.md 1-5 in order: generation, exposure,
// kinetics or the tabulated curve, development, the image) or at pixel
// scale. The driver (render.cpp) schedules tiles; the physics lives in the
// per-section files.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "model/dye.h"
#include "engine/engine_plan.h"
#include "filmgrain/render.h"
#include "model/geometry.h"
#include "kernels/grain_kernel.h"
#include "model/image_formation.h"
#include "kernels/coverage_grid.h"
#include "kernels/coverage_raster.h"
#include "kernels/coverage_scanline.h"

namespace filmgrain {

/// Per-worker scratch buffers, reused from tile to tile.
struct TileScratch {
    std::vector<Disc> discs;
    /// One past each population's last disc in `discs` (dye layers).
    std::vector<size_t> population_end;
    std::vector<double> fraction;
    GridCoverageScratch grid;
    ScanlineScratch scanline;
    RasterScratch raster;
    DyeScratch dye;
    ExposurePlane plane;
    std::vector<double> values;
    std::vector<double> log_factor;  ///< per pixel, pixel scale of an inhibited layer
    std::vector<uint8_t> drawn;  ///< per pixel, a layer with a pixel floor: at pixel scale
    std::vector<uint8_t> columns;  ///< per column of a band of rows: one not drawn
    std::vector<double> edges_x, edges_y;  ///< the tile's scan pixel edges, um (pixel scale)
    /// Grains visited, for the stop check (poll_stop).
    uint32_t grains_seen = 0;
    /// A cell's grains, their mean photons, develop uniforms and decisions
    /// from the curve (develop_fast).
    FastGrains::Batch batch;
    std::vector<double> lambda, u;
    std::vector<uint8_t> decided;
    std::vector<uint32_t> touching;  ///< indices into the batch
    /// The discs of a batch whose exposure is integrated, and their
    /// integrals from the plane.
    struct DiscBatch {
        std::vector<double> x, y, r, value;
        void resize(size_t n)
        {
            if (x.size() < n) {
                x.resize(n);
                y.resize(n);
                r.resize(n);
                value.resize(n);
            }
        }
    } disc_batch;
};


/// Renders tiles with the paths of a plan. The plan is read-only and shared
/// by all workers; the counters are atomics. Every argument must outlive
/// the renderer.
class TileRenderer {
public:
    TileRenderer(const Stock& stock, const SceneSettings& scene, const FrameGeometry& frame,
                 const Roi& roi, const std::vector<LayerPlan>& layers, float* out,
                 const std::atomic<bool>& stop);
    ~TileRenderer();

    /// Renders the scan pixels [x0, x1) x [y0, y1) of every layer into
    /// `out` (pixel-interleaved, layer by layer, over the ROI). Throws
    /// Stopped once `stop` is set (checked every few thousand grains).
    void render_tile(TileScratch& scratch, int64_t x0, int64_t y0, int64_t x1, int64_t y1);

    /// Per layer: the counters summed over the tiles rendered, the plan's
    /// path, reason and error estimate, and the ROI's mean density.
    void fill_stats(RenderStats& stats) const;

private:
    class Impl;
    std::unique_ptr<Impl> m_impl;
};

}  // namespace filmgrain
