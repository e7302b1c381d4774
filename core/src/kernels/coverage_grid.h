// filmgrain: MODEL.md 5's exact covered fraction of every pixel of a
// block at once (union_coverage_um2's quantity, by Green's theorem).
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "model/image_formation.h"

namespace filmgrain {

/// A point on a circle: its angle in [0, 2 pi] and, computed once, its
/// cosine and sine.
struct ArcPoint {
    double angle, c, s;
};

/// Scratch space for grid_coverage, reused between calls.
struct GridCoverageScratch {
    std::vector<size_t> cell_offsets, cell_fill, cell_discs, stamp;
    std::vector<std::pair<double, double>> arcs;
    std::vector<ArcPoint> crossings;
    std::vector<size_t> line_offsets, line_fill;
    std::vector<std::pair<double, double>> line_chords;
    std::vector<double> area;
};

/// Exact covered fraction of each pixel of the block [x0, x1) x [y0, y1)
/// of a grid of px x py micrometre pixels by the union of the discs: the
/// same quantity as union_coverage_um2 for every pixel, computed for the
/// whole block at once. Green's theorem over the union's boundary: each
/// disc's visible arcs (outside every other disc) are found once and cut at
/// the pixel grid lines, and each grid line's stretches inside the union are
/// found once, so the cost grows with discs and neighbours, not with pixels
/// times discs squared. Every disc passed must touch the block (discs that
/// do not can be left out: they cannot change a pixel of it). Depends only
/// on the discs, their order and absolute pixel coordinates, so any tiling
/// gives bit-identical fractions.
void grid_coverage(const std::vector<Disc>& discs, int64_t x0, int64_t y0, int64_t x1,
                   int64_t y1, double px_um, double py_um, GridCoverageScratch& scratch,
                   double* fraction);

}  // namespace filmgrain
