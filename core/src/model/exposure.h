// filmgrain: MODEL.md section 2, exposure: scene-linear values to lux-seconds
// to absorbed photons, with the image box-reconstructed over input pixels.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "filmgrain/image.h"
#include "filmgrain/render.h"
#include "filmgrain/stock.h"

namespace filmgrain {

/// Incident photons per square micrometre per lux-second at 555 nm.
inline constexpr double kPhotonsPerUm2PerLxs = 4.09e3;

/// log2(10): stops per decade of exposure (exposure_stops counts stops, log H
/// decades).
inline constexpr double kStopsPerDecade = 3.3219280948873623;

/// Exposure per unit of scene-linear value, lux-seconds:
/// H = v / 0.18 * exposure_at_grey_lxs * 2^stops.
double exposure_lxs_per_unit_value(double exposure_at_grey_lxs, double exposure_stops);

/// The largest exposure the kinetics represent (MODEL.md 2, extremes), as
/// the mean absorbed photons of a mean-sized grain of a layer's most
/// sensitive population: about 2^33 times the count at the built-in
/// stocks' grey point, where every grain but the very smallest develops.
/// Brighter values (+Inf included) are clamped to it: the light saturates.
/// (The early-stopped chain decides such a grain within its first few
/// hundred events; the photons it never reaches cost nothing.)
inline constexpr double kMaxMeanPhotonsPerGrain = 1e10;

/// The exposure value v at which a layer saturates: kMaxMeanPhotonsPerGrain
/// over the largest mean absorbed photons per unit value of a mean-sized
/// grain of its populations (quantum_efficiency * 4.09e3 * H per unit
/// value * mean disc area, MODEL.md 2), for `lxs_per_value` lux-seconds a
/// unit of value. +Inf for a layer whose grains absorb nothing.
double saturation_value(const Layer& layer, double lxs_per_value);

/// Exact area of the intersection of the disc (centre cx, cy; radius r) with
/// the rectangle [x0, x1] x [y0, y1], all in micrometres. Closed form (the
/// signed quadrant function of the disc at the four corners).
double disc_rect_area_um2(double cx_um, double cy_um, double r_um, double x0_um, double y0_um,
                          double x1_um, double y1_um);

/// The exposure value v of one layer over the input image (MODEL.md 2):
/// v = dot(sensitivity, rgb); a grey input y is rgb = (y, y, y). The
/// extremes (MODEL.md 2): a pixel with a NaN channel has v = 0 (it exposes
/// nothing); a channel of +-Inf counts only where its weight is not 0;
/// negative v is 0 (there is no negative light); v above `max_value`
/// (saturation_value), +Inf included, is max_value: the light saturates.
/// Outside the image v = 0. Thread safety: const, shareable; holds a view,
/// not a copy. Beyond the image (MODEL.md 2): `edge` clamp, the nearest
/// edge pixel's v (the scene continues); gate, 0.
class LayerExposure {
public:
    LayerExposure(const ImageView& input, const std::array<double, 3>& sensitivity,
                  double input_pitch_um, double max_value, FrameEdge edge);

    /// v of input pixel (ix, iy) (whole-image coordinates), which must lie
    /// inside the view's window.
    double value(int64_t ix, int64_t iy) const
    {
        const double v = weighted_sum(ix, iy);
        if (!(v > 0.0))  // NaN, negative or zero
            return 0.0;
        return v < m_max_value ? v : m_max_value;
    }

    /// Whether input pixel (ix, iy) saturates: v reaches max_value.
    bool saturates(int64_t ix, int64_t iy) const { return weighted_sum(ix, iy) >= m_max_value; }

    /// The value at which the layer saturates.
    double max_value() const { return m_max_value; }

    /// Integral of v over the disc, value x square micrometres, against the
    /// box-reconstructed image and what lies beyond it (exact up to
    /// rounding).
    double integrate_over_disc(double cx_um, double cy_um, double r_um) const;

    /// v at the input pixel containing a point (beyond the image: the
    /// edge's, or 0).
    double value_at(double x_um, double y_um) const;

    /// Mean of v over the rectangle [x0, x1] x [y0, y1] (box-reconstructed
    /// image, and beyond it the edge's or 0): the input pixels it overlaps,
    /// weighted by the overlap.
    double mean_over_rect(double x0_um, double y0_um, double x1_um, double y1_um) const;

    /// mean_over_rect of every cell of a grid, row by row into `means`: the
    /// rectangles [xs_um[i], xs_um[i + 1]] x [ys_um[j], ys_um[j + 1]]. Each
    /// column's and row's overlaps are found once, not once a cell (the
    /// same sums in the same order: the same values).
    void means_over_grid(const std::vector<double>& xs_um, const std::vector<double>& ys_um,
                         double* means) const;

    /// What lies beyond the image.
    FrameEdge edge() const { return m_edge; }
    /// The image pixel whose v a pixel index (any, beyond the image too)
    /// reads with edge() == clamp: the nearest one.
    int64_t clamp_x(int64_t ix) const { return std::clamp<int64_t>(ix, 0, m_input.frame_width() - 1); }
    int64_t clamp_y(int64_t iy) const { return std::clamp<int64_t>(iy, 0, m_input.frame_height() - 1); }

private:
    /// An input pixel (column or row; beyond the image with clamp, the
    /// nearest edge one) that an interval overlaps, and by how much.
    struct Overlap {
        int64_t index;
        double length_um;
    };
    /// The input pixels along one axis of `pixels` that [a_um, b_um]
    /// overlaps by more than 0, in order (gate: only those of the image).
    void overlaps(double a_um, double b_um, int64_t pixels, std::vector<Overlap>& out) const;

    /// integrate_over_disc of a disc inside the image's pixels [ix0, ix1] x
    /// [iy0, iy1], and of one reaching beyond the image (clamp).
    double integrate_over_pixels(double cx_um, double cy_um, double r_um, int64_t ix0,
                                 int64_t iy0, int64_t ix1, int64_t iy1) const;
    double integrate_over_disc_beyond(double cx_um, double cy_um, double r_um) const;

    /// dot(sensitivity, rgb) of a pixel, unclamped: NaN where a channel is
    /// NaN, channels of weight 0 left out (0 x Inf is not NaN here).
    double weighted_sum(int64_t ix, int64_t iy) const
    {
        const float* p = m_input.pixel(ix, iy);
        if (m_input.channels < 3)
            return m_grey_weight == 0.0 ? (std::isnan(p[0]) ? p[0] : 0.0)
                                        : m_grey_weight * p[0];
        if (std::isnan(p[0]) || std::isnan(p[1]) || std::isnan(p[2]))
            return std::numeric_limits<double>::quiet_NaN();
        double v = 0.0;
        for (int c = 0; c < 3; ++c)
            if (m_sensitivity[c] != 0.0)
                v += m_sensitivity[c] * p[c];
        return v;
    }

    ImageView m_input;
    std::array<double, 3> m_sensitivity;
    double m_grey_weight;
    double m_pitch_um;
    double m_max_value;
    FrameEdge m_edge;
};

}  // namespace filmgrain
