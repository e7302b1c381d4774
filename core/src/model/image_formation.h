// filmgrain: MODEL.md section 5, image formation: developed discs to
// transmittance to negative density. The exact area a union of discs covers
// in a rectangle (the model's reference) is here; the coverage kernels a
// render runs over whole blocks of pixels, one algorithm a file, are in
// kernels/: coverage_grid (exact), coverage_scanline, coverage_raster.
#pragma once

#include <algorithm>
#include <cmath>
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

/// Calls f(a, b) for each interval of the union of the intervals
/// [first, last) (pairs (a, b), sorted by a, non-empty range), in order.
template<typename It, typename F> inline void for_each_union_interval(It first, It last, F&& f)
{
    double a = first->first, b = first->second;
    for (auto it = first + 1; it != last; ++it) {
        if (it->first <= b) {
            b = std::max(b, it->second);
        } else {
            f(a, b);
            a = it->first;
            b = it->second;
        }
    }
    f(a, b);
}

/// log10(e): D = -log10 T = -kLog10E ln T (MODEL.md 5), so a relative
/// change dT/T of transmittance moves density by -kLog10E dT/T, and a
/// layer of n grains per um^2 of mean area a, each developing with
/// probability P, has density kLog10E n a P in the Boolean model's limit.
inline constexpr double kLog10E = 0.43429448190325176;

/// Negative density from transmittance: D = -log10(max(T, 10^-max_density))
/// + base_density (MODEL.md 5). The clamp is part of the model; here it is
/// given as its smallest transmittance, min_transmittance = 10^-max_density.
inline double clamped_density(double transmittance, double min_transmittance,
                              double base_density)
{
    return -std::log10(std::max(transmittance, min_transmittance)) + base_density;
}

/// clamped_density of a layer, made once (its clamp is a pow) and applied
/// to every pixel.
class DensityFromTransmittance {
public:
    DensityFromTransmittance(double max_density, double base_density);
    double operator()(double transmittance) const
    {
        return clamped_density(transmittance, m_min_transmittance, m_base_density);
    }
    /// 10^-max_density: the smallest transmittance the clamp lets through.
    double min_transmittance() const { return m_min_transmittance; }

private:
    double m_min_transmittance;
    double m_base_density;
};

/// DensityFromTransmittance(max_density, base_density)(transmittance).
double density_from_transmittance(double transmittance, double max_density,
                                  double base_density);

}  // namespace filmgrain
