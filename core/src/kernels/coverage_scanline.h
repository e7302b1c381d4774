// filmgrain: MODEL.md 5's covered fraction of each pixel sampled on
// sub-scanlines, the union of the discs' chords exact on each.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "model/image_formation.h"

namespace filmgrain {

/// Scratch space for scanline_coverage, reused between calls.
struct ScanlineScratch {
    std::vector<size_t> offsets;
    std::vector<std::pair<double, double>> chords;
    std::vector<size_t> fill;
};

/// Covered fraction of each pixel of the block [x0, x1) x [y0, y1) of a
/// grid of px x py micrometre pixels, sampled on `samples` sub-scanlines per
/// pixel row (at y = (row + (s + 0.5) / samples) py): on each sub-scanline
/// the union of the discs' chords is exact, so only the integration in y is
/// sampled (midpoint rule). Grain centres are uniformly random relative to
/// the grid, so the expected coverage equals the exact one (stratified
/// sampling of the area); what remains is a per-pixel error that shrinks
/// with `samples` and is measured in docs/. Writes (x1-x0)*(y1-y0) fractions
/// row-major into `fraction`. Depends only on the discs and absolute pixel
/// coordinates, never on the block: the same for any tiling.
void scanline_coverage(const std::vector<Disc>& discs, int64_t x0, int64_t y0, int64_t x1,
                       int64_t y1, double px_um, double py_um, int samples,
                       ScanlineScratch& scratch, double* fraction);

}  // namespace filmgrain
