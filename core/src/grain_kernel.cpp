// The per-grain kernel of the fast paths: tables and the exposure plane.
#include "grain_kernel.h"

#include <algorithm>
#include <cmath>

namespace filmgrain {

FastGrains::FastGrains(const PopulationGrains& grains, int quantiles)
    : m_grains(grains), m_quantiles(std::max(quantiles, 1))
{
    const double nq = static_cast<double>(m_quantiles);
    double area_table = 0.0, area_exact = 0.0, total = 0.0;
    for (const PopulationGrains::Bin& bin : grains.bins()) {
        // A bin's z (of ln d) by inverting its truncated normal; u = 0 or 1
        // may be a bound at -inf (radius 0 for bin 0).
        const auto radius = [&](double u) {
            const double z = bin.z.sample(std::min(u, 1.0 - 0x1.0p-53));
            return std::isfinite(z) ? grains.radius_at_z_um(z) : 0.0;
        };
        std::vector<double> table(static_cast<size_t>(m_quantiles) + 2);
        for (int k = 0; k <= m_quantiles; ++k)
            table[static_cast<size_t>(k)] = radius(k / nq);
        table.back() = table[static_cast<size_t>(m_quantiles)];
        // Errors at the midpoints, where linear interpolation errs most, and
        // of the mean disc area: per interval, the table's mean r^2 (exact
        // for a linear r) against Simpson's rule on the true r^2.
        double a_table = 0.0, a_exact = 0.0;
        for (int k = 0; k < m_quantiles; ++k) {
            const double r0 = table[static_cast<size_t>(k)], r1 = table[static_cast<size_t>(k) + 1];
            const double exact  = radius((k + 0.5) / nq);
            const double interp = 0.5 * (r0 + r1);
            if (exact > 0.0)
                m_max_radius_error = std::max(m_max_radius_error, std::fabs(interp - exact) / exact);
            a_table += (r0 * r0 + r0 * r1 + r1 * r1) / 3.0;
            a_exact += (r0 * r0 + 4.0 * exact * exact + r1 * r1) / 6.0;
        }
        area_table += bin.grains_per_um2 * a_table / nq;
        area_exact += bin.grains_per_um2 * a_exact / nq;
        total += bin.grains_per_um2;
        m_radius.push_back(std::move(table));
    }
    m_mean_area_error = total > 0.0 && area_exact > 0.0 ? std::fabs(area_table - area_exact) / area_exact : 0.0;
}

void ExposurePlane::fill(const LayerExposure& exposure, const FrameGeometry& frame,
                         const RectUm& rect)
{
    const double p = frame.input_pitch_um;
    const auto clip = [](double v, int64_t n) {
        return std::clamp<int64_t>(static_cast<int64_t>(std::clamp(v, -1.0, 9e18)), 0, n);
    };
    const int64_t x0 = clip(std::floor(rect.x0_um / p), frame.input_width);
    const int64_t y0 = clip(std::floor(rect.y0_um / p), frame.input_height);
    const int64_t x1 = clip(std::floor(rect.x1_um / p) + 1, frame.input_width);
    const int64_t y1 = clip(std::floor(rect.y1_um / p) + 1, frame.input_height);
    m_inv_pitch = 1.0 / p;
    m_x0 = static_cast<double>(x0);
    m_y0 = static_cast<double>(y0);
    m_w  = static_cast<double>(x1 - x0);
    m_h  = static_cast<double>(y1 - y0);
    m_stride = static_cast<size_t>(x1 - x0);
    m_v.resize(static_cast<size_t>((x1 - x0) * (y1 - y0)));
    size_t i = 0;
    for (int64_t y = y0; y < y1; ++y)
        for (int64_t x = x0; x < x1; ++x)
            m_v[i++] = static_cast<float>(exposure.value(x, y));
}

}  // namespace filmgrain
