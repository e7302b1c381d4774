// Microdensitometer granularity: circular apertures over a patch.
#include "granularity.h"

#include <cmath>

namespace filmgrain::sensitometry {

double GranularityReading::selwyn_um() const
{
    return sigma_density * std::sqrt(2.0 * aperture_area_um2);
}

namespace {

/// Sufficient statistics of one block.
struct BlockSums {
    double n = 0, t = 0, t2 = 0, d = 0, d2 = 0;
    void add(const BlockSums& o)
    {
        n += o.n;
        t += o.t;
        t2 += o.t2;
        d += o.d;
        d2 += o.d2;
    }
};

struct Moments {
    double mean_d, sigma_d, rel_sigma_t;
};

Moments moments_of(const BlockSums& s)
{
    const double mean_t = s.t / s.n, mean_d = s.d / s.n;
    const double var_t  = std::max(0.0, s.t2 / s.n - mean_t * mean_t) * s.n / (s.n - 1.0);
    const double var_d  = std::max(0.0, s.d2 / s.n - mean_d * mean_d) * s.n / (s.n - 1.0);
    return { mean_d, std::sqrt(var_d), std::sqrt(var_t) / mean_t };
}

}  // namespace

GranularityReading read_granularity(const std::vector<double>& transmittance, int64_t side_px,
                                    const ApertureTemplate& aperture, int spacing_px,
                                    double base_density, int blocks)
{
    GranularityReading out;
    out.aperture_diameter_um = aperture.diameter_um;
    out.aperture_area_um2    = aperture.area_um2();
    const int r      = aperture.radius_px;
    const int side_t = 2 * r + 1;
    double w_total   = 0.0;
    for (double w : aperture.weights)
        w_total += w;
    // Sum over the template, row by row: the fully inside run of a row via
    // a prefix sum, its partial pixels one by one.
    struct Row {
        int dy, full_lo, full_hi;
        std::vector<std::pair<int, double>> partial;
    };
    std::vector<Row> rows;
    for (int dy = -r; dy <= r; ++dy) {
        Row row { dy, 1, 0, {} };
        for (int dx = -r; dx <= r; ++dx) {
            const double w = aperture.weights[static_cast<size_t>((dy + r) * side_t + dx + r)];
            if (w >= 1.0 - 1e-12) {
                if (row.full_lo > row.full_hi)
                    row.full_lo = row.full_hi = dx;
                else
                    row.full_hi = dx;
            }
        }
        for (int dx = -r; dx <= r; ++dx) {
            const double w = aperture.weights[static_cast<size_t>((dy + r) * side_t + dx + r)];
            const bool in_run = row.full_lo <= row.full_hi && dx >= row.full_lo && dx <= row.full_hi;
            if (w > 0.0 && !in_run)
                row.partial.emplace_back(dx, w);
        }
        rows.push_back(std::move(row));
    }
    // Row prefix sums of T.
    std::vector<double> prefix(static_cast<size_t>(side_px * (side_px + 1)));
    for (int64_t y = 0; y < side_px; ++y) {
        double acc = 0.0;
        prefix[static_cast<size_t>(y * (side_px + 1))] = 0.0;
        for (int64_t x = 0; x < side_px; ++x) {
            acc += transmittance[static_cast<size_t>(y * side_px + x)];
            prefix[static_cast<size_t>(y * (side_px + 1) + x + 1)] = acc;
        }
    }
    std::vector<BlockSums> block(static_cast<size_t>(blocks * blocks));
    for (int64_t cy = r; cy + r < side_px; cy += spacing_px)
        for (int64_t cx = r; cx + r < side_px; cx += spacing_px) {
            double sum = 0.0;
            for (const Row& row : rows) {
                const int64_t y = cy + row.dy;
                const double* pre = &prefix[static_cast<size_t>(y * (side_px + 1))];
                if (row.full_lo <= row.full_hi)
                    sum += pre[cx + row.full_hi + 1] - pre[cx + row.full_lo];
                for (const auto& [dx, w] : row.partial)
                    sum += w * transmittance[static_cast<size_t>(y * side_px + cx + dx)];
            }
            const double t = sum / w_total;
            const double d = -std::log10(t) + base_density;
            BlockSums& b = block[static_cast<size_t>((cy * blocks / side_px) * blocks
                                                     + cx * blocks / side_px)];
            b.n += 1;
            b.t += t;
            b.t2 += t * t;
            b.d += d;
            b.d2 += d * d;
        }
    BlockSums all;
    for (const BlockSums& b : block)
        all.add(b);
    out.positions = static_cast<int64_t>(all.n);
    if (all.n < 2)
        return out;
    const Moments m = moments_of(all);
    out.mean_density                 = m.mean_d;
    out.sigma_density                = m.sigma_d;
    out.relative_sigma_transmittance = m.rel_sigma_t;
    // Jackknife: leave one block out.
    const double k = static_cast<double>(block.size());
    double js = 0, js2 = 0, jt = 0, jt2 = 0;
    for (const BlockSums& b : block) {
        BlockSums rest = all;
        rest.n -= b.n;
        rest.t -= b.t;
        rest.t2 -= b.t2;
        rest.d -= b.d;
        rest.d2 -= b.d2;
        const Moments mj = moments_of(rest);
        js += mj.sigma_d;
        js2 += mj.sigma_d * mj.sigma_d;
        jt += mj.rel_sigma_t;
        jt2 += mj.rel_sigma_t * mj.rel_sigma_t;
    }
    const auto jk_se = [&](double s, double s2) {
        const double mean = s / k;
        return std::sqrt(std::max(0.0, (k - 1.0) * (s2 / k - mean * mean)));
    };
    out.sigma_density_se                = jk_se(js, js2);
    out.relative_sigma_transmittance_se = jk_se(jt, jt2);
    return out;
}

}  // namespace filmgrain::sensitometry
