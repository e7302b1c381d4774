// filmgrain: MODEL.md section 5, image formation: developed discs to
// transmittance to negative density.
#pragma once

#include <cstddef>

namespace filmgrain {

/// An opaque developed grain, micrometres.
struct Disc {
    double x_um = 0.0;
    double y_um = 0.0;
    double r_um = 0.0;
};

/// True if the disc and the rectangle [x0, x1] x [y0, y1] overlap with
/// positive area.
bool disc_touches_rect(const Disc& d, double x0_um, double y0_um, double x1_um, double y1_um);

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

/// Negative density from transmittance: D = -log10(max(T, 10^-max_density))
/// + base_density (MODEL.md 5). The clamp is part of the model.
double density_from_transmittance(double transmittance, double max_density,
                                  double base_density);

}  // namespace filmgrain
