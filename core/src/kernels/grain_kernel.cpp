// The per-grain kernel of the fast paths: tables and the exposure plane.
#include "kernels/grain_kernel.h"

#include <algorithm>
#include <cmath>
#include <limits>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

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
        m_counts.emplace_back(bin.grains_per_um2 * bin.cell_um * bin.cell_um);
    }
    m_mean_area_error = total > 0.0 && area_exact > 0.0 ? std::fabs(area_table - area_exact) / area_exact : 0.0;
}

size_t FastGrains::drawn_within(const Batch& batch, const RectUm& rect) const
{
    const auto inside = [&](double x, double y) {
        return x >= rect.x0_um && x < rect.x1_um && y >= rect.y0_um && y < rect.y1_um;
    };
    size_t count = 0;
    if (batch.n == batch.drawn) {
        for (size_t i = 0; i < batch.n; ++i)
            count += inside(batch.x[i], batch.y[i]);
        return count;
    }
    const double cell_um = m_grains.bins()[batch.bin].cell_um;
    const double x0 = static_cast<double>(batch.cx) * cell_um;
    const double y0 = static_cast<double>(batch.cy) * cell_um;
    // The positions (grain_position: x0 + bits * scale) lie in [x0, x0 +
    // cell_um] (the top only by rounding): the cell's count where that
    // lies strictly inside or outside.
    if (x0 >= rect.x0_um && x0 + cell_um < rect.x1_um && y0 >= rect.y0_um
        && y0 + cell_um < rect.y1_um)
        return batch.drawn;
    if (x0 + cell_um < rect.x0_um || x0 >= rect.x1_um || y0 + cell_um < rect.y0_um
        || y0 >= rect.y1_um)
        return 0;
    const double scale = cell_um * 0x1.0p-32;
    for (size_t i = 0; i < batch.drawn; ++i) {
        double x, y;
        grain_position(batch.cell, i, x0, y0, scale, x, y);
        count += inside(x, y);
    }
    return count;
}

SegmentTable::SegmentTable() : m_area(kIntervals + 2)
{
    const auto exact = [](double t) { return std::acos(t) - t * std::sqrt(1.0 - t * t); };
    for (int k = 0; k <= kIntervals; ++k)
        m_area[static_cast<size_t>(k)] = exact(static_cast<double>(k) / kIntervals);
    m_area.back() = m_area[kIntervals];  // t = 1 reads k = kIntervals and the next
    for (int k = 0; k < kIntervals; ++k) {
        const double t = (k + 0.5) / kIntervals;
        m_max_error = std::max(m_max_error, std::fabs(area(t) - exact(t)));
    }
}

const SegmentTable& SegmentTable::shared()
{
    static const SegmentTable table;
    return table;
}

void ExposurePlane::fill(const LayerExposure& exposure, const FrameGeometry& frame,
                         const RectUm& rect)
{
    const double p = frame.input_pitch_um;
    // The pixels under `rect`: within the image (gate: zeros beyond), or
    // all of them, beyond the image the nearest edge pixel's (clamp,
    // MODEL.md 2).
    const bool clamp = exposure.edge() == FrameEdge::clamp;
    const auto clip = [clamp](double v, int64_t n) {
        const int64_t i = static_cast<int64_t>(std::clamp(v, -9e18, 9e18));
        return clamp ? i : std::clamp<int64_t>(i, 0, n);
    };
    const int64_t x0 = clip(std::floor(rect.x0_um / p), frame.input_width);
    const int64_t y0 = clip(std::floor(rect.y0_um / p), frame.input_height);
    const int64_t x1 = clip(std::floor(rect.x1_um / p) + 1, frame.input_width);
    const int64_t y1 = clip(std::floor(rect.y1_um / p) + 1, frame.input_height);
    m_pitch_um     = p;
    m_per_pitch_um = 1.0 / p;
    m_x0 = static_cast<double>(x0);
    m_y0 = static_cast<double>(y0);
    m_w  = static_cast<double>(x1 - x0);
    m_h  = static_cast<double>(y1 - y0);
    m_nx            = x1 - x0;
    m_ny            = y1 - y0;
    m_padded_stride = static_cast<size_t>(m_nx + 2 * kPad);
    m_padded.assign(m_padded_stride * static_cast<size_t>(m_ny + 2 * kPad), 0.0f);
    for (int64_t y = y0; y < y1; ++y) {
        float* row = m_padded.data() + static_cast<size_t>(y - y0 + kPad) * m_padded_stride + kPad;
        if (clamp)
            for (int64_t x = x0; x < x1; ++x)
                row[x - x0] = static_cast<float>(exposure.value(exposure.clamp_x(x),
                                                                exposure.clamp_y(y)));
        else
            for (int64_t x = x0; x < x1; ++x)
                row[x - x0] = static_cast<float>(exposure.value(x, y));
    }
}

/// ExposurePlane::integrals_over_discs: a scalar loop, and an AVX2 one
/// that takes four discs at a time with the same IEEE operations in the
/// same order (no FMA; max and min as maxpd and minpd: the second operand
/// unless the first is greater, or less; truncating int conversions;
/// gathers for the table and the plane), so that both give the same bits.
struct PlaneIntegrals {
    const SegmentTable* table;
    const double* seg;
    const float* v;
    double stride, nx, ny;           ///< the padded row, the window (pixels)
    double per_pitch_um, pitch_um;   ///< 1 / pitch, pitch
    double x0, y0;                   ///< the window's first pixel

    static constexpr double kK    = SegmentTable::kIntervals;
    static constexpr double kPad  = static_cast<double>(ExposurePlane::kPad);
    static constexpr double kBig  = 0x1.0p30;  // keeps the int conversions defined
    static constexpr double kQuarterPi = 0.25 * M_PI;

    explicit PlaneIntegrals(const ExposurePlane& plane)
        : table(plane.m_segment)
        , seg(plane.m_segment->nodes())
        , v(plane.m_padded.data())
        , stride(static_cast<double>(plane.m_padded_stride))
        , nx(static_cast<double>(plane.m_nx))
        , ny(static_cast<double>(plane.m_ny))
        , per_pitch_um(plane.m_per_pitch_um)
        , pitch_um(plane.m_pitch_um)
        , x0(plane.m_x0)
        , y0(plane.m_y0)
    {
    }

    static double max_of(double a, double b) { return a > b ? a : b; }  // maxpd
    static double min_of(double a, double b) { return a < b ? a : b; }  // minpd
    /// floor through int64_t (|g| <= kBig: exact).
    static double floor_of(double g)
    {
        const double t = static_cast<double>(static_cast<int64_t>(g));
        return t > g ? t - 1.0 : t;
    }

    /// Where a disc lies: its pixel (fx, fy; plane coordinates, clamped
    /// into the padding: only a disc beyond the window is moved, and it
    /// gets a wrong value, not a read outside the memory), the centre
    /// within it (tx, ty in [0, 1)), and the pitch in radii.
    struct Where {
        double fx, fy, tx, ty, inv_r;
    };
    Where locate(double x_um, double y_um, double r_um) const
    {
        const double gx = min_of(max_of(x_um * per_pitch_um - x0, -kBig), kBig);
        const double gy = min_of(max_of(y_um * per_pitch_um - y0, -kBig), kBig);
        const double fx = min_of(max_of(floor_of(gx), -1.0), nx);
        const double fy = min_of(max_of(floor_of(gy), -1.0), ny);
        return { fx, fy, gx - fx, gy - fy, pitch_um / r_um };
    }
    /// Distance t in radii cut to [0, 1] (a disc does not cross an edge a
    /// radius away).
    static double cut(double t) { return min_of(max_of(t, 0.0), 1.0); }
    /// S(t) from the table, t in [0, 1].
    double segment(double t) const { return table->area(t); }
    /// The quadrant beyond a corner at distances a, b (in radii) whose
    /// segments are sa, sb: nothing unless the corner is inside the disc.
    static double quadrant(double a, double sa, double b, double sb)
    {
        const double corner = (0.5 * (sa + sb) - kQuarterPi) + a * b;
        return a * a + b * b < 1.0 ? corner : 0.0;
    }
    /// The plane's value at `base` (an index, a whole number) plus offsets.
    double at(double base) const { return v[static_cast<int>(base)]; }

    /// A disc of radius up to half a pitch: the nearer edges and the four
    /// pixels around their corner.
    double one(double x_um, double y_um, double r_um) const
    {
        const Where w = locate(x_um, y_um, r_um);
        const double a = cut(min_of(w.tx, 1.0 - w.tx) * w.inv_r);
        const double b = cut(min_of(w.ty, 1.0 - w.ty) * w.inv_r);
        const double dx = w.tx < 0.5 ? -1.0 : 1.0, drow = w.ty < 0.5 ? -stride : stride;
        const double area_x = segment(a), area_y = segment(b);
        const double area_xy = quadrant(a, area_x, b, area_y);
        const double base = (w.fy + kPad) * stride + (w.fx + kPad);
        const double sum = ((at(base) * (((M_PI - area_x) - area_y) + area_xy)
                             + at(base + dx) * (area_x - area_xy))
                            + at(base + drow) * (area_y - area_xy))
                           + at((base + drow) + dx) * area_xy;
        return (r_um * r_um) * sum;
    }

    /// The same integral for a disc of radius up to a pitch: it may cross
    /// the edges on both sides of its pixel, at distances aL, aR, bB, bT
    /// (in radii; never two on one side), so the nine pixels around get
    /// the segments beyond each edge less the quadrants beyond each of the
    /// four corners that lie inside the disc. Scalar: the few grains
    /// between half a pitch and a pitch in radius take it.
    double wide(double x_um, double y_um, double r_um) const
    {
        const Where w = locate(x_um, y_um, r_um);
        const double aL = cut(w.tx * w.inv_r), aR = cut((1.0 - w.tx) * w.inv_r);
        const double bB = cut(w.ty * w.inv_r), bT = cut((1.0 - w.ty) * w.inv_r);
        const double sL = segment(aL), sR = segment(aR), sB = segment(bB), sT = segment(bT);
        const double qLB = quadrant(aL, sL, bB, sB), qLT = quadrant(aL, sL, bT, sT);
        const double qRB = quadrant(aR, sR, bB, sB), qRT = quadrant(aR, sR, bT, sT);
        const double base = (w.fy + kPad) * stride + (w.fx + kPad);
        const double centre = ((((M_PI - sL) - sR) - sB) - sT) + ((qLB + qLT) + (qRB + qRT));
        const double sum = at(base) * centre + at(base - 1.0) * ((sL - qLB) - qLT)
                           + at(base + 1.0) * ((sR - qRB) - qRT)
                           + at(base - stride) * ((sB - qLB) - qRB)
                           + at(base + stride) * ((sT - qLT) - qRT)
                           + at((base - stride) - 1.0) * qLB + at((base + stride) - 1.0) * qLT
                           + at((base - stride) + 1.0) * qRB + at((base + stride) + 1.0) * qRT;
        return (r_um * r_um) * sum;
    }
};

namespace {

void plane_integrals_portable(const PlaneIntegrals& k, const double* x, const double* y,
                              const double* r, size_t n, double* out)
{
    for (size_t i = 0; i < n; ++i)
        out[i] = k.one(x[i], y[i], r[i]);
}

#if defined(__x86_64__) && defined(__GNUC__)
// Gathers with a mask of all ones and a defined source (the unmasked
// intrinsics leave GCC 12 warning of an uninitialised source).
__attribute__((target("avx2"), always_inline)) inline __m256d gather_d(const double* base,
                                                                         __m128i idx)
{
    return _mm256_mask_i32gather_pd(_mm256_setzero_pd(), base, idx,
                                    _mm256_castsi256_pd(_mm256_set1_epi64x(-1)), 8);
}
/// The floats at the (whole-number) indices, as doubles.
__attribute__((target("avx2"), always_inline)) inline __m256d gather_s(const float* base,
                                                                         __m256d index)
{
    return _mm256_cvtps_pd(_mm_mask_i32gather_ps(_mm_setzero_ps(), base,
                                                 _mm256_cvttpd_epi32(index),
                                                 _mm_castsi128_ps(_mm_set1_epi32(-1)), 4));
}

__attribute__((target("avx2"))) void plane_integrals_avx2(const PlaneIntegrals& k,
                                                          const double* x, const double* y,
                                                          const double* r, size_t n, double* out)
{
    const __m256d per_pitch_um_v = _mm256_set1_pd(k.per_pitch_um);
    const __m256d pitch_um_v     = _mm256_set1_pd(k.pitch_um);
    const __m256d x0 = _mm256_set1_pd(k.x0), y0 = _mm256_set1_pd(k.y0);
    const __m256d big = _mm256_set1_pd(PlaneIntegrals::kBig), nbig = _mm256_set1_pd(-PlaneIntegrals::kBig);
    const __m256d one = _mm256_set1_pd(1.0), mone = _mm256_set1_pd(-1.0), zero = _mm256_setzero_pd();
    const __m256d half = _mm256_set1_pd(0.5), nx = _mm256_set1_pd(k.nx), ny = _mm256_set1_pd(k.ny);
    const __m256d stride = _mm256_set1_pd(k.stride), nstride = _mm256_set1_pd(-k.stride);
    const __m256d K = _mm256_set1_pd(PlaneIntegrals::kK), pad = _mm256_set1_pd(PlaneIntegrals::kPad);
    const __m256d qpi = _mm256_set1_pd(PlaneIntegrals::kQuarterPi), pi = _mm256_set1_pd(M_PI);
    size_t i = 0;
    for (; i + 4 <= n; i += 4) {
        const __m256d xr = _mm256_loadu_pd(x + i), yr = _mm256_loadu_pd(y + i);
        const __m256d rr = _mm256_loadu_pd(r + i);
        const __m256d gx = _mm256_min_pd(
            _mm256_max_pd(_mm256_sub_pd(_mm256_mul_pd(xr, per_pitch_um_v), x0), nbig), big);
        const __m256d gy = _mm256_min_pd(
            _mm256_max_pd(_mm256_sub_pd(_mm256_mul_pd(yr, per_pitch_um_v), y0), nbig), big);
        const __m256d fx = _mm256_min_pd(_mm256_max_pd(_mm256_floor_pd(gx), mone), nx);
        const __m256d fy = _mm256_min_pd(_mm256_max_pd(_mm256_floor_pd(gy), mone), ny);
        const __m256d tx = _mm256_sub_pd(gx, fx), ty = _mm256_sub_pd(gy, fy);
        const __m256d inv_r = _mm256_div_pd(pitch_um_v, rr);
        const __m256d a = _mm256_min_pd(
            _mm256_max_pd(_mm256_mul_pd(_mm256_min_pd(tx, _mm256_sub_pd(one, tx)), inv_r), zero),
            one);
        const __m256d b = _mm256_min_pd(
            _mm256_max_pd(_mm256_mul_pd(_mm256_min_pd(ty, _mm256_sub_pd(one, ty)), inv_r), zero),
            one);
        const __m256d dx = _mm256_blendv_pd(one, mone, _mm256_cmp_pd(tx, half, _CMP_LT_OQ));
        const __m256d drow = _mm256_blendv_pd(stride, nstride, _mm256_cmp_pd(ty, half, _CMP_LT_OQ));
        const __m256d sa = _mm256_mul_pd(a, K), sb = _mm256_mul_pd(b, K);
        const __m128i ka = _mm256_cvttpd_epi32(sa), kb = _mm256_cvttpd_epi32(sb);
        const __m256d fa = _mm256_sub_pd(sa, _mm256_cvtepi32_pd(ka));
        const __m256d fb = _mm256_sub_pd(sb, _mm256_cvtepi32_pd(kb));
        const __m256d a0 = gather_d(k.seg, ka), a1 = gather_d(k.seg + 1, ka);
        const __m256d b0 = gather_d(k.seg, kb), b1 = gather_d(k.seg + 1, kb);
        const __m256d area_x = _mm256_add_pd(a0, _mm256_mul_pd(fa, _mm256_sub_pd(a1, a0)));
        const __m256d area_y = _mm256_add_pd(b0, _mm256_mul_pd(fb, _mm256_sub_pd(b1, b0)));
        const __m256d corner = _mm256_add_pd(
            _mm256_sub_pd(_mm256_mul_pd(half, _mm256_add_pd(area_x, area_y)), qpi),
            _mm256_mul_pd(a, b));
        const __m256d inside = _mm256_cmp_pd(
            _mm256_add_pd(_mm256_mul_pd(a, a), _mm256_mul_pd(b, b)), one, _CMP_LT_OQ);
        const __m256d area_xy = _mm256_and_pd(inside, corner);
        const __m256d base = _mm256_add_pd(_mm256_mul_pd(_mm256_add_pd(fy, pad), stride),
                                           _mm256_add_pd(fx, pad));
        const __m256d based = _mm256_add_pd(base, drow);
        const __m256d v00 = gather_s(k.v, base), vx = gather_s(k.v, _mm256_add_pd(base, dx));
        const __m256d vy = gather_s(k.v, based), vxy = gather_s(k.v, _mm256_add_pd(based, dx));
        __m256d sum = _mm256_mul_pd(
            v00, _mm256_add_pd(_mm256_sub_pd(_mm256_sub_pd(pi, area_x), area_y), area_xy));
        sum = _mm256_add_pd(sum, _mm256_mul_pd(vx, _mm256_sub_pd(area_x, area_xy)));
        sum = _mm256_add_pd(sum, _mm256_mul_pd(vy, _mm256_sub_pd(area_y, area_xy)));
        sum = _mm256_add_pd(sum, _mm256_mul_pd(vxy, area_xy));
        _mm256_storeu_pd(out + i, _mm256_mul_pd(_mm256_mul_pd(rr, rr), sum));
    }
    for (; i < n; ++i)
        out[i] = k.one(x[i], y[i], r[i]);
}
#endif

}  // namespace

void ExposurePlane::integrals_over_discs(const double* x_um, const double* y_um,
                                         const double* r_um, size_t n, double* out,
                                         bool portable) const
{
#if defined(__x86_64__) && defined(__GNUC__)
    static const bool has_avx2 = __builtin_cpu_supports("avx2");
    if (has_avx2 && !portable)
        return plane_integrals_avx2(PlaneIntegrals(*this), x_um, y_um, r_um, n, out);
#endif
    (void)portable;
    plane_integrals_portable(PlaneIntegrals(*this), x_um, y_um, r_um, n, out);
}

double ExposurePlane::max_over(double x0_um, double y0_um, double x1_um, double y1_um) const
{
    const double gx0 = std::floor(x0_um * m_per_pitch_um - m_x0);
    const double gy0 = std::floor(y0_um * m_per_pitch_um - m_y0);
    const double gx1 = std::floor(x1_um * m_per_pitch_um - m_x0);
    const double gy1 = std::floor(y1_um * m_per_pitch_um - m_y0);
    if (!(gx0 >= 0.0 && gy0 >= 0.0 && gx1 < m_w && gy1 < m_h))
        return std::numeric_limits<double>::infinity();
    float top = 0.0f;
    for (size_t y = static_cast<size_t>(gy0); y <= static_cast<size_t>(gy1); ++y) {
        const float* row = m_padded.data() + (y + kPad) * m_padded_stride + kPad;
        for (size_t x = static_cast<size_t>(gx0); x <= static_cast<size_t>(gx1); ++x)
            top = std::max(top, row[x]);
    }
    return top;
}

double ExposurePlane::integral_over_disc(double x_um, double y_um, double r_um) const
{
    const PlaneIntegrals k(*this);
    return r_um <= 0.5 * m_pitch_um ? k.one(x_um, y_um, r_um) : k.wide(x_um, y_um, r_um);
}

}  // namespace filmgrain
