// filmgrain: MODEL.md section 1, geometry: the frame, its pixel grids, and
// the procedural grain populations.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "filmgrain/image.h"
#include "filmgrain/status.h"
#include "filmgrain/stock.h"
#include "util/rng.h"
#include "util/sampling.h"

namespace filmgrain {

/// Micrometres per millimetre (unit conversion helper).
inline constexpr double um_from_mm(double mm) { return mm * 1000.0; }

/// An axis-aligned rectangle on the film, micrometres.
struct RectUm {
    double x0_um = 0.0, y0_um = 0.0, x1_um = 0.0, y1_um = 0.0;
};

/// The film frame and the input and scan pixel grids over it. The input is
/// mapped with square pixels of pitch frame_width / input_width; the scan
/// has its own resolution: scan_width x scan_height pixels over the scan
/// reference (a rectangle of input pixels, by default the whole input), its
/// grid continuing beyond the reference at the same pitch, so that it may
/// cover the rest of the frame too (a plate's overscan around its display
/// window). Scan pixel (0, 0) is the reference's corner. Row 0 is the top.
struct FrameGeometry {
    double width_um        = 0.0;
    double height_um       = 0.0;
    int64_t input_width    = 0;
    int64_t input_height   = 0;
    double input_pitch_um  = 0.0;
    int64_t scan_width     = 0;
    int64_t scan_height    = 0;
    double scan_pitch_x_um = 0.0;
    double scan_pitch_y_um = 0.0;
    /// The input pixels the scan's scan_width x scan_height pixels cover.
    Roi scan_reference;
    /// Film position of scan pixel (0, 0)'s corner (the reference's).
    double scan_origin_x_um = 0.0;
    double scan_origin_y_um = 0.0;

    /// scan_width 0: the reference's width in input pixels; scan_height 0:
    /// follow the reference's aspect ratio. `reference`: empty for the
    /// whole input. Fails on non-positive or non-finite sizes and on a
    /// reference that is not inside the input.
    static Status make(double width_mm, int64_t input_width, int64_t input_height,
                       int64_t scan_width, int64_t scan_height, FrameGeometry& out,
                       const Roi& reference = {});

    /// Film rectangle of a block of scan pixels [x0, x1) x [y0, y1).
    RectUm scan_rect(int64_t x0, int64_t y0, int64_t x1, int64_t y1) const
    {
        return { scan_origin_x_um + x0 * scan_pitch_x_um, scan_origin_y_um + y0 * scan_pitch_y_um,
                 scan_origin_x_um + x1 * scan_pitch_x_um, scan_origin_y_um + y1 * scan_pitch_y_um };
    }

    /// The scan pixels over the whole frame: the frame rounded outward to
    /// whole scan pixels (without a reference, [0, scan_width) x [0,
    /// scan_height)). A render's ROI lies inside it.
    Roi frame_scan_pixels() const;
};

/// The scan pixels (scan_width x scan_height over `reference`) over a
/// rectangle of input pixels: its film rectangle rounded outward to whole
/// scan pixels, in exact integer arithmetic (filmgrain/render.h's
/// scan_pixels_over).
Roi scan_pixels_over(const Roi& reference, int64_t scan_width, int64_t scan_height,
                     const Roi& input_pixels);

/// One grain: a disc and the identity that keys all of its random streams.
struct Grain {
    double x_um      = 0.0;
    double y_um      = 0.0;
    double radius_um = 0.0;
    uint64_t id      = 0;
};

/// MODEL.md 1: ln d of a population's grains is Normal(ln diameter_um -
/// s^2/2, s^2) (mean diameter diameter_um): its mean, and the diameter at
/// normal score z.
inline double log_median_diameter_um(const Population& pop)
{
    const double s = pop.diameter_log_sigma;
    return std::log(pop.diameter_um) - 0.5 * s * s;
}
inline double diameter_at_z_um(const Population& pop, double z)
{
    return std::exp(log_median_diameter_um(pop) + pop.diameter_log_sigma * z);
}
/// MODEL.md 1: the mean disc area a_mean = pi/4 diameter_um^2 exp(s^2).
inline double mean_disc_area_um2(const Population& pop)
{
    const double s = pop.diameter_log_sigma;
    return M_PI / 4.0 * pop.diameter_um * pop.diameter_um * std::exp(s * s);
}

/// The grain process of one population, generated procedurally per film
/// cell. A population's disc diameters are lognormal: ln d ~ Normal(ln
/// diameter_um - s^2/2, s^2). To find every grain that may touch a region
/// without a global bound on the radius, the process is split (thinned)
/// into independent Poisson processes by bins of the standard normal z of
/// ln d: (-inf, 3], then bins that each double the diameter, up to z = 9.
/// Each bin has its own cell size and its own search margin (its largest
/// radius). Diameters above z = 9 (probability 1.1e-19 per grain) are not
/// generated: the only deviation from MODEL.md 1, far below any test's
/// resolution (a frame of 1e12 grains misses one with probability 1e-7).
///
/// Grains of a cell are a pure function of (seed, layer, population, bin,
/// cell): never of tile, ROI or thread. A population of grains_per_um2 0
/// (only ever made by thinning one, as the fog path does) has no bins and
/// no grains. Thread safety: const, shareable.
class PopulationGrains {
public:
    PopulationGrains(const Population& pop, uint64_t seed, uint32_t layer_index,
                     uint32_t population_index);

    /// Mean disc area a_mean = pi/4 d^2 exp(s^2), square micrometres.
    double mean_area_um2() const { return m_mean_area_um2; }
    /// Largest radius this population generates, micrometres.
    double max_radius_um() const;

    /// Calls visit(const Grain&) for every grain whose centre lies within its
    /// bin's largest radius of `rect` (a superset of the grains whose discs
    /// touch it), in a fixed global order: bin, cell row, cell column, index.
    /// The visitor decides what touches. `reach`: as for_each_cell_near.
    template<typename Visit>
    void for_each_grain_near(const RectUm& rect, Visit&& visit) const
    {
        for_each_grain_near(rect, 1.0, visit);
    }
    template<typename Visit>
    void for_each_grain_near(const RectUm& rect, double reach, Visit&& visit) const;

    /// Calls visit(bin, cx, cy) for every cell whose grains may reach
    /// `rect` (centres within the bin's largest radius of it, times `reach`
    /// for an image that reaches beyond the grain: dye clouds), in the
    /// order of for_each_grain_near. Engines that generate a cell's grains
    /// their own way use this and cell_id().
    template<typename Visit>
    void for_each_cell_near(const RectUm& rect, Visit&& visit, double reach = 1.0) const;

    /// The identity of a cell, keying its random streams.
    uint64_t cell_id(size_t bin, int64_t cx, int64_t cy) const
    {
        return hash_ids(m_key, bin, static_cast<uint64_t>(cx), static_cast<uint64_t>(cy));
    }
    /// Disc radius at normal score z of ln d, micrometres.
    double radius_at_z_um(double z) const { return 0.5 * std::exp(m_log_median_um + m_log_sigma * z); }

    /// The bins, for tests and diagnostics.
    struct Bin {
        double z_lo;            ///< lower bound of z (exclusive; -inf for bin 0)
        double z_hi;            ///< upper bound of z (inclusive)
        double grains_per_um2;  ///< intensity of this bin's process
        double max_radius_um;   ///< radius at z_hi
        double cell_um;         ///< side of this bin's square cells
        TruncatedNormal z;      ///< z restricted to the bin
    };
    const std::vector<Bin>& bins() const { return m_bins; }

private:
    /// Grains of one cell, appended to `out`.
    void cell_grains(size_t bin, int64_t cx, int64_t cy, std::vector<Grain>& out) const;

    double m_log_median_um = 0.0;  ///< mean of ln d
    double m_log_sigma     = 0.0;
    double m_mean_area_um2 = 0.0;
    uint64_t m_key         = 0;  ///< hash of (seed, layer, population)
    std::vector<Bin> m_bins;
};

template<typename Visit>
void PopulationGrains::for_each_cell_near(const RectUm& rect, Visit&& visit, double reach) const
{
    for (size_t b = 0; b < m_bins.size(); ++b) {
        const Bin& bin   = m_bins[b];
        const double pad = reach * bin.max_radius_um;
        const auto cell  = [&](double v) {
            return static_cast<int64_t>(std::floor(v / bin.cell_um));
        };
        const int64_t cx0 = cell(rect.x0_um - pad), cx1 = cell(rect.x1_um + pad);
        const int64_t cy0 = cell(rect.y0_um - pad), cy1 = cell(rect.y1_um + pad);
        for (int64_t cy = cy0; cy <= cy1; ++cy)
            for (int64_t cx = cx0; cx <= cx1; ++cx)
                visit(b, cx, cy);
    }
}

template<typename Visit>
void PopulationGrains::for_each_grain_near(const RectUm& rect, double reach, Visit&& visit) const
{
    std::vector<Grain> grains;
    for_each_cell_near(
        rect,
        [&](size_t b, int64_t cx, int64_t cy) {
            grains.clear();
            cell_grains(b, cx, cy, grains);
            for (const Grain& g : grains)
                visit(g);
        },
        reach);
}

}  // namespace filmgrain
