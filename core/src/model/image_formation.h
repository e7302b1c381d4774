// filmgrain: MODEL.md section 5, image formation: developed discs to
// transmittance to negative density.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace filmgrain {

/// An opaque developed grain, micrometres.
struct Disc {
    double x_um = 0.0;
    double y_um = 0.0;
    double r_um = 0.0;
};

/// True if the disc and the rectangle [x0, x1] x [y0, y1] overlap with
/// positive area.
inline bool disc_touches_rect(const Disc& d, double x0_um, double y0_um, double x1_um,
                              double y1_um)
{
    const double dx = std::max({ x0_um - d.x_um, 0.0, d.x_um - x1_um });
    const double dy = std::max({ y0_um - d.y_um, 0.0, d.y_um - y1_um });
    return dx * dx + dy * dy < d.r_um * d.r_um;
}

/// Area shared by two discs of radius r_um whose centres are h_um apart
/// (the "lens"), square micrometres; 0 from h = 2 r.
double lens_area_um2(double r_um, double h_um);

/// Exact area of the rectangle [x0, x1] x [y0, y1] covered by the union of
/// the discs, square micrometres. Green's theorem over the boundary of
/// (union of discs) intersected with the rectangle: the circle arcs that lie
/// inside the rectangle and outside every other disc, plus the rectangle
/// edges that lie inside the union. O(n^2 log n) for n discs; discs that do
/// not touch the rectangle may be passed and contribute nothing. The result
/// depends only on the discs, their order and the rectangle, so it is the
/// same whichever tile computes it.
double union_coverage_um2(const Disc* discs, size_t count, double x0_um, double y0_um,
                          double x1_um, double y1_um);

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

/// Negative density from transmittance: D = -log10(max(T, 10^-max_density))
/// + base_density (MODEL.md 5). The clamp is part of the model.
double density_from_transmittance(double transmittance, double max_density,
                                  double base_density);

}  // namespace filmgrain
