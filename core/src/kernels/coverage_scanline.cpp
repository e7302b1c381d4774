// Coverage on sub-scanlines (coverage_scanline.h).
#include "kernels/coverage_scanline.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

#include "util/bucket.h"

namespace filmgrain {

void scanline_coverage(const std::vector<Disc>& discs, int64_t x0, int64_t y0, int64_t x1,
                       int64_t y1, double px_um, double py_um, int samples,
                       ScanlineScratch& scratch, double* fraction)
{
    const int64_t tw = x1 - x0, th = y1 - y0;
    const int64_t rows = th * samples;          // sub-scanlines of the block
    const int64_t g0   = y0 * samples;          // global index of the first
    const double h     = py_um / samples;       // sub-scanline spacing
    std::fill(fraction, fraction + tw * th, 0.0);
    auto& offsets = scratch.offsets;
    auto& chords  = scratch.chords;
    // Sub-scanlines a disc crosses: (g + 0.5) h in (y - r, y + r); the
    // rows of the buckets are g - g0.
    const auto crossing = [&](size_t i, int64_t& ra, int64_t& rb) {
        const Disc& d = discs[i];
        ra = std::max<int64_t>(g0, static_cast<int64_t>(std::ceil((d.y_um - d.r_um) / h - 0.5)))
             - g0;
        rb = std::min<int64_t>(g0 + rows - 1,
                               static_cast<int64_t>(std::floor((d.y_um + d.r_um) / h - 0.5)))
             - g0;
    };
    const auto chord = [&](size_t i, int64_t r) {
        const Disc& d     = discs[i];
        const double dy   = (static_cast<double>(r + g0) + 0.5) * h - d.y_um;
        const double half = std::sqrt(std::max(0.0, d.r_um * d.r_um - dy * dy));
        return std::pair<double, double>(d.x_um - half, d.x_um + half);
    };
    bucket_by_row(discs.size(), rows, crossing, chord, offsets, scratch.fill, chords);
    // Each sub-scanline: sort its chords, merge, and deposit the covered
    // lengths into the pixels they cross, in increasing x.
    const double left = static_cast<double>(x0) * px_um, right = static_cast<double>(x1) * px_um;
    const double weight = 1.0 / (px_um * samples);
    for (int64_t r = 0; r < rows; ++r) {
        auto first = chords.begin() + static_cast<std::ptrdiff_t>(offsets[static_cast<size_t>(r)]);
        auto last  = chords.begin() + static_cast<std::ptrdiff_t>(offsets[static_cast<size_t>(r + 1)]);
        if (first == last)
            continue;
        std::sort(first, last);
        double* row = fraction + (r / samples) * tw;
        const auto deposit = [&](double a, double b) {
            a = std::max(a, left);
            b = std::min(b, right);
            if (!(b > a))
                return;
            int64_t i = std::max<int64_t>(x0, static_cast<int64_t>(std::floor(a / px_um)));
            for (; i < x1; ++i) {
                const double pa = static_cast<double>(i) * px_um;
                const double pb = static_cast<double>(i + 1) * px_um;
                if (pa >= b)
                    break;
                row[i - x0] += (std::min(b, pb) - std::max(a, pa)) * weight;
            }
        };
        for_each_union_interval(first, last, deposit);
    }
    for (int64_t i = 0; i < tw * th; ++i)
        fraction[i] = std::min(fraction[i], 1.0);
}

}  // namespace filmgrain
