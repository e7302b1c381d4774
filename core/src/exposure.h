// filmgrain: MODEL.md section 2, exposure: scene-linear values to lux-seconds
// to absorbed photons, with the image box-reconstructed over input pixels.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>

#include "filmgrain/image.h"
#include "filmgrain/stock.h"

namespace filmgrain {

/// Incident photons per square micrometre per lux-second at 555 nm.
inline constexpr double kPhotonsPerUm2PerLxs = 4.09e3;
/// The scene-linear value that receives exposure_at_grey_lxs.
inline constexpr double kGreyValue = 0.18;

/// Exposure per unit of scene-linear value, lux-seconds:
/// H = v / 0.18 * exposure_at_grey_lxs * 2^stops.
double exposure_lxs_per_unit_value(double exposure_at_grey_lxs, double exposure_stops);

/// Exact area of the intersection of the disc (centre cx, cy; radius r) with
/// the rectangle [x0, x1] x [y0, y1], all in micrometres. Closed form (the
/// signed quadrant function of the disc at the four corners).
double disc_rect_area_um2(double cx_um, double cy_um, double r_um, double x0_um, double y0_um,
                          double x1_um, double y1_um);

/// The exposure value v of one layer over the input image (MODEL.md 2):
/// v = dot(sensitivity, rgb); a grey input y is rgb = (y, y, y). A pixel
/// with a non-finite channel (NaN, +-Inf) has v = 0, and negative v is
/// clamped to 0: there is no negative light. Outside the image v = 0.
/// Thread safety: const, shareable; holds a view, not a copy.
class LayerExposure {
public:
    LayerExposure(const ImageView& input, const std::array<double, 3>& sensitivity,
                  double input_pitch_um);

    /// v of input pixel (ix, iy) (whole-image coordinates), which must lie
    /// inside the view's window.
    double value(int64_t ix, int64_t iy) const
    {
        const float* p = m_input.pixel(ix, iy);
        double v;
        if (m_input.channels < 3) {
            if (!std::isfinite(p[0]))
                return 0.0;
            v = m_grey_weight * p[0];
        } else {
            if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
                return 0.0;
            v = m_sensitivity[0] * p[0] + m_sensitivity[1] * p[1] + m_sensitivity[2] * p[2];
        }
        return v > 0.0 ? v : 0.0;
    }

    /// Integral of v over the disc, value x square micrometres, against the
    /// box-reconstructed image (exact up to rounding).
    double integrate_over_disc(double cx_um, double cy_um, double r_um) const;

    /// v at the input pixel containing a point (0 outside the image).
    double value_at(double x_um, double y_um) const;

    /// Mean of v over the rectangle [x0, x1] x [y0, y1] (box-reconstructed
    /// image, 0 outside it): the input pixels it overlaps, weighted by the
    /// overlap.
    double mean_over_rect(double x0_um, double y0_um, double x1_um, double y1_um) const;

private:
    ImageView m_input;
    std::array<double, 3> m_sensitivity;
    double m_grey_weight;
    double m_pitch_um;
};

}  // namespace filmgrain
