// MODEL.md section 2: exposure.
#include "model/exposure.h"

#include "model/geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace filmgrain {

double exposure_lxs_per_unit_value(double exposure_at_grey_lxs, double exposure_stops)
{
    return exposure_at_grey_lxs / kGreyValue * std::exp2(exposure_stops);
}

namespace {

/// Area of the disc of radius r centred at the origin within [0, x] x [0, y]
/// for x, y >= 0.
double quadrant_area(double x, double y, double r)
{
    x = std::min(x, r);
    y = std::min(y, r);
    const double r2 = r * r;
    if (x * x + y * y <= r2)
        return x * y;
    // I(a) = integral_0^a sqrt(r^2 - u^2) du: the area of the quarter disc
    // below a (or left of a, by symmetry).
    const auto integral = [&](double a) {
        const double s = std::clamp(a / r, -1.0, 1.0);
        return 0.5 * (a * std::sqrt(std::max(0.0, r2 - a * a)) + r2 * std::asin(s));
    };
    if (x >= r)  // the whole quarter disc's width: only y cuts it
        return y >= r ? 0.25 * M_PI * r2 : integral(y);
    if (y >= r)
        return integral(x);
    // The circle's height at x is below y: columns [0, xc] are full height y,
    // columns [xc, x] end on the circle.
    const double xc = std::sqrt(std::max(0.0, r2 - y * y));
    return y * xc + (integral(x) - integral(xc));
}

/// Signed version: the integral over [0, x] x [0, y] with orientation.
double signed_quadrant_area(double x, double y, double r)
{
    const double a = quadrant_area(std::fabs(x), std::fabs(y), r);
    return ((x < 0.0) != (y < 0.0)) ? -a : a;
}

}  // namespace

double disc_rect_area_um2(double cx_um, double cy_um, double r_um, double x0_um, double y0_um,
                          double x1_um, double y1_um)
{
    const double ax = x0_um - cx_um, bx = x1_um - cx_um;
    const double ay = y0_um - cy_um, by = y1_um - cy_um;
    if (ax >= r_um || bx <= -r_um || ay >= r_um || by <= -r_um || r_um <= 0.0)
        return 0.0;
    const double area = signed_quadrant_area(bx, by, r_um) - signed_quadrant_area(ax, by, r_um)
                        - signed_quadrant_area(bx, ay, r_um)
                        + signed_quadrant_area(ax, ay, r_um);
    return std::max(0.0, area);
}

double saturation_value(const Layer& layer, double lxs_per_value)
{
    double photons_per_value = 0.0;  // of a mean-sized grain, the largest
    for (const Population& pop : layer.populations)
        photons_per_value
            = std::max(photons_per_value, pop.quantum_efficiency * kPhotonsPerUm2PerLxs
                                              * lxs_per_value * mean_disc_area_um2(pop));
    return photons_per_value > 0.0 ? kMaxMeanPhotonsPerGrain / photons_per_value
                                   : std::numeric_limits<double>::infinity();
}

LayerExposure::LayerExposure(const ImageView& input, const std::array<double, 3>& sensitivity,
                             double input_pitch_um, double max_value, FrameEdge edge)
    : m_input(input)
    , m_sensitivity(sensitivity)
    , m_grey_weight(sensitivity[0] + sensitivity[1] + sensitivity[2])
    , m_pitch_um(input_pitch_um)
    , m_max_value(max_value)
    , m_edge(edge)
{
}

namespace {

/// A pixel index as an integer, for indices of any size (clamped far
/// beyond any image: the edge's pixel then).
int64_t pixel_index(double f) { return static_cast<int64_t>(std::clamp(f, -9e18, 9e18)); }

}  // namespace

double LayerExposure::value_at(double x_um, double y_um) const
{
    const double fx = std::floor(x_um / m_pitch_um), fy = std::floor(y_um / m_pitch_um);
    if (fx < 0.0 || fy < 0.0 || fx >= static_cast<double>(m_input.frame_width())
        || fy >= static_cast<double>(m_input.frame_height())) {
        if (m_edge == FrameEdge::gate || std::isnan(fx) || std::isnan(fy))
            return 0.0;
        return value(clamp_x(pixel_index(fx)), clamp_y(pixel_index(fy)));
    }
    return value(static_cast<int64_t>(fx), static_cast<int64_t>(fy));
}

void LayerExposure::overlaps(double a_um, double b_um, int64_t pixels,
                             std::vector<Overlap>& out) const
{
    out.clear();
    const double p = m_pitch_um;
    const double n = static_cast<double>(pixels);
    const bool clamp = m_edge == FrameEdge::clamp;
    // Every pixel the interval overlaps; with clamp, beyond the image the
    // nearest edge pixel's.
    const double f1 = clamp ? std::ceil(b_um / p) : std::min(std::ceil(b_um / p), n);
    for (double f = clamp ? std::floor(a_um / p) : std::max(std::floor(a_um / p), 0.0); f < f1;
         ++f) {
        const double o = std::min(b_um, (f + 1) * p) - std::max(a_um, f * p);
        if (o > 0.0)
            out.push_back({ clamp ? std::clamp<int64_t>(pixel_index(f), 0, pixels - 1)
                                  : static_cast<int64_t>(f),
                            o });
    }
}

double LayerExposure::mean_over_rect(double x0_um, double y0_um, double x1_um,
                                     double y1_um) const
{
    double mean = 0.0;
    means_over_grid({ x0_um, x1_um }, { y0_um, y1_um }, &mean);
    return mean;
}

void LayerExposure::means_over_grid(const std::vector<double>& xs_um,
                                    const std::vector<double>& ys_um, double* means) const
{
    if (xs_um.size() < 2 || ys_um.size() < 2)
        return;
    const size_t nx = xs_um.size() - 1, ny = ys_um.size() - 1;
    // The columns' overlaps, end to end, and where each column's start.
    std::vector<Overlap> all, one;
    std::vector<size_t> column_start { 0 };
    for (size_t i = 0; i < nx; ++i) {
        overlaps(xs_um[i], xs_um[i + 1], m_input.frame_width(), one);
        all.insert(all.end(), one.begin(), one.end());
        column_start.push_back(all.size());
    }
    for (size_t j = 0; j < ny; ++j) {
        overlaps(ys_um[j], ys_um[j + 1], m_input.frame_height(), one);
        const double height_um = ys_um[j + 1] - ys_um[j];
        for (size_t i = 0; i < nx; ++i) {
            double sum = 0.0;
            for (const Overlap& row : one)
                for (size_t c = column_start[i]; c < column_start[i + 1]; ++c)
                    sum += all[c].length_um * row.length_um * value(all[c].index, row.index);
            const double area = (xs_um[i + 1] - xs_um[i]) * height_um;
            means[j * nx + i] = area > 0.0 ? sum / area : 0.0;
        }
    }
}

double LayerExposure::integrate_over_disc(double cx_um, double cy_um, double r_um) const
{
    const double p = m_pitch_um;
    // Input pixels the disc's bounding box touches, clipped to the image.
    const double w = static_cast<double>(m_input.frame_width());
    const double h = static_cast<double>(m_input.frame_height());
    const double fx0 = std::floor((cx_um - r_um) / p), fx1 = std::floor((cx_um + r_um) / p);
    const double fy0 = std::floor((cy_um - r_um) / p), fy1 = std::floor((cy_um + r_um) / p);
    const bool clamp = m_edge == FrameEdge::clamp;
    if (clamp && !(fx0 >= 0.0 && fy0 >= 0.0 && fx1 < w && fy1 < h))
        return integrate_over_disc_beyond(cx_um, cy_um, r_um);
    if (fx1 < 0.0 || fy1 < 0.0 || fx0 >= w || fy0 >= h)
        return 0.0;
    if (fx0 == fx1 && fy0 == fy1)  // the disc lies inside one pixel
        return value(static_cast<int64_t>(fx0), static_cast<int64_t>(fy0)) * M_PI * r_um * r_um;

    const int64_t ix0 = static_cast<int64_t>(std::max(fx0, 0.0));
    const int64_t iy0 = static_cast<int64_t>(std::max(fy0, 0.0));
    const int64_t ix1 = static_cast<int64_t>(std::min(fx1, w - 1.0));
    const int64_t iy1 = static_cast<int64_t>(std::min(fy1, h - 1.0));
    return integrate_over_pixels(cx_um, cy_um, r_um, ix0, iy0, ix1, iy1);
}

double LayerExposure::integrate_over_disc_beyond(double cx_um, double cy_um, double r_um) const
{
    // A disc reaching beyond the image, the scene continued (MODEL.md 2:
    // clamp): its pixels past the edge read the nearest edge pixel. Those
    // beyond on one side read one column (or row) of the image, so the
    // pixels the disc covers are grouped by the image pixel they read.
    const double p = m_pitch_um;
    const int64_t ix0 = pixel_index(std::floor((cx_um - r_um) / p));
    const int64_t ix1 = pixel_index(std::floor((cx_um + r_um) / p));
    const int64_t iy0 = pixel_index(std::floor((cy_um - r_um) / p));
    const int64_t iy1 = pixel_index(std::floor((cy_um + r_um) / p));
    // The image's columns [cx0, cx1] and rows [cy0, cy1] the disc reads, and
    // the film span each one covers: the edge ones reach to the disc's edge.
    const int64_t cx0 = clamp_x(ix0), cx1 = clamp_x(ix1);
    const int64_t cy0 = clamp_y(iy0), cy1 = clamp_y(iy1);
    const auto x_lo = [&](int64_t c) { return c == cx0 ? cx_um - r_um : static_cast<double>(c) * p; };
    const auto x_hi = [&](int64_t c) { return c == cx1 ? cx_um + r_um : static_cast<double>(c + 1) * p; };
    const auto y_lo = [&](int64_t c) { return c == cy0 ? cy_um - r_um : static_cast<double>(c) * p; };
    const auto y_hi = [&](int64_t c) { return c == cy1 ? cy_um + r_um : static_cast<double>(c + 1) * p; };
    double sum = 0.0;
    for (int64_t y = cy0; y <= cy1; ++y)
        for (int64_t x = cx0; x <= cx1; ++x) {
            const double v = value(x, y);
            if (v == 0.0)
                continue;
            sum += v * disc_rect_area_um2(cx_um, cy_um, r_um, x_lo(x), y_lo(y), x_hi(x), y_hi(y));
        }
    return sum;
}

double LayerExposure::integrate_over_pixels(double cx_um, double cy_um, double r_um, int64_t ix0,
                                            int64_t iy0, int64_t ix1, int64_t iy1) const
{
    const double p   = m_pitch_um;
    const int64_t nx = ix1 - ix0 + 1, ny = iy1 - iy0 + 1;
    // Signed quadrant function at the (nx+1) x (ny+1) pixel corners, relative
    // to the centre; a pixel's share is the difference of its four corners.
    thread_local std::vector<double> corners;
    corners.resize(static_cast<size_t>((nx + 1) * (ny + 1)));
    for (int64_t j = 0; j <= ny; ++j) {
        const double y = static_cast<double>(iy0 + j) * p - cy_um;
        for (int64_t i = 0; i <= nx; ++i) {
            const double x = static_cast<double>(ix0 + i) * p - cx_um;
            corners[static_cast<size_t>(j * (nx + 1) + i)] = signed_quadrant_area(x, y, r_um);
        }
    }
    double sum = 0.0;
    for (int64_t j = 0; j < ny; ++j)
        for (int64_t i = 0; i < nx; ++i) {
            const double v = value(ix0 + i, iy0 + j);
            if (v == 0.0)
                continue;
            const size_t c00 = static_cast<size_t>(j * (nx + 1) + i);
            const size_t c10 = c00 + static_cast<size_t>(nx + 1);
            const double area = corners[c10 + 1] - corners[c10] - corners[c00 + 1] + corners[c00];
            sum += v * std::max(0.0, area);
        }
    return sum;
}

}  // namespace filmgrain
