// MODEL.md section 5: image formation.
#include "model/image_formation.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

namespace filmgrain {

namespace {

/// Calls f(a, b) for each interval of the union of the intervals
/// [first, last) (pairs (a, b), sorted by a, non-empty range), in order.
template<typename It, typename F> void for_each_union_interval(It first, It last, F&& f)
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
    auto& fill    = scratch.fill;
    // Sub-scanlines a disc crosses: (g + 0.5) h in (y - r, y + r).
    const auto crossing = [&](const Disc& d, int64_t& ga, int64_t& gb) {
        ga = std::max<int64_t>(g0, static_cast<int64_t>(std::ceil((d.y_um - d.r_um) / h - 0.5)));
        gb = std::min<int64_t>(g0 + rows - 1,
                               static_cast<int64_t>(std::floor((d.y_um + d.r_um) / h - 0.5)));
    };
    offsets.assign(static_cast<size_t>(rows + 1), 0);
    for (const Disc& d : discs) {
        int64_t ga, gb;
        crossing(d, ga, gb);
        for (int64_t g = ga; g <= gb; ++g)
            ++offsets[static_cast<size_t>(g - g0 + 1)];
    }
    for (size_t i = 1; i < offsets.size(); ++i)
        offsets[i] += offsets[i - 1];
    chords.resize(offsets.back());
    fill.assign(offsets.begin(), offsets.end() - 1);
    for (const Disc& d : discs) {
        int64_t ga, gb;
        crossing(d, ga, gb);
        for (int64_t g = ga; g <= gb; ++g) {
            const double dy   = (static_cast<double>(g) + 0.5) * h - d.y_um;
            const double half = std::sqrt(std::max(0.0, d.r_um * d.r_um - dy * dy));
            chords[fill[static_cast<size_t>(g - g0)]++] = { d.x_um - half, d.x_um + half };
        }
    }
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

namespace {

/// floor and ceil of a double within int64_t range, without a library call
/// (the x86-64 baseline has no rounding instruction).
inline int64_t floor_i64(double v)
{
    const int64_t i = static_cast<int64_t>(v);
    return i - (static_cast<double>(i) > v);
}
inline int64_t ceil_i64(double v)
{
    const int64_t i = static_cast<int64_t>(v);
    return i + (static_cast<double>(i) < v);
}

/// Covered points per pixel of a raster: the popcounts of each pixel's
/// `samples` words. Three builds of one loop: with AVX-512 popcounts where
/// the processor has them, with the popcnt instruction (every x86-64 since
/// ~2008), else portable.
inline void count_points_portable(const uint64_t* bits, int64_t tw, int64_t th, int64_t samples,
                                  int* count, double weight, double* fraction)
{
    for (int64_t iy = 0; iy < th; ++iy) {
        std::fill(count, count + tw, 0);
        for (int64_t j = 0; j < samples; ++j) {
            const uint64_t* row = bits + (iy * samples + j) * tw;
            for (int64_t ix = 0; ix < tw; ++ix)
                count[ix] += __builtin_popcountll(row[ix]);
        }
        for (int64_t ix = 0; ix < tw; ++ix)
            fraction[iy * tw + ix] = count[ix] * weight;
    }
}
#if defined(__x86_64__) && defined(__GNUC__)
// Eight words' popcounts at once where the processor has them.
__attribute__((target("popcnt,avx512f,avx512vl,avx512vpopcntdq"))) void count_points_avx512(
    const uint64_t* bits, int64_t tw, int64_t th, int64_t samples, int* count, double weight,
    double* fraction)
{
    count_points_portable(bits, tw, th, samples, count, weight, fraction);
}
__attribute__((target("popcnt"))) void count_points_popcnt(const uint64_t* bits, int64_t tw,
                                                          int64_t th, int64_t samples, int* count,
                                                          double weight, double* fraction)
{
    count_points_portable(bits, tw, th, samples, count, weight, fraction);
}
#endif
void count_points(const uint64_t* bits, int64_t tw, int64_t th, int64_t samples, int* count,
                  double weight, double* fraction, bool portable)
{
#if defined(__x86_64__) && defined(__GNUC__)
    if (portable)
        return count_points_portable(bits, tw, th, samples, count, weight, fraction);
    static const bool has_vpopcnt = __builtin_cpu_supports("avx512vpopcntdq")
                                    && __builtin_cpu_supports("avx512vl");
    static const bool has_popcnt  = __builtin_cpu_supports("popcnt");
    if (has_vpopcnt)
        return count_points_avx512(bits, tw, th, samples, count, weight, fraction);
    if (has_popcnt)
        return count_points_popcnt(bits, tw, th, samples, count, weight, fraction);
#endif
    count_points_portable(bits, tw, th, samples, count, weight, fraction);
}

}  // namespace

double lens_area_um2(double r_um, double h_um)
{
    if (h_um >= 2.0 * r_um)
        return 0.0;
    const double h = std::max(0.0, h_um);
    return 2.0 * r_um * r_um * std::acos(h / (2.0 * r_um))
           - 0.5 * h * std::sqrt(std::max(0.0, 4.0 * r_um * r_um - h * h));
}

namespace {

/// ceil and floor as doubles: with the processor's rounding instruction
/// (SSE4.1, so that a loop of them vectorises) or through int64_t. The same
/// values either way (exact integers).
template<bool kRound> inline double ceil_d(double v)
{
    if constexpr (kRound)
        return std::ceil(v);
    else
        return static_cast<double>(ceil_i64(v));
}
template<bool kRound> inline double floor_d(double v)
{
    if constexpr (kRound)
        return std::floor(v);
    else
        return static_cast<double>(floor_i64(v));
}

/// Four words of a sample row, as one vector (the compiler's generic
/// vectors: two SSE2 registers in the portable build, one in the AVX2 one).
typedef uint64_t Words4 __attribute__((vector_size(32)));

/// Masks of a run of sample points within a window of four words that
/// starts at the word of the run's first point: `last[d]` has the window's
/// bits 0..d (d: the run's last point relative to the window's first bit),
/// `first[s]` every bit from s of the first word and all of the others (s:
/// the run's first point within its word). A run's window mask is
/// last[d] & first[s]: words past the run's last get 0.
struct RunMasks {
    uint64_t last[256][4];
    uint64_t first[64][4];
};
constexpr RunMasks make_run_masks()
{
    RunMasks m {};
    for (int d = 0; d < 256; ++d)
        for (int w = 0; w < 4; ++w) {
            const int top = d - 64 * w;  // the run's last bit within word w
            m.last[d][w] = top < 0 ? 0 : top >= 63 ? ~uint64_t(0) : ~uint64_t(0) >> (63 - top);
        }
    for (int s = 0; s < 64; ++s)
        for (int w = 0; w < 4; ++w)
            m.first[s][w] = w == 0 ? ~uint64_t(0) << s : ~uint64_t(0);
    return m;
}
constexpr RunMasks kRunMasks = make_run_masks();

/// The widest run (last point minus first) that a four-word window holds
/// from any first point within its word: 255 - 63.
constexpr int64_t kWindowRun = 192;

/// Two words of a sample row, as one vector.
typedef uint64_t Words2 __attribute__((vector_size(16)));

/// ORs each row's run of points [lo[i], hi[i]] (relative to the rows' first
/// column; empty where hi < lo) into rows row, row + tw, ...: a window of
/// `Words` from the run's first word, which must hold the run (at most 64
/// points for two words, kWindowRun for four).
template<typename Words>
[[gnu::always_inline]] inline void or_runs(const double* lo, const double* hi, int n,
                                           uint64_t* row, int64_t tw)
{
    for (int i = 0; i < n; ++i, row += tw) {
        const int64_t ka = static_cast<int64_t>(lo[i]);
        const int64_t kb = static_cast<int64_t>(hi[i]);
        if (kb < ka)
            continue;
        const int64_t wa = ka >> 6;
        Words last, first, words;
        std::memcpy(&last, kRunMasks.last[kb - (wa << 6)], sizeof last);
        std::memcpy(&first, kRunMasks.first[ka & 63], sizeof first);
        std::memcpy(&words, row + wa, sizeof words);
        words |= last & first;
        std::memcpy(row + wa, &words, sizeof words);
    }
}

/// The bits of raster_coverage: every disc's run of sample points on every
/// sample row it crosses, ORed into `bits` (`tw` words per sample row, the
/// block's first sample column gx0 and row gy0 as global indices; three
/// words of padding after the last row). Built once per instruction set
/// (below); bit-identical builds: the arithmetic is the same IEEE
/// operations in the same order (no contraction into FMA).
template<bool kRound>
[[gnu::always_inline]] inline void raster_discs(const std::vector<Disc>& discs, int64_t tw,
                                                int64_t rows, int64_t gx0, int64_t gy0,
                                                double hy, double inv_hx, double inv_hy,
                                                uint64_t* bits, std::vector<double>& span)
{
    const int64_t cols = tw * 64;
    const double first_col = static_cast<double>(gx0);
    const double last_col  = static_cast<double>(gx0 + cols - 1);
    for (const Disc& d : discs) {
        // Sample rows (g + 0.5) hy inside (y - r, y + r), as global indices.
        const int64_t ga = std::max<int64_t>(gy0, ceil_i64((d.y_um - d.r_um) * inv_hy - 0.5));
        const int64_t gb = std::min<int64_t>(gy0 + rows - 1,
                                             floor_i64((d.y_um + d.r_um) * inv_hy - 0.5));
        if (gb < ga)
            continue;
        const int n = static_cast<int>(gb - ga + 1);
        span.resize(static_cast<size_t>(2 * n));
        double* lo = span.data();
        double* hi = span.data() + n;
        // Locals, so that the stores below cannot alias the disc.
        const double r2 = d.r_um * d.r_um;
        const double xc = d.x_um * inv_hx - 0.5;
        const double yc = d.y_um;
        const double row0 = static_cast<double>(ga);
        // The spans of all its rows first: a plain loop the compiler
        // vectorises where it has the rounding instruction.
        for (int i = 0; i < n; ++i) {
            // From the global row index, as every tile computes it.
            const double dy   = (row0 + static_cast<double>(i) + 0.5) * hy - yc;
            const double w2   = std::max(r2 - dy * dy, 0.0);
            const double half = std::sqrt(w2) * inv_hx;
            // Sample columns (k + 0.5) hx inside [x - half, x + half], cut
            // to the block and relative to its first column (exact: integers
            // below 2^53); an empty span (w2 = 0 at the pole, or outside the
            // block) gives lo > hi.
            lo[i] = std::max(ceil_d<kRound>(xc - half), first_col) - first_col;
            hi[i] = std::min(floor_d<kRound>(xc + half), last_col) - first_col;
        }
        // Then the bits. A run no longer than kWindowRun points (a disc up
        // to three pixels wide) is ORed in as one window of four words from
        // its first word (two words for a run of at most 64 points, a disc
        // up to a pixel wide), with masks from kRunMasks: no branch on how
        // many words it crosses. (A run holds at most 2 half + 1 points,
        // half <= r inv_hx; the margin of 2 covers the rounding of half.)
        uint64_t* row = bits + (ga - gy0) * tw;
        const double width = 2.0 * d.r_um * inv_hx;
        if (width <= static_cast<double>(kWindowRun - 2)) {
            if (width <= static_cast<double>(64 - 2))
                or_runs<Words2>(lo, hi, n, row, tw);
            else
                or_runs<Words4>(lo, hi, n, row, tw);
            continue;
        }
        // Wider runs: the first and last words, then the words between.
        for (int i = 0; i < n; ++i, row += tw) {
            const int64_t ka = static_cast<int64_t>(lo[i]);
            const int64_t kb = static_cast<int64_t>(hi[i]);
            if (kb < ka)
                continue;
            const int64_t wa = ka >> 6, wb = kb >> 6;
            const uint64_t ma = ~uint64_t(0) << (ka & 63);
            const uint64_t mb = ~uint64_t(0) >> (63 - (kb & 63));
            const uint64_t two = uint64_t(0) - static_cast<uint64_t>(wb != wa);  // all ones if so
            row[wa] |= ma & (mb | two);
            row[wb] |= mb & two;
            for (int64_t w = wa + 1; w < wb; ++w)
                row[w] = ~uint64_t(0);
        }
    }
}

void raster_discs_portable(const std::vector<Disc>& discs, int64_t tw, int64_t rows, int64_t gx0,
                           int64_t gy0, double hy, double inv_hx, double inv_hy, uint64_t* bits,
                           std::vector<double>& span)
{
    raster_discs<false>(discs, tw, rows, gx0, gy0, hy, inv_hx, inv_hy, bits, span);
}
#if defined(__x86_64__) && defined(__GNUC__)
// AVX2 for four rows' spans at once, without FMA (its single rounding would
// change which sample points a span holds).
__attribute__((target("avx2"))) void raster_discs_avx2(const std::vector<Disc>& discs,
                                                       int64_t tw, int64_t rows, int64_t gx0,
                                                       int64_t gy0, double hy, double inv_hx,
                                                       double inv_hy, uint64_t* bits,
                                                       std::vector<double>& span)
{
    raster_discs<true>(discs, tw, rows, gx0, gy0, hy, inv_hx, inv_hy, bits, span);
}
#endif

}  // namespace

void raster_coverage(const std::vector<Disc>& discs, int64_t x0, int64_t y0, int64_t x1,
                     int64_t y1, double px_um, double py_um, int samples,
                     RasterScratch& scratch, double* fraction)
{
    // 64 points across a pixel (one word per pixel and sample row), `samples`
    // rows down it: a disc's span on a row is a run of bits, fine in x at
    // little cost; rows cost a square root each, so they are what `samples`
    // sets.
    constexpr int64_t kX = 64;
    const int64_t tw = x1 - x0, th = y1 - y0;
    const int64_t S    = samples;
    const int64_t rows = th * S;                // sample rows of the block
    const int64_t gx0 = x0 * kX, gy0 = y0 * S;  // global index of the first
    const double hy = py_um / static_cast<double>(S);
    const double inv_hx = static_cast<double>(kX) / px_um, inv_hy = static_cast<double>(S) / py_um;
    auto& bits = scratch.bits;
    // Three words of padding: a run's four-word window may reach past the
    // last word of the last row (ORing zeros there).
    bits.assign(static_cast<size_t>(tw * rows + 3), 0);
#if defined(__x86_64__) && defined(__GNUC__)
    static const bool has_avx2 = __builtin_cpu_supports("avx2");
    if (has_avx2 && !scratch.portable)
        raster_discs_avx2(discs, tw, rows, gx0, gy0, hy, inv_hx, inv_hy, bits.data(),
                          scratch.span);
    else
#endif
        raster_discs_portable(discs, tw, rows, gx0, gy0, hy, inv_hx, inv_hy, bits.data(),
                              scratch.span);
    scratch.count.resize(static_cast<size_t>(tw));
    count_points(bits.data(), tw, th, S, scratch.count.data(), 1.0 / static_cast<double>(kX * S),
                 fraction, scratch.portable);
}

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
    offsets.assign(static_cast<size_t>(gw * gh + 1), 0);
    for (size_t i = 0; i < discs.size(); ++i) {
        if (discs[i].r_um > r_small)
            big.push_back(i);
        else
            ++offsets[static_cast<size_t>(grow(discs[i].y_um) * gw + gcol(discs[i].x_um)) + 1];
    }
    for (size_t c = 1; c < offsets.size(); ++c)
        offsets[c] += offsets[c - 1];
    members.resize(offsets.back());
    fill.assign(offsets.begin(), offsets.end() - 1);
    for (size_t i = 0; i < discs.size(); ++i)
        if (discs[i].r_um <= r_small)
            members[fill[static_cast<size_t>(grow(discs[i].y_um) * gw + gcol(discs[i].x_um))]++] = i;

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

double density_from_transmittance(double transmittance, double max_density,
                                  double base_density)
{
    const double floor_t = std::pow(10.0, -max_density);
    return -std::log10(std::max(transmittance, floor_t)) + base_density;
}

}  // namespace filmgrain
