// filmgrain: the per-grain kernel of the fast paths. MODEL.md 1-4 for the
// grains of a tile in one plain loop per cell, chosen once per population
// (OCIO's "renderer chosen once"):
//   - generation: the population's Poisson process, cell by cell as
//     PopulationGrains splits it (same bins, cells and intensities), but a
//     cell's count comes from its bin's tabulated Poisson CDF, and
//     each grain's position, size and develop uniform come from two words
//     of a counter-based stream of its cell (no per-grain seeding), and its
//     radius from the bin's tabulated quantile function;
//   - exposure at the grain's centre times its area (ExposureMethod::centre),
//     read from a float plane of the layer's values over the tile;
//   - development: one uniform against P(develop | lambda) (DevelopCurve),
//     the Poisson count and the latent-image chain folded into the curve.
// Same distribution as the exact engine up to the errors each step reports
// (quantile interpolation, centre exposure, the curve and its table); not
// the same grains (the streams differ). Deterministic: everything is keyed
// by the cell.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "model/exposure.h"
#include "model/geometry.h"
#include "model/image_formation.h"
#include "util/rng.h"
#include "util/sampling.h"

namespace filmgrain {

/// A population's grains drawn the fast way. Thread safety: const.
class FastGrains {
public:
    /// `quantiles` intervals of the radius quantile function per bin.
    FastGrains(const PopulationGrains& grains, int quantiles = 4096);

    /// Largest relative error of a tabulated radius, measured at the
    /// midpoints between quantile nodes against the exact inverse CDF (it
    /// is largest at the steep ends of the bins: ~0.45 in the lowest
    /// 1/quantiles of bin 0, whose radius tends to 0, ~1e-2 at most else).
    double max_radius_relative_error() const { return m_max_radius_error; }
    /// Relative error of the mean disc area the table gives (what moves a
    /// density: D = 0.434 n E[a P]), against Simpson's rule on the exact
    /// quantile function.
    double mean_area_relative_error() const { return m_mean_area_error; }

    /// Calls visit(x_um, y_um, r_um, u_bits, id) for every grain whose centre
    /// lies within its bin's largest radius of `rect`: u_bits is 32 uniform
    /// bits for the grain's development, id a stable identity for the rare
    /// grain that needs more random numbers (its photon count beyond the
    /// curve).
    template<typename Visit> void for_each_grain_near(const RectUm& rect, Visit&& visit) const;

    /// A cell's grains as arrays, for kernels that decide them in plain
    /// loops: grain i is at (x[i], y[i]) with radius r[i] and development
    /// bits u_bits[i]; its identity (for_each_grain_near's id) is
    /// grain_id(i). `drawn`: the cell's grains before any filter.
    struct Batch {
        uint64_t cell = 0;
        size_t bin    = 0;
        int64_t cx = 0, cy = 0;
        size_t n      = 0;
        size_t drawn  = 0;
        std::vector<double> x, y, r;
        std::vector<uint32_t> u_bits;
        std::vector<uint32_t> index;  ///< each grain's place among the drawn
        uint64_t grain_id(size_t i) const { return hash_combine(cell, index[i]); }
    };
    /// Calls visit(batch) for every cell of for_each_grain_near, in its
    /// order, with the cell's grains (the same grains, in the same order).
    /// `batch` is scratch, reused from cell to cell.
    template<typename Visit>
    void for_each_cell_batch(const RectUm& rect, Batch& batch, Visit&& visit) const
    {
        for_each_cell_batch(
            rect, 1.0, batch, [](size_t, int64_t, int64_t) { return nullptr; }, visit);
    }
    /// The same for grains whose image reaches `reach` times their radius
    /// (PopulationGrains::for_each_cell_near), with a filter:
    /// filter_of(bin, cx, cy) gives, for each cell,
    /// either nullptr (every grain) or a predicate keep(r_um, u_bits) on a
    /// grain's radius and development bits; the batch then holds only the
    /// grains it keeps (same values, same identities, in order; batch.drawn
    /// counts them all), and only their positions are drawn. A predicate
    /// with may_keep(u_bits) false keeps no grain of those bits whatever
    /// its radius, which is then not drawn. For kernels that can tell from
    /// radius and uniform alone that a grain will not develop
    /// (tile_renderer.cpp's grain filter).
    template<typename FilterOf, typename Visit>
    void for_each_cell_batch(const RectUm& rect, double reach, Batch& batch, FilterOf&& filter_of,
                             Visit&& visit) const;

    /// How many of a batch's drawn grains (batch.drawn, kept or not) have
    /// their centre in [x0, x1) x [y0, y1): from the kept grains'
    /// positions when the filter kept all, else the cell's count where it
    /// lies wholly inside or outside, else every drawn grain's position.
    size_t drawn_within(const Batch& batch, const RectUm& rect) const;

    /// The bins, as PopulationGrains has them.
    const std::vector<PopulationGrains::Bin>& bins() const { return m_grains.bins(); }
    /// The largest radius the table gives a grain of bin b (its top node;
    /// an interpolated radius exceeds it by rounding at most).
    double largest_radius_um(size_t b) const
    {
        return m_radius[b][static_cast<size_t>(m_quantiles)];
    }

private:
    /// Grain i's centre, drawn from its cell's counter word 2 i: in the
    /// cell whose corner is (x0_um, y0_um), scale_um = cell side / 2^32.
    static void grain_position(uint64_t cell, uint64_t i, double x0_um, double y0_um,
                               double scale_um, double& x_um, double& y_um)
    {
        const uint64_t w0 = counter_u64(cell, 2 * i);
        x_um = x0_um + static_cast<double>(w0 & 0xffffffffu) * scale_um;
        y_um = y0_um + static_cast<double>(w0 >> 32) * scale_um;
    }

    PopulationGrains m_grains;
    int m_quantiles = 0;
    /// Per bin: radius at u = k / quantiles, k = 0..quantiles, and a copy of
    /// the last (interpolation at u -> 1 needs no check).
    std::vector<std::vector<double>> m_radius;
    /// Per bin: its cells' Poisson counts, tabulated.
    std::vector<PoissonTable> m_counts;
    double m_max_radius_error = 0.0;
    double m_mean_area_error  = 0.0;
};

template<typename FilterOf, typename Visit>
void FastGrains::for_each_cell_batch(const RectUm& rect, double reach, Batch& batch,
                                     FilterOf&& filter_of, Visit&& visit) const
{
    constexpr double k2m32 = 0x1.0p-32;
    const double q         = static_cast<double>(m_quantiles) * k2m32;
    m_grains.for_each_cell_near(rect, [&](size_t b, int64_t cx, int64_t cy) {
        const PopulationGrains::Bin& bin = m_grains.bins()[b];
        const uint64_t cell              = m_grains.cell_id(b, cx, cy);
        Rng count_rng(cell, Stage::fast_cell);
        const uint64_t n = m_counts[b].sample(count_rng.uniform());
        batch.cell  = cell;
        batch.bin   = b;
        batch.cx    = cx;
        batch.cy    = cy;
        batch.drawn = static_cast<size_t>(n);
        if (batch.x.size() < batch.drawn) {
            batch.x.resize(batch.drawn);
            batch.y.resize(batch.drawn);
            batch.r.resize(batch.drawn);
            batch.u_bits.resize(batch.drawn);
            batch.index.resize(batch.drawn);
        }
        const double* radius = m_radius[b].data();
        const double x0 = static_cast<double>(cx) * bin.cell_um;
        const double y0 = static_cast<double>(cy) * bin.cell_um;
        const double scale = bin.cell_um * k2m32;
        double* xs = batch.x.data();
        double* ys = batch.y.data();
        double* rs = batch.r.data();
        uint32_t* us = batch.u_bits.data();
        uint32_t* index = batch.index.data();
        const auto keep = filter_of(b, cx, cy);
        // Radius and development bits first, each grain written and kept
        // or not without a branch; then the kept grains' positions.
        size_t m = 0;
        for (size_t i = 0; i < batch.drawn; ++i) {
            const uint64_t w1 = counter_u64(cell, 2 * i + 1);
            const uint32_t u  = static_cast<uint32_t>(w1 >> 32);
            // A grain the filter drops whatever its radius: no radius.
            if constexpr (!std::is_same_v<std::decay_t<decltype(keep)>, std::nullptr_t>)
                if (keep && !keep.may_keep(u))
                    continue;
            const double t    = static_cast<double>(w1 & 0xffffffffu) * q;
            const size_t k    = static_cast<size_t>(t);
            const double r_um = radius[k] + (t - static_cast<double>(k)) * (radius[k + 1] - radius[k]);
            rs[m]    = r_um;
            us[m]    = u;
            index[m] = static_cast<uint32_t>(i);
            if constexpr (std::is_same_v<std::decay_t<decltype(keep)>, std::nullptr_t>)
                ++m;
            else
                m += !keep || keep(r_um, u);
        }
        for (size_t j = 0; j < m; ++j)
            grain_position(cell, index[j], x0, y0, scale, xs[j], ys[j]);
        batch.n = m;
        visit(static_cast<const Batch&>(batch));
    }, reach);
}

template<typename Visit>
void FastGrains::for_each_grain_near(const RectUm& rect, Visit&& visit) const
{
    Batch batch;
    for_each_cell_batch(rect, batch, [&](const Batch& b) {
        for (size_t i = 0; i < b.n; ++i)
            visit(b.x[i], b.y[i], b.r[i], b.u_bits[i], b.grain_id(i));
    });
}

/// The area of the unit disc beyond a line at distance t from its centre,
/// acos t - t sqrt(1 - t^2) for t in [0, 1] (pi/2 at 0, 0 at 1 and beyond),
/// tabulated (linear interpolation on 4096 intervals) for the kernel's disc
/// integral. Thread safety: const.
class SegmentTable {
public:
    SegmentTable();
    /// S(t) by linear interpolation, t in [0, 1] (the kernel's loops,
    /// PlaneIntegrals, interpolate the same nodes the same way).
    double area(double t) const
    {
        const double s = t * kIntervals;
        const int k    = static_cast<int>(s);
        return m_area[k] + (s - static_cast<double>(k)) * (m_area[k + 1] - m_area[k]);
    }
    /// Largest absolute error of area() against the formula, measured at
    /// the midpoints of the intervals (~1e-6, in the last interval, where
    /// the area falls as (1 - t)^1.5).
    double max_error() const { return m_max_error; }
    /// The process's table.
    static const SegmentTable& shared();

    static constexpr int kIntervals = 4096;
    /// The nodes, at t = k / kIntervals for k = 0..kIntervals, and a copy
    /// of the last (t = 1 reads it and the next).
    const double* nodes() const { return m_area.data(); }

private:
    std::vector<double> m_area;
    double m_max_error = 0.0;
};

/// The exposure values v of one layer (LayerExposure) over the input pixels
/// under a film rectangle, as floats; beyond the image the nearest edge
/// pixel's (the exposure's edge clamp) or 0 (gate), as LayerExposure reads
/// them: the centre lookup of the fast kernel costs one load, its disc
/// integral four. Reused from tile to tile.
class ExposurePlane {
public:
    /// Fills the plane for the input pixels that `rect` touches.
    void fill(const LayerExposure& exposure, const FrameGeometry& frame, const RectUm& rect);

    /// The input pixel pitch: the largest radius integral_over_disc takes;
    /// integrals_over_discs takes half of it.
    double pitch_um() const { return m_pitch_um; }

    /// The integral of v over the disc (value x um^2) against the
    /// box-reconstructed image, as LayerExposure::integrate_over_disc, for
    /// a disc of radius r <= pitch_um() that lies inside the filled window
    /// (pixels beyond it read 0, as outside the image). Such a disc never
    /// crosses two pixel edges on one side of its centre. A disc with r <=
    /// pitch / 2 crosses at most the nearer vertical and horizontal edge:
    /// with a = the distance to the vertical edge and b to the horizontal
    /// one, in radii, its area beyond the vertical edge is r^2 S(a), beyond
    /// the horizontal one r^2 S(b) (S: SegmentTable), and beyond both (the
    /// corner's quadrant, when the corner is inside the disc, a^2 + b^2 <
    /// 1) r^2 (S(a) / 2 + S(b) / 2 - pi / 4 + a b): the four pixels around
    /// the corner get their shares of pi r^2. A wider disc: the same with
    /// the edges on both sides and the four corners, over the nine pixels
    /// around. Exact up to the segment table's error (max_error() r^2 per
    /// edge) and the plane's float values.
    double integral_over_disc(double x_um, double y_um, double r_um) const;

    /// integral_over_disc of n discs (x[i], y[i], r[i]) with r <= pitch / 2
    /// into out[i], in one loop that the AVX2 build runs four discs at a
    /// time (the same values in every build: the same IEEE operations, no
    /// FMA). A wider disc, or one beyond the window, gets a wrong value,
    /// never a read outside the plane's memory. `portable`: the baseline
    /// build even where the processor has AVX2 (for the test that both
    /// agree).
    void integrals_over_discs(const double* x_um, const double* y_um, const double* r_um,
                              size_t n, double* out, bool portable = false) const;

    /// The largest v over the input pixels that the rectangle [x0, x1] x
    /// [y0, y1] touches (a bound of v over it); +infinity where it reaches
    /// beyond the filled window.
    double max_over(double x0_um, double y0_um, double x1_um, double y1_um) const;

    /// v at the input pixel holding (x, y); 0 outside the filled window
    /// (outside the image, or beyond the rectangle it was filled for).
    double at(double x_um, double y_um) const
    {
        // floor() without a library call: negative values fall outside the
        // window whichever way they round, as the check below needs.
        const double gx = x_um * m_per_pitch_um - m_x0, gy = y_um * m_per_pitch_um - m_y0;
        if (!(gx >= 0.0 && gy >= 0.0 && gx < m_w && gy < m_h))
            return 0.0;
        const size_t fx = static_cast<size_t>(gx), fy = static_cast<size_t>(gy);
        return m_padded[(fy + kPad) * m_padded_stride + (fx + kPad)];
    }

private:
    /// Pixels of zeros around the window in m_padded.
    static constexpr int64_t kPad = 2;
    friend struct PlaneIntegrals;

    /// The window's values with kPad pixels of zeros on every side (the
    /// disc integrals read the neighbours of a pixel without checks).
    std::vector<float> m_padded;
    int64_t m_nx = 0, m_ny = 0;
    size_t m_padded_stride = 0;
    const SegmentTable* m_segment = &SegmentTable::shared();
    double m_pitch_um = 0.0;
    double m_per_pitch_um = 0.0;
    double m_x0 = 0.0, m_y0 = 0.0, m_w = 0.0, m_h = 0.0;
};

}  // namespace filmgrain
