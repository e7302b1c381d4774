// filmgrain: MODEL.md section 8, dye layers: each developed grain leaves a
// cloud of dye whose density adds to its neighbours' (Beer-Lambert), instead
// of an opaque disc.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "filmgrain/stock.h"
#include "image_formation.h"

namespace filmgrain {

/// Where a gaussian cloud is cut off, in cloud radii: its density there is
/// exp(-2 * 3^2) = 1.5e-8 of its peak (the error this adds to a pixel's
/// density is below 1.5e-8 * cloud_density per overlapping cloud).
inline constexpr double kGaussianCloudReach = 3.0;

/// How far a developed grain's image reaches, in grain radii: 1 for silver
/// (the disc), cloud_diameter_ratio for disc clouds, kGaussianCloudReach
/// times that for gaussian ones.
double image_reach_factor(const Layer& layer);

/// The area a developed grain of area a blocks in the Boolean model, over a:
/// a uniformly exposed patch has E[T] = exp(-sum over populations of
/// grains_per_um2 E[a P] * factor) (MODEL.md 5 and 8). 1 for silver; for
/// dye, integral over the plane of (1 - 10^-D_1(x)) over a: disc clouds
/// ratio^2 (1 - 10^-cloud_density); gaussian clouds ratio^2 Ein(k) / 2
/// with k = cloud_density ln 10 and Ein(k) = integral_0^k (1 - e^-t) / t dt
/// (the per-point clamp at max_density is not in this expectation).
double cloud_area_factor(const Layer& layer);

/// Scratch space for dye_transmittance, reused between calls.
struct DyeScratch {
    std::vector<size_t> offsets, fill, members;
    std::vector<int64_t> density;  ///< fixed point, 2^-32 density units
    std::vector<std::pair<double, int>> ends;
    std::vector<double> level, factor;
};

/// MODEL.md 8's image of a dye layer: the mean of 10^-min(D(x), max_density)
/// over each pixel of the block [x0, x1) x [y0, y1) (px x py micrometre
/// pixels), D(x) the sum of the clouds of the developed grains `grains`
/// (their centres and grain radii). Disc clouds: exact along `samples`
/// rows per pixel (D is a whole number of clouds between chord ends), the
/// midpoint rule across them. Gaussian clouds: sampled at `samples` x
/// `samples` points per pixel (the centres of its sub-pixels), densities
/// summed in fixed point (2^-32 units, each cloud's share rounded once) so
/// that the sum does not depend on the grains' order. Either way the result
/// depends only on the grains and absolute pixel coordinates: the same for
/// any tiling. Grains whose cloud does not reach the block may be passed.
/// Writes (x1-x0)*(y1-y0) transmittances row-major. `samples`: [1, 256].
void dye_transmittance(const std::vector<Disc>& grains, const Layer& layer, double max_density,
                       int64_t x0, int64_t y0, int64_t x1, int64_t y1, double px_um,
                       double py_um, int samples, DyeScratch& scratch, double* transmittance);

}  // namespace filmgrain
