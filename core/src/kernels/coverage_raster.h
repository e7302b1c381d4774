// filmgrain: MODEL.md 5's covered fraction of each pixel sampled at
// 64 x samples points, a bit per point.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "model/image_formation.h"

namespace filmgrain {

/// Scratch space for raster_coverage, reused between calls.
struct RasterScratch {
    std::vector<uint64_t> bits;
    std::vector<int> count;
    std::vector<double> span;
    /// Use the portable builds even where the processor has AVX2 or
    /// AVX-512 popcounts (for the test that every build gives the same
    /// fractions).
    bool portable = false;
};

/// Covered fraction of each pixel of the block [x0, x1) x [y0, y1) of a
/// grid of px x py micrometre pixels, sampled at 64 x samples points per
/// pixel (the centres of its sub-pixels: 64 across, `samples` rows down):
/// the fraction of those points inside some disc. A bit per point (a word
/// per pixel and row), set by each disc's span on each sample row, then
/// counted per pixel. Grain centres are uniformly random
/// relative to the grid, so the expected coverage equals the exact one
/// (stratified point sampling of the area); what remains is a per-pixel
/// error that shrinks with `samples` and is measured against exact coverage
/// in docs/performance. `samples`: [1, 256]. Depends only
/// on the discs and absolute pixel coordinates: the same for any tiling.
void raster_coverage(const std::vector<Disc>& discs, int64_t x0, int64_t y0, int64_t x1,
                     int64_t y1, double px_um, double py_um, int samples,
                     RasterScratch& scratch, double* fraction);

}  // namespace filmgrain
