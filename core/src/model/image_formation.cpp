// MODEL.md section 5: image formation (the exact covered area, density).
#include "model/image_formation.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

namespace filmgrain {

namespace {

constexpr double kTwoPi = 2.0 * M_PI;

/// Angular intervals on one circle, in [0, 2 pi).
struct ArcSet {
    std::vector<std::pair<double, double>> arcs;
    bool all = false;

    void clear()
    {
        arcs.clear();
        all = false;
    }

    /// Excludes the arc centred at angle `centre` with half-width `half`.
    void exclude(double centre, double half)
    {
        if (half <= 0.0)
            return;
        if (half >= M_PI) {
            all = true;
            return;
        }
        double a = centre - half;
        a -= kTwoPi * std::floor(a / kTwoPi);
        const double b = a + 2.0 * half;
        if (b <= kTwoPi) {
            arcs.emplace_back(a, b);
        } else {
            arcs.emplace_back(a, kTwoPi);
            arcs.emplace_back(0.0, b - kTwoPi);
        }
    }

    /// Excludes the part of the circle beyond a line at signed distance t*r
    /// from the centre, on the side of angle `centre`: the points with
    /// cos(theta - centre) > t.
    void exclude_beyond(double centre, double t)
    {
        if (t >= 1.0)
            return;
        if (t <= -1.0) {
            all = true;
            return;
        }
        exclude(centre, std::acos(t));
    }
};

/// Green's theorem term 1/2 integral (x dy - y dx) along a circle arc.
double arc_term(double cx, double cy, double r, double a, double b)
{
    return 0.5 * (r * r * (b - a) + cx * r * (std::sin(b) - std::sin(a))
                  - cy * r * (std::cos(b) - std::cos(a)));
}

/// Length of the union of intervals clipped to [0, limit].
double union_length(std::vector<std::pair<double, double>>& iv, double limit)
{
    std::sort(iv.begin(), iv.end());
    double total = 0.0, cur_a = 0.0, cur_b = -1.0;
    bool open = false;
    for (auto [a, b] : iv) {
        a = std::max(a, 0.0);
        b = std::min(b, limit);
        if (b <= a)
            continue;
        if (open && a <= cur_b) {
            cur_b = std::max(cur_b, b);
        } else {
            if (open)
                total += cur_b - cur_a;
            cur_a = a;
            cur_b = b;
            open  = true;
        }
    }
    if (open)
        total += cur_b - cur_a;
    return total;
}

}  // namespace

double union_coverage_um2(const Disc* discs, size_t count, double x0_um, double y0_um,
                          double x1_um, double y1_um)
{
    const double w = x1_um - x0_um, h = y1_um - y0_um;
    if (count == 0 || !(w > 0.0) || !(h > 0.0))
        return 0.0;
    // Work relative to the rectangle's corner: the bottom and left edges
    // then contribute nothing, and coordinates stay small.
    thread_local std::vector<Disc> local;
    local.resize(count);
    for (size_t i = 0; i < count; ++i) {
        local[i] = { discs[i].x_um - x0_um, discs[i].y_um - y0_um, discs[i].r_um };
        const Disc& d       = local[i];
        const auto inside = [&](double x, double y) {
            return (x - d.x_um) * (x - d.x_um) + (y - d.y_um) * (y - d.y_um) <= d.r_um * d.r_um;
        };
        if (inside(0, 0) && inside(w, 0) && inside(0, h) && inside(w, h))
            return w * h;  // one disc covers the whole rectangle
    }

    double area = 0.0;
    thread_local ArcSet excluded;
    for (size_t i = 0; i < count; ++i) {
        const Disc& di = local[i];
        excluded.clear();
        // The parts of the circle outside the rectangle.
        excluded.exclude_beyond(M_PI, di.x_um / di.r_um);               // x < 0
        excluded.exclude_beyond(0.0, (w - di.x_um) / di.r_um);          // x > w
        excluded.exclude_beyond(1.5 * M_PI, di.y_um / di.r_um);         // y < 0
        excluded.exclude_beyond(0.5 * M_PI, (h - di.y_um) / di.r_um);   // y > h
        // The parts inside another disc.
        for (size_t j = 0; j < count && !excluded.all; ++j) {
            if (j == i)
                continue;
            const Disc& dj  = local[j];
            const double dx = dj.x_um - di.x_um, dy = dj.y_um - di.y_um;
            const double dist = std::hypot(dx, dy);
            if (dist >= di.r_um + dj.r_um)
                continue;  // apart
            if (dist + di.r_um <= dj.r_um) {
                // i lies inside j; of two identical discs the later one
                // is the hidden one, so exactly one boundary remains.
                if (di.r_um < dj.r_um || dist > 0.0 || j < i)
                    excluded.all = true;
                continue;
            }
            if (dist + dj.r_um <= di.r_um)
                continue;  // j lies inside i
            const double c = (di.r_um * di.r_um + dist * dist - dj.r_um * dj.r_um)
                             / (2.0 * di.r_um * dist);
            excluded.exclude(std::atan2(dy, dx), std::acos(std::clamp(c, -1.0, 1.0)));
        }
        if (excluded.all)
            continue;
        // The visible arcs are the gaps between the excluded ones.
        auto& arcs = excluded.arcs;
        std::sort(arcs.begin(), arcs.end());
        double cursor = 0.0;
        for (const auto& [a, b] : arcs) {
            if (a > cursor)
                area += arc_term(di.x_um, di.y_um, di.r_um, cursor, a);
            cursor = std::max(cursor, b);
        }
        if (cursor < kTwoPi)
            area += arc_term(di.x_um, di.y_um, di.r_um, cursor, kTwoPi);
    }

    // The rectangle's right (x = w, upwards) and top (y = h, leftwards)
    // edges where they lie inside the union.
    thread_local std::vector<std::pair<double, double>> right, top;
    right.clear();
    top.clear();
    for (size_t i = 0; i < count; ++i) {
        const Disc& d = local[i];
        const double ex = w - d.x_um, ey = h - d.y_um;
        if (std::fabs(ex) < d.r_um) {
            const double half = std::sqrt(d.r_um * d.r_um - ex * ex);
            right.emplace_back(d.y_um - half, d.y_um + half);
        }
        if (std::fabs(ey) < d.r_um) {
            const double half = std::sqrt(d.r_um * d.r_um - ey * ey);
            top.emplace_back(d.x_um - half, d.x_um + half);
        }
    }
    area += 0.5 * (w * union_length(right, h) + h * union_length(top, w));
    return std::clamp(area, 0.0, w * h);
}

double lens_area_um2(double r_um, double h_um)
{
    if (h_um >= 2.0 * r_um)
        return 0.0;
    const double h = std::max(0.0, h_um);
    return 2.0 * r_um * r_um * std::acos(h / (2.0 * r_um))
           - 0.5 * h * std::sqrt(std::max(0.0, 4.0 * r_um * r_um - h * h));
}

DensityFromTransmittance::DensityFromTransmittance(double max_density, double base_density)
    : m_min_transmittance(std::pow(10.0, -max_density)), m_base_density(base_density)
{
}

double density_from_transmittance(double transmittance, double max_density,
                                  double base_density)
{
    return DensityFromTransmittance(max_density, base_density)(transmittance);
}

}  // namespace filmgrain
