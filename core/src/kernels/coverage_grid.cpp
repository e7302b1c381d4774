// Exact coverage of a block of pixels (coverage_grid.h).
#include "kernels/coverage_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

#include "util/bucket.h"

namespace filmgrain {

namespace {

/// A monotone stand-in for the angle of a unit vector (c, s): [0, 4) over
/// [0, 2 pi), exact at the axes and half a turn apart exactly 2 apart
/// ("diamond angle"), with no trigonometry.
double pseudo_angle(double c, double s)
{
    if (s >= 0.0)
        return c >= 0.0 ? s / (c + s) : 1.0 - c / (s - c);
    return c < 0.0 ? 2.0 - s / (-c - s) : 3.0 + c / (c - s);
}

ArcPoint arc_point(double c, double s) { return { pseudo_angle(c, s), c, s }; }

/// The intervals of circle i hidden inside other discs, as pairs of points
/// (ordered by pseudo-angle; one crossing the start of the circle is cut
/// in two). Returns false if the whole circle is hidden.
bool hidden_intervals(const std::vector<Disc>& discs, size_t i, const size_t* candidates,
                      size_t ncandidates, std::vector<std::pair<ArcPoint, ArcPoint>>& out)
{
    const Disc& di = discs[i];
    out.clear();
    for (size_t k = 0; k < ncandidates; ++k) {
        const size_t j = candidates[k];
        if (j == i)
            continue;
        const Disc& dj    = discs[j];
        const double dx   = dj.x_um - di.x_um, dy = dj.y_um - di.y_um;
        const double rsum = di.r_um + dj.r_um;
        const double d2   = dx * dx + dy * dy;
        if (d2 >= rsum * rsum)
            continue;  // apart
        const double dist = std::sqrt(d2);
        if (dist + di.r_um <= dj.r_um) {
            // i lies inside j; of two identical discs the later is hidden.
            if (di.r_um < dj.r_um || dist > 0.0 || j < i)
                return false;
            continue;
        }
        if (dist + dj.r_um <= di.r_um)
            continue;  // j lies inside i
        // The two intersection points: the direction to j turned by -+w,
        // cos w = (ri^2 + d^2 - rj^2) / (2 ri d).
        const double cw = std::clamp((di.r_um * di.r_um + d2 - dj.r_um * dj.r_um)
                                         / (2.0 * di.r_um * dist),
                                     -1.0, 1.0);
        const double sw = std::sqrt((1.0 - cw) * (1.0 + cw));
        const double ux = dx / dist, uy = dy / dist;
        const ArcPoint a = arc_point(ux * cw + uy * sw, uy * cw - ux * sw);
        const ArcPoint b = arc_point(ux * cw - uy * sw, uy * cw + ux * sw);
        if (a.angle <= b.angle) {
            out.emplace_back(a, b);
        } else {  // across the start of the circle
            out.emplace_back(a, ArcPoint { 4.0, 1.0, 0.0 });
            out.emplace_back(ArcPoint { 0.0, 1.0, 0.0 }, b);
        }
    }
    return true;
}

}  // namespace

void grid_coverage(const std::vector<Disc>& discs, int64_t x0, int64_t y0, int64_t x1,
                   int64_t y1, double px_um, double py_um, GridCoverageScratch& scratch,
                   double* fraction)
{
    const int64_t tw = x1 - x0, th = y1 - y0;
    auto& area = scratch.area;
    area.assign(static_cast<size_t>(tw * th), 0.0);
    const auto col = [&](double x) { return static_cast<int64_t>(std::floor(x / px_um)); };
    const auto row = [&](double y) { return static_cast<int64_t>(std::floor(y / py_um)); };

    // 1. Neighbours. Disc centres are bucketed on a grid of cells twice the
    //    typical radius; a disc's overlapping neighbours then lie in the
    //    cells within its radius plus the largest typical radius. The rare
    //    discs much larger than typical ("big") are kept apart and tested
    //    against every disc, so one giant grain does not widen every query.
    auto& offsets = scratch.cell_offsets;
    auto& fill    = scratch.cell_fill;
    auto& members = scratch.cell_discs;
    auto& big     = scratch.stamp;  // indices of the big discs
    big.clear();
    double r_ref = 0.0;
    for (const Disc& d : discs)
        r_ref += d.r_um;
    r_ref = discs.empty() ? 1.0 : std::max(r_ref / static_cast<double>(discs.size()), 1e-9);
    const double r_small = 3.0 * r_ref;  // larger discs are "big"
    const double gx0 = static_cast<double>(x0) * px_um - r_small;
    const double gy0 = static_cast<double>(y0) * py_um - r_small;
    // Cells are at least two typical radii wide, and no more numerous than
    // about four per disc: a block of pixels far larger than its grains
    // (a thumbnail of fine grain) then costs what its discs cost, not
    // (block / radius)^2 empty cells. Any cell size gives the same result:
    // it only decides which non-overlapping discs are also tested.
    const double span_x = static_cast<double>(x1 - x0) * px_um + 2.0 * r_small;
    const double span_y = static_cast<double>(y1 - y0) * py_um + 2.0 * r_small;
    const double cell   = std::max(
        2.0 * r_ref, std::sqrt(span_x * span_y / (4.0 * static_cast<double>(discs.size()) + 16.0)));
    const int64_t gw = static_cast<int64_t>(std::ceil((static_cast<double>(x1) * px_um + r_small - gx0) / cell)) + 1;
    const int64_t gh = static_cast<int64_t>(std::ceil((static_cast<double>(y1) * py_um + r_small - gy0) / cell)) + 1;
    const auto gcol = [&](double x) {
        return std::clamp<int64_t>(static_cast<int64_t>(std::floor((x - gx0) / cell)), 0, gw - 1);
    };
    const auto grow = [&](double y) {
        return std::clamp<int64_t>(static_cast<int64_t>(std::floor((y - gy0) / cell)), 0, gh - 1);
    };
    // Small discs are bucketed by the cell of their centre; big ones are
    // tested by every disc.
    for (size_t i = 0; i < discs.size(); ++i)
        if (discs[i].r_um > r_small)
            big.push_back(i);
    const auto cell_of = [&](size_t i, int64_t& c0, int64_t& c1) {
        c0 = grow(discs[i].y_um) * gw + gcol(discs[i].x_um);
        c1 = discs[i].r_um > r_small ? c0 - 1 : c0;
    };
    bucket_by_row(discs.size(), gw * gh, cell_of, [](size_t i, int64_t) { return i; }, offsets,
                  fill, members);

    // 2. Visible arcs of each disc, cut where the circle crosses the pixel
    //    grid; each piece lies in one pixel and adds its Green term there
    //    (in the pixel's own coordinates, so its left and bottom edges add
    //    nothing below).
    std::vector<size_t> candidates;
    std::vector<std::pair<ArcPoint, ArcPoint>> hidden;
    auto& crossings = scratch.crossings;
    for (size_t i = 0; i < discs.size(); ++i) {
        const Disc& d = discs[i];
        candidates.assign(big.begin(), big.end());
        const double reach = d.r_um + r_small;
        const int64_t ca = gcol(d.x_um - reach), cb = gcol(d.x_um + reach);
        for (int64_t gy = grow(d.y_um - reach), gy1 = grow(d.y_um + reach); gy <= gy1; ++gy) {
            const size_t c0 = static_cast<size_t>(gy * gw + ca), c1 = static_cast<size_t>(gy * gw + cb);
            candidates.insert(candidates.end(), members.begin() + static_cast<std::ptrdiff_t>(offsets[c0]),
                              members.begin() + static_cast<std::ptrdiff_t>(offsets[c1 + 1]));
        }
        // (The candidates' order does not matter: the hidden intervals are
        // sorted before use, and ties between identical discs are broken by
        // index.)
        if (!hidden_intervals(discs, i, candidates.data(), candidates.size(), hidden))
            continue;
        // Points where the circle meets grid lines inside the block's span,
        // their cosine and sine known algebraically (a vertical line fixes
        // the cosine, a horizontal one the sine).
        crossings.clear();
        const auto add_line = [&](double offset, bool vertical) {
            const double t = offset / d.r_um;
            if (!(t > -1.0 && t < 1.0))
                return;
            const double root = std::sqrt((1.0 - t) * (1.0 + t));
            if (vertical) {
                crossings.push_back(arc_point(t, root));
                crossings.push_back(arc_point(t, -root));
            } else {
                crossings.push_back(arc_point(root, t));
                crossings.push_back(arc_point(-root, t));
            }
        };
        for (int64_t k = std::max(x0, col(d.x_um - d.r_um)); k <= std::min(x1, col(d.x_um + d.r_um) + 1); ++k)
            add_line(static_cast<double>(k) * px_um - d.x_um, true);
        for (int64_t m = std::max(y0, row(d.y_um - d.r_um)); m <= std::min(y1, row(d.y_um + d.r_um) + 1); ++m)
            add_line(static_cast<double>(m) * py_um - d.y_um, false);
        const auto by_angle = [](const ArcPoint& u, const ArcPoint& v) { return u.angle < v.angle; };
        std::sort(crossings.begin(), crossings.end(), by_angle);
        std::sort(hidden.begin(), hidden.end(),
                  [](const auto& u, const auto& v) { return u.first.angle < v.first.angle; });
        // Deposits the Green term of the arc piece from p to q
        // (counterclockwise), lying in one pixel, in that pixel's
        // coordinates. `full` marks the whole circle (p == q).
        const auto deposit = [&](const ArcPoint& p, const ArcPoint& q, bool full) {
            const double cross = p.c * q.s - p.s * q.c, dot = p.c * q.c + p.s * q.s;
            double span        = full ? 2.0 * M_PI : std::atan2(cross, dot);
            if (span < 0.0)
                span += 2.0 * M_PI;
            if (!(span > 0.0))
                return;
            // The piece's middle: along u_p + u_q, reversed beyond a half
            // turn; near a half turn that sum vanishes: turn u_p instead.
            double mx = p.c + q.c, my = p.s + q.s;
            const double n = std::sqrt(mx * mx + my * my);
            if (n < 1e-3) {
                const double h = 0.5 * span, ch = std::cos(h), sh = std::sin(h);
                mx = p.c * ch - p.s * sh;
                my = p.s * ch + p.c * sh;
            } else {
                const double sign = span > M_PI ? -1.0 : 1.0;
                mx *= sign / n;
                my *= sign / n;
            }
            const int64_t ix = col(d.x_um + d.r_um * mx);
            const int64_t iy = row(d.y_um + d.r_um * my);
            if (ix < x0 || ix >= x1 || iy < y0 || iy >= y1)
                return;
            const double lx = d.x_um - static_cast<double>(ix) * px_um;
            const double ly = d.y_um - static_cast<double>(iy) * py_um;
            area[static_cast<size_t>((iy - y0) * tw + (ix - x0))]
                += 0.5 * (d.r_um * d.r_um * span + lx * d.r_um * (q.s - p.s)
                          - ly * d.r_um * (q.c - p.c));
        };
        // Cuts the visible arc from a to b at the crossings.
        const auto emit = [&](const ArcPoint& a, const ArcPoint& b) {
            ArcPoint lo = a;
            auto it     = std::upper_bound(crossings.begin(), crossings.end(), a, by_angle);
            bool any    = false;
            for (; it != crossings.end() && it->angle < b.angle; ++it) {
                deposit(lo, *it, false);
                lo  = *it;
                any = true;
            }
            deposit(lo, b, !any && a.angle == 0.0 && b.angle == 4.0);
        };
        // Visible = gaps between the merged hidden intervals.
        ArcPoint cursor { 0.0, 1.0, 0.0 };
        for (const auto& [a, b] : hidden) {
            if (a.angle > cursor.angle)
                emit(cursor, a);
            if (b.angle > cursor.angle)
                cursor = b;
        }
        if (cursor.angle < 4.0)
            emit(cursor, ArcPoint { 4.0, 1.0, 0.0 });
    }

    // 3. Grid lines inside the union: each pixel's right edge (x = x_i+1,
    //    upwards: 1/2 px L) and top edge (y = y_j+1, leftwards: 1/2 py L).
    //    Lines 0..tw-1 are the verticals x = (x0+1+k) px, then th horizontals.
    auto& loff   = scratch.line_offsets;
    auto& lfill  = scratch.line_fill;
    auto& chords = scratch.line_chords;
    const size_t nlines = static_cast<size_t>(tw + th);
    const auto for_lines = [&](const Disc& d, auto&& f) {
        for (int64_t k = std::max(x0 + 1, col(d.x_um - d.r_um)); k <= std::min(x1, col(d.x_um + d.r_um) + 1); ++k) {
            const double e = static_cast<double>(k) * px_um - d.x_um;
            if (e * e < d.r_um * d.r_um) {
                const double h = std::sqrt(d.r_um * d.r_um - e * e);
                f(static_cast<size_t>(k - x0 - 1), d.y_um - h, d.y_um + h);
            }
        }
        for (int64_t m = std::max(y0 + 1, row(d.y_um - d.r_um)); m <= std::min(y1, row(d.y_um + d.r_um) + 1); ++m) {
            const double e = static_cast<double>(m) * py_um - d.y_um;
            if (e * e < d.r_um * d.r_um) {
                const double h = std::sqrt(d.r_um * d.r_um - e * e);
                f(static_cast<size_t>(tw + (m - y0 - 1)), d.x_um - h, d.x_um + h);
            }
        }
    };
    loff.assign(nlines + 1, 0);
    for (const Disc& d : discs)
        for_lines(d, [&](size_t line, double, double) { ++loff[line + 1]; });
    for (size_t l = 1; l < loff.size(); ++l)
        loff[l] += loff[l - 1];
    chords.resize(loff.back());
    lfill.assign(loff.begin(), loff.end() - 1);
    for (const Disc& d : discs)
        for_lines(d, [&](size_t line, double a, double b) { chords[lfill[line]++] = { a, b }; });
    for (size_t l = 0; l < nlines; ++l) {
        auto first = chords.begin() + static_cast<std::ptrdiff_t>(loff[l]);
        auto last  = chords.begin() + static_cast<std::ptrdiff_t>(loff[l + 1]);
        if (first == last)
            continue;
        std::sort(first, last);
        const bool vertical = l < static_cast<size_t>(tw);
        // Along a vertical line the pixels are rows y0..y1; along a
        // horizontal one, columns x0..x1.
        const double step   = vertical ? py_um : px_um;
        const int64_t lo_ix = vertical ? y0 : x0, hi_ix = vertical ? y1 : x1;
        const double factor = 0.5 * (vertical ? px_um : py_um);
        const auto deposit  = [&](double a, double b) {
            a = std::max(a, static_cast<double>(lo_ix) * step);
            b = std::min(b, static_cast<double>(hi_ix) * step);
            if (!(b > a))
                return;
            for (int64_t i = std::max(lo_ix, static_cast<int64_t>(std::floor(a / step))); i < hi_ix; ++i) {
                // Both ends as index * step, as the clip above: pa + step
                // would round differently from the next pixel's pa.
                const double pa = static_cast<double>(i) * step;
                const double pb = static_cast<double>(i + 1) * step;
                if (pa >= b)
                    break;
                const double len = std::min(b, pb) - std::max(a, pa);
                const size_t at  = vertical ? static_cast<size_t>((i - y0) * tw + static_cast<int64_t>(l))
                                            : static_cast<size_t>((static_cast<int64_t>(l) - tw) * tw + (i - x0));
                area[at] += factor * len;
            }
        };
        for_each_union_interval(first, last, deposit);
    }

    const double pixel_um2 = px_um * py_um;
    for (size_t i = 0; i < area.size(); ++i)
        fraction[i] = std::clamp(area[i] / pixel_um2, 0.0, 1.0);
}

}  // namespace filmgrain
