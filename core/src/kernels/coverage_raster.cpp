// Coverage on a raster of points (coverage_raster.h).
#include "kernels/coverage_raster.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

namespace filmgrain {

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

}  // namespace filmgrain
