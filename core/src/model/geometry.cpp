// MODEL.md section 1: the frame, its pixel grids, and the grain processes.
#include "model/geometry.h"

#include <cmath>
#include <limits>

#include "util/rng.h"
#include "util/sampling.h"

namespace filmgrain {

namespace {

/// Bin 0 holds z <= 3 (99.87% of grains); higher bins double the diameter.
constexpr double kFirstBinTopZ = 3.0;
/// Diameters with z above this are not generated (Q(9) = 1.1e-19).
constexpr double kTruncationZ = 9.0;
/// Expected grains per cell: trades per-cell overhead against grains
/// generated outside the region asked for.
constexpr double kGrainsPerCell = 16.0;

}  // namespace

Status FrameGeometry::make(double width_mm, int64_t input_width, int64_t input_height,
                           int64_t scan_width, int64_t scan_height, FrameGeometry& out,
                           const Roi& reference)
{
    if (!std::isfinite(width_mm) || width_mm <= 0.0 || width_mm > 1e9)
        return Status::errorf("width_mm = ", width_mm, ": must be in (0, 1e9]");
    if (input_width <= 0 || input_height <= 0)
        return Status::errorf("input image is ", input_width, "x", input_height,
                              ": must have at least one pixel");
    if (scan_width < 0 || scan_height < 0)
        return Status::errorf("scan = ", scan_width, "x", scan_height,
                              ": sizes must be positive");
    const Roi ref = reference.empty() ? Roi { 0, 0, input_width, input_height } : reference;
    if (ref.x_begin < 0 || ref.y_begin < 0 || ref.x_end > input_width || ref.y_end > input_height)
        return Status::errorf("scan reference [", ref.x_begin, ", ", ref.x_end, ") x [",
                              ref.y_begin, ", ", ref.y_end, ") lies outside the ", input_width,
                              "x", input_height, " input");
    FrameGeometry g;
    g.width_um       = um_from_mm(width_mm);
    g.input_width    = input_width;
    g.input_height   = input_height;
    g.input_pitch_um = g.width_um / static_cast<double>(input_width);
    g.height_um      = g.input_pitch_um * static_cast<double>(input_height);
    g.scan_reference = ref;
    const int64_t ref_w = ref.width(), ref_h = ref.height();
    // Over the whole input (no reference) the frame's own size, so that the
    // scan covers it exactly whatever the rounding of the pitch.
    const bool whole = ref_w == input_width && ref_h == input_height;
    const double ref_w_um = whole ? g.width_um : g.input_pitch_um * static_cast<double>(ref_w);
    const double ref_h_um = whole ? g.height_um : g.input_pitch_um * static_cast<double>(ref_h);
    g.scan_width     = scan_width ? scan_width : ref_w;
    if (scan_height) {
        g.scan_height = scan_height;
    } else if (!scan_width) {
        g.scan_height = ref_h;
    } else {
        const double h = std::round(static_cast<double>(g.scan_width) * ref_h_um / ref_w_um);
        g.scan_height  = std::max<int64_t>(1, static_cast<int64_t>(h));
    }
    constexpr int64_t kMaxSide = int64_t(1) << 40;
    if (g.scan_width > kMaxSide || g.scan_height > kMaxSide)
        return Status::errorf("scan = ", g.scan_width, "x", g.scan_height,
                              ": each side must be at most 2^40");
    g.scan_pitch_x_um = ref_w_um / static_cast<double>(g.scan_width);
    g.scan_pitch_y_um = ref_h_um / static_cast<double>(g.scan_height);
    g.scan_origin_x_um = g.input_pitch_um * static_cast<double>(ref.x_begin);
    g.scan_origin_y_um = g.input_pitch_um * static_cast<double>(ref.y_begin);
    out                = g;
    return {};
}

namespace {

/// GCC's and Clang's 128-bit integer (__extension__: not ISO C++, said once).
__extension__ typedef __int128 Int128;

/// floor(a / b) and ceil(a / b) for b > 0, exactly (128-bit products).
int64_t floor_div(Int128 a, Int128 b)
{
    const Int128 q = a / b;
    return static_cast<int64_t>(q * b > a ? q - 1 : q);
}
int64_t ceil_div(Int128 a, Int128 b)
{
    const Int128 q = a / b;
    return static_cast<int64_t>(q * b < a ? q + 1 : q);
}

}  // namespace

Roi scan_pixels_over(const Roi& reference, int64_t scan_width, int64_t scan_height,
                     const Roi& input_pixels)
{
    // Input pixel x lies at scan position (x - ref.x_begin) * scan_width /
    // ref.width() (and likewise down).
    const Roi& r      = reference;
    const Int128 sw = scan_width, sh = scan_height, rw = r.width(), rh = r.height();
    return Roi { floor_div(static_cast<Int128>(input_pixels.x_begin - r.x_begin) * sw, rw),
                 floor_div(static_cast<Int128>(input_pixels.y_begin - r.y_begin) * sh, rh),
                 ceil_div(static_cast<Int128>(input_pixels.x_end - r.x_begin) * sw, rw),
                 ceil_div(static_cast<Int128>(input_pixels.y_end - r.y_begin) * sh, rh) };
}

Roi FrameGeometry::frame_scan_pixels() const
{
    return scan_pixels_over(scan_reference, scan_width, scan_height,
                            Roi { 0, 0, input_width, input_height });
}

PopulationGrains::PopulationGrains(const Population& pop, uint64_t seed, uint32_t layer_index,
                                   uint32_t population_index)
{
    const double s   = pop.diameter_log_sigma;
    m_log_sigma      = s;
    m_log_median_um  = log_median_diameter_um(pop);
    m_mean_area_um2  = mean_disc_area_um2(pop);
    m_key            = hash_ids(seed, layer_index, population_index);
    const double lam = pop.grains_per_um2;
    // A process of no grains (a population thinned to nothing, e.g. to a
    // fog probability of 0) has no bins: it visits no cell.
    if (!(lam > 0.0))
        return;

    const auto add_bin   = [&](double z_lo, double z_hi, double probability) {
        m_bins.push_back(Bin { z_lo, z_hi, lam * probability, radius_at_z_um(z_hi),
                               std::sqrt(kGrainsPerCell / (lam * probability)),
                               TruncatedNormal(z_lo, z_hi) });
    };

    // Bins are only needed where diameters differ enough to matter for the
    // search margin; a narrow distribution is a single bin.
    const double inf = std::numeric_limits<double>::infinity();
    if (s * (kTruncationZ - kFirstBinTopZ) < std::log(2.0)) {
        add_bin(-inf, kTruncationZ, 1.0 - normal_upper_tail(kTruncationZ));
        return;
    }
    add_bin(-inf, kFirstBinTopZ, normal_cdf(kFirstBinTopZ));
    const double dz = std::log(2.0) / s;
    for (double z_lo = kFirstBinTopZ; z_lo < kTruncationZ; z_lo += dz) {
        const double z_hi = std::min(z_lo + dz, kTruncationZ);
        add_bin(z_lo, z_hi, normal_upper_tail(z_lo) - normal_upper_tail(z_hi));
    }
}

double PopulationGrains::max_radius_um() const
{
    double r = 0.0;
    for (const Bin& b : m_bins)
        r = std::max(r, b.max_radius_um);
    return r;
}

void PopulationGrains::cell_grains(size_t bin_index, int64_t cx, int64_t cy,
                                   std::vector<Grain>& out) const
{
    const Bin& bin         = m_bins[bin_index];
    const uint64_t cell_id = this->cell_id(bin_index, cx, cy);
    Rng rng(cell_id, Stage::cell);
    const uint64_t count = sample_poisson(bin.grains_per_um2 * bin.cell_um * bin.cell_um, rng);
    for (uint64_t i = 0; i < count; ++i) {
        Grain g;
        g.x_um = (static_cast<double>(cx) + rng.uniform()) * bin.cell_um;
        g.y_um = (static_cast<double>(cy) + rng.uniform()) * bin.cell_um;
        const double z
            = m_log_sigma > 0.0 ? bin.z.sample(rng.uniform()) : 0.0;
        g.radius_um = radius_at_z_um(z);
        g.id        = hash_combine(cell_id, i);
        out.push_back(g);
    }
}

}  // namespace filmgrain
