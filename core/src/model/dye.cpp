// MODEL.md section 8: dye layers.
#include "model/dye.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <mutex>

#include "util/bucket.h"

namespace filmgrain {

namespace {

/// Ein(k) = integral_0^k (1 - e^-t) / t dt = gamma + ln k + E1(k), with
/// E1(k) = -Ei(-k) (std::expint is Ei); the series k - k^2/4 below 1e-6.
double ein(double k)
{
    if (k < 1e-6)
        return k - 0.25 * k * k;
    constexpr double kEulerGamma = 0.57721566490153286;
    return kEulerGamma + std::log(k) - std::expint(-k);
}

constexpr double kFixedPoint = 4294967296.0;  // 2^32 per density unit
constexpr double kLn10       = 2.302585092994046;

/// The clouds over a stretch of a row, for MODEL.md 8's sum: a whole
/// number of clouds, `count`; 10^-min(count c, max_density) looked up in
/// the scratch's levels (disc_rows clears them once per call).
class CloudCount {
public:
    CloudCount(const Layer& layer, double max_density, DyeScratch& scratch)
        : m_level(scratch.level), m_density(layer.cloud_density), m_max_density(max_density)
    {
    }
    /// A cloud of population `pop` enters the stretch (`step` +1) or leaves
    /// it (-1).
    void step(int step, uint8_t /*pop*/) { m_count += step; }
    double transmittance()
    {
        while (static_cast<int>(m_level.size()) <= m_count)
            m_level.push_back(std::exp(-kLn10 * std::min(static_cast<double>(m_level.size())
                                                             * m_density,
                                                         m_max_density)));
        return m_level[static_cast<size_t>(m_count)];
    }

private:
    std::vector<double>& m_level;  // 10^-min(k c, max) for k clouds
    double m_density, m_max_density;
    int m_count = 0;
};

/// The clouds over a stretch of a row when populations are coupler-limited
/// (FilledImage): each such population counts max_dye_density if any of its
/// clouds is there, the others cloud_density per cloud.
class LimitedCloudCount {
public:
    LimitedCloudCount(const Layer& layer, double max_density, DyeScratch& scratch)
        : m_layer(layer), m_max_density(max_density), m_memo(scratch.memo)
    {
    }
    void step(int step, uint8_t pop)
    {
        m_count[pop] += step;
        m_stale = true;
    }
    double transmittance()
    {
        if (m_stale) {
            // What the density depends on (each limited population's
            // presence, the others' counts), 15 bits a population, keys a
            // cache of the transmittances already computed (the same
            // value, without the exponential). The top bit marks a key (an
            // empty slot holds 0).
            const size_t np = m_layer.populations.size();
            uint64_t key    = uint64_t { 1 } << 63;
            bool keyed      = np <= 4;
            for (size_t p = 0; p < np && keyed; ++p) {
                const int c = m_layer.populations[p].max_dye_density > 0.0 ? (m_count[p] > 0)
                                                                            : m_count[p];
                keyed = c >= 0 && c < 0x7fff;
                key |= static_cast<uint64_t>(c) << (15 * p);
            }
            std::pair<uint64_t, double>* slot = nullptr;
            if (keyed) {
                slot = &m_memo[(key * 0x9e3779b97f4a7c15ULL) >> (64 - kMemoBits)];
                if (slot->first == key) {
                    m_t     = slot->second;
                    m_stale = false;
                    return m_t;
                }
            }
            double d = 0.0;
            for (size_t p = 0; p < np; ++p) {
                const double limit = m_layer.populations[p].max_dye_density;
                if (limit > 0.0)
                    d += m_count[p] > 0 ? limit : 0.0;
                else
                    d += m_count[p] * m_layer.cloud_density;
            }
            m_t     = std::exp(-kLn10 * std::min(d, m_max_density));
            m_stale = false;
            if (slot)
                *slot = { key, m_t };
        }
        return m_t;
    }

    /// Slots of the cache (2^kMemoBits), emptied for each block.
    static constexpr int kMemoBits = 10;
    static void clear_memo(DyeScratch& scratch)
    {
        scratch.memo.assign(size_t { 1 } << kMemoBits, { 0, 0.0 });
    }

private:
    const Layer& m_layer;
    double m_max_density;
    std::vector<std::pair<uint64_t, double>>& m_memo;
    std::array<int, 256> m_count {};  // per population (uint8_t indices)
    double m_t   = 1.0;
    bool m_stale = true;
};

/// Sorts a sequence that is nearly in order (each element a few places
/// from its own): insertion, O(n + inversions).
void sort_nearly_sorted(std::vector<std::pair<double, int>>& v)
{
    for (size_t i = 1; i < v.size(); ++i) {
        if (!(v[i] < v[i - 1]))
            continue;
        const std::pair<double, int> x = v[i];
        size_t j = i;
        do {
            v[j] = v[j - 1];
            --j;
        } while (j > 0 && x < v[j - 1]);
        v[j] = x;
    }
}

/// Disc clouds: along each of `samples` rows per pixel row, D(x) is a
/// whole number of clouds times cloud_density (or, Counter
/// LimitedCloudCount, a sum of such levels), constant between the clouds'
/// chord ends, so 10^-D is integrated exactly along the row (a sweep over
/// the sorted chord ends, cut at the pixel edges); only the integral across
/// rows is sampled (the midpoint rule). Every piece a pixel sums lies
/// between chord ends inside it or its own edges, in order: the same in
/// every block. `population`: each grain's (read by LimitedCloudCount).
template<typename Counter>
void disc_rows(const std::vector<Disc>& grains, const uint8_t* population, const Layer& layer,
               double max_density, int64_t x0, int64_t y0, int64_t x1, int64_t y1,
               double px_um, double py_um, int samples, DyeScratch& scratch,
               double* transmittance)
{
    const int64_t tw = x1 - x0;
    const int64_t s  = samples;
    const double sy  = py_um / static_cast<double>(s);
    const double left = static_cast<double>(x0) * px_um, right = static_cast<double>(x1) * px_um;
    // A chord end: where, and a code: +(1 + 2 p) where a cloud of
    // population p enters, -(1 + 2 p) where it leaves (p = 0 without
    // `population`: the codes +-1 of a plain count).
    std::vector<std::pair<double, int>>& enters = scratch.enters;
    std::vector<std::pair<double, int>>& leaves = scratch.leaves;
    std::vector<size_t>& by_x = scratch.by_x;
    std::vector<std::vector<size_t>>& crossing = scratch.crossing;
    const auto pop_of = [&](size_t grain) -> uint8_t { return population ? population[grain] : 0; };
    scratch.level.clear();
    std::vector<double> sum(static_cast<size_t>(tw));
    for (int64_t row = y0; row < y1; ++row) {
        std::fill(sum.begin(), sum.end(), 0.0);
        const size_t b = scratch.offsets[static_cast<size_t>(row - y0)];
        const size_t e = scratch.offsets[static_cast<size_t>(row - y0 + 1)];
        // The row's clouds by centre: along each sample row their chord
        // ends are then nearly in order (an end lies within a cloud radius
        // of its centre), sorted by insertion and merged. The result is the
        // sorted sequence of ends, whatever sort makes it.
        by_x.assign(scratch.members.begin() + static_cast<std::ptrdiff_t>(b),
                    scratch.members.begin() + static_cast<std::ptrdiff_t>(e));
        std::sort(by_x.begin(), by_x.end(), [&](size_t p, size_t q) {
            return grains[p].x_um < grains[q].x_um || (grains[p].x_um == grains[q].x_um && p < q);
        });
        // The sample rows each cloud crosses (|y - y_c| < r_c), found from
        // its extent (a row more each way, then the exact test): each row
        // then reads only its own clouds, still by centre.
        const auto sample_y = [&](int64_t j) {
            return (static_cast<double>(row * s + j) + 0.5) * sy;
        };
        crossing.resize(static_cast<size_t>(s));
        for (std::vector<size_t>& c : crossing)
            c.clear();
        const double first = static_cast<double>(row * s);
        for (const size_t gi : by_x) {
            const Disc& g   = grains[gi];
            const double rc = layer.cloud_diameter_ratio * g.r_um;
            const double lo = std::floor((g.y_um - rc) / sy - 0.5 - first) - 1.0;
            const double hi = std::ceil((g.y_um + rc) / sy - 0.5 - first) + 1.0;
            const int64_t j1 = static_cast<int64_t>(std::min(hi, static_cast<double>(s - 1)));
            for (int64_t j = static_cast<int64_t>(std::max(lo, 0.0)); j <= j1; ++j)
                if (std::fabs(sample_y(j) - g.y_um) < rc)
                    crossing[static_cast<size_t>(j)].push_back(gi);
        }
        for (int64_t j = 0; j < s; ++j) {
            const double y = sample_y(j);
            const std::vector<size_t>& clouds = crossing[static_cast<size_t>(j)];
            // Room for every cloud's ends, written through pointers (no
            // size kept in memory per end), then cut to what was written.
            enters.resize(clouds.size());
            leaves.resize(clouds.size());
            std::pair<double, int>* enter = enters.data();
            std::pair<double, int>* leave = leaves.data();
            Counter count(layer, max_density, scratch);  // clouds covering the block's left edge
            for (const size_t gi : clouds) {
                const Disc& g   = grains[gi];
                const double rc = layer.cloud_diameter_ratio * g.r_um;
                const double dy = y - g.y_um;
                const double half = std::sqrt(rc * rc - dy * dy);
                const double a = g.x_um - half, c = g.x_um + half;
                if (c <= left || a >= right)
                    continue;
                const int tag = population ? 2 * static_cast<int>(pop_of(gi)) : 0;
                if (a <= left)
                    count.step(+1, pop_of(gi));
                else
                    *enter++ = { a, +1 + tag };
                if (c < right)
                    *leave++ = { c, -1 - tag };
            }
            enters.resize(static_cast<size_t>(enter - enters.data()));
            leaves.resize(static_cast<size_t>(leave - leaves.data()));
            sort_nearly_sorted(enters);
            sort_nearly_sorted(leaves);
            // The two sorted sequences merged as the sweep reads them (as
            // std::merge orders them: a leave before an enter only if it
            // compares less), then the row's right end (code 0).
            const std::pair<double, int>* en = enters.data();
            const std::pair<double, int>* const en_end = en + enters.size();
            const std::pair<double, int>* le = leaves.data();
            const std::pair<double, int>* const le_end = le + leaves.size();
            const std::pair<double, int> row_end { right, 0 };
            double x   = left;
            int64_t ix = x0;  // the pixel holding x
            for (;;) {
                const std::pair<double, int>& next
                    = le != le_end && (en == en_end || *le < *en) ? *le++
                      : en != en_end                            ? *en++
                                                                : row_end;
                const auto& [at, code] = next;
                // [x, at) has the clouds `count` holds: cut it at the pixel edges.
                const double t = count.transmittance();
                while (x < at) {
                    const double edge = static_cast<double>(ix + 1) * px_um;
                    const double to   = std::min(at, edge);
                    sum[static_cast<size_t>(ix - x0)] += t * (to - x);
                    x = to;
                    if (to == edge && ix + 1 < x1)
                        ++ix;
                    else if (to == edge)
                        break;
                }
                x = std::max(x, at);
                if (code == 0)
                    break;
                count.step(code > 0 ? +1 : -1, static_cast<uint8_t>((std::abs(code) - 1) / 2));
            }
        }
        for (int64_t ix = 0; ix < tw; ++ix)
            transmittance[static_cast<size_t>((row - y0) * tw + ix)]
                = sum[static_cast<size_t>(ix)] / (px_um * static_cast<double>(s));
    }
}

}  // namespace

double image_reach_factor(const Layer& layer)
{
    if (layer.image == LayerImage::silver)
        return 1.0;
    return layer.cloud_diameter_ratio
           * (layer.cloud_profile == CloudProfile::gaussian ? kGaussianCloudReach : 1.0);
}

double cloud_area_factor(const Layer& layer)
{
    if (layer.image == LayerImage::silver)
        return 1.0;
    const double r2 = layer.cloud_diameter_ratio * layer.cloud_diameter_ratio;
    if (layer.cloud_profile == CloudProfile::disc)
        return r2 * -std::expm1(-layer.cloud_density * kLn10);
    return r2 * 0.5 * ein(layer.cloud_density * kLn10);
}

FilledImage filled_image(double cloud_diameter_ratio, const Population& pop)
{
    FilledImage f;
    f.area_ratio = cloud_diameter_ratio * cloud_diameter_ratio;
    if (pop.coupler_limited())
        f.opacity = -std::expm1(-pop.max_dye_density * kLn10);
    return f;
}

bool has_coupler_limit(const Layer& layer)
{
    return std::any_of(layer.populations.begin(), layer.populations.end(),
                       [](const Population& p) { return p.coupler_limited(); });
}

double layer_mean_transmittance(const Layer& layer, const std::vector<double>& cover)
{
    double added = 0.0, filled = 1.0;
    for (size_t p = 0; p < layer.populations.size(); ++p) {
        if (!layer.populations[p].coupler_limited()) {
            added += cover[p];
            continue;
        }
        const FilledImage f = filled_image(layer.cloud_diameter_ratio, layer.populations[p]);
        filled *= f.mean(f.area_ratio * cover[p]);
    }
    return std::exp(-cloud_area_factor(layer) * added) * filled;
}

namespace {

/// Grid steps per cloud radius of the gaussian overlap table.
constexpr int kGaussianOverlapSteps = 32;

/// k(R = 1, h) of gaussian clouds of peak density `density` at h = i /
/// kGaussianOverlapSteps, i = 0 .. 2 kGaussianCloudReach steps: the sum of
/// f(p) f(p + h) over a square grid of that step (the trapezoid rule: f
/// is smooth and, with the cut, 0 at the grid's edge), f = 1 - 10^-D_1.
std::vector<double> gaussian_overlap_table(double density)
{
    constexpr int kSide = static_cast<int>(kGaussianCloudReach) * kGaussianOverlapSteps;
    constexpr int kN    = 2 * kSide + 1;  // grid points per axis over [-3, 3]
    constexpr double kStep = 1.0 / kGaussianOverlapSteps;
    std::vector<double> f(static_cast<size_t>(kN * kN));
    for (int j = 0; j < kN; ++j)
        for (int i = 0; i < kN; ++i) {
            const double tx = (i - kSide) * kStep, ty = (j - kSide) * kStep;
            const double t2 = tx * tx + ty * ty;
            f[static_cast<size_t>(j * kN + i)]
                = t2 >= kGaussianCloudReach * kGaussianCloudReach
                      ? 0.0
                      : -std::expm1(-kLn10 * density * std::exp(-2.0 * t2));
        }
    std::vector<double> k(static_cast<size_t>(2 * kSide + 2), 0.0);
    for (int s = 0; s <= 2 * kSide; ++s) {
        double sum = 0.0;
        for (int j = 0; j < kN; ++j) {
            const double* row = &f[static_cast<size_t>(j * kN)];
            for (int i = 0; i + s < kN; ++i)
                sum += row[i] * row[i + s];
        }
        k[static_cast<size_t>(s)] = sum * kStep * kStep;
    }
    return k;  // the last entry stays 0: beyond the reach
}

/// One table per cloud density, made once per process.
std::shared_ptr<const std::vector<double>> shared_gaussian_overlap(double density)
{
    static std::mutex mutex;
    static std::map<double, std::shared_ptr<const std::vector<double>>> tables;
    const std::lock_guard<std::mutex> lock(mutex);
    auto& t = tables[density];
    if (!t)
        t = std::make_shared<const std::vector<double>>(gaussian_overlap_table(density));
    return t;
}

}  // namespace

ImageOverlap::ImageOverlap(const Layer& layer)
    : m_image(layer.image),
      m_profile(layer.cloud_profile),
      m_ratio(layer.image == LayerImage::dye ? layer.cloud_diameter_ratio : 1.0),
      m_area_factor(cloud_area_factor(layer))
{
    if (m_image == LayerImage::dye) {
        const double block = -std::expm1(-layer.cloud_density * kLn10);
        m_disc_factor      = block * block;
        if (m_profile == CloudProfile::gaussian) {
            m_gaussian = shared_gaussian_overlap(layer.cloud_density);
            const std::vector<double>& k = *m_gaussian;
            size_t i = k.size() - 1;  // the first node from which k stays below 1e-3 k(0)
            while (i > 0 && k[i - 1] < 1e-3 * k[0])
                --i;
            m_gaussian_correlation_radii = static_cast<double>(i) / kGaussianOverlapSteps;
        }
    }
}

double ImageOverlap::blocking_um2(double r_um) const
{
    return M_PI * r_um * r_um * m_area_factor;
}

FilledImage ImageOverlap::filled(const Population& pop) const
{
    return filled_image(m_ratio, pop);
}

double ImageOverlap::cloud_lens_um2(double r_um, double h_um) const
{
    return lens_area_um2(m_ratio * r_um, h_um);
}

double ImageOverlap::overlap_um2(double r_um, double h_um) const
{
    const double rc_um = m_ratio * r_um;
    if (m_image == LayerImage::silver)
        return lens_area_um2(r_um, h_um);
    if (m_profile == CloudProfile::disc)
        return m_disc_factor * lens_area_um2(rc_um, h_um);
    const std::vector<double>& k = *m_gaussian;
    const double x = std::fabs(h_um) / rc_um * kGaussianOverlapSteps;
    const size_t i = static_cast<size_t>(x);
    if (!(x < static_cast<double>(k.size() - 1)))
        return 0.0;
    const double f = x - static_cast<double>(i);
    return rc_um * rc_um * (k[i] * (1.0 - f) + k[i + 1] * f);
}

double ImageOverlap::correlation_range_um(double r_um) const
{
    if (m_image == LayerImage::dye && m_profile == CloudProfile::gaussian)
        return m_gaussian_correlation_radii * m_ratio * r_um;
    return overlap_range_um(r_um);
}

double ImageOverlap::overlap_range_um(double r_um) const
{
    if (m_image == LayerImage::silver)
        return 2.0 * r_um;
    const double rc_um = m_ratio * r_um;
    return m_profile == CloudProfile::disc ? 2.0 * rc_um : 2.0 * kGaussianCloudReach * rc_um;
}

void dye_transmittance(const std::vector<Disc>& grains, const std::vector<size_t>& population_end,
                       const Layer& layer, double max_density, int64_t x0, int64_t y0,
                       int64_t x1, int64_t y1, double px_um, double py_um, int samples,
                       DyeScratch& scratch, double* transmittance)
{
    const int64_t tw = x1 - x0, th = y1 - y0;
    const int64_t s  = samples;
    const bool gaussian = layer.cloud_profile == CloudProfile::gaussian;
    const double reach  = image_reach_factor(layer);
    const double peak   = layer.cloud_density;

    // Bucket the clouds by the pixel rows they reach (counting sort; the
    // buckets' rows are r - y0).
    std::vector<size_t>& offsets = scratch.offsets;
    std::vector<size_t>& members = scratch.members;
    const auto rows = [&](size_t i, int64_t& r0, int64_t& r1) {
        const Disc& g       = grains[i];
        const double extent = reach * g.r_um;
        r0 = std::max<int64_t>(y0, static_cast<int64_t>(std::floor((g.y_um - extent) / py_um)))
             - y0;
        r1 = std::min<int64_t>(y1 - 1, static_cast<int64_t>(std::floor((g.y_um + extent) / py_um)))
             - y0;
    };
    bucket_by_row(grains.size(), th, rows, [](size_t i, int64_t) { return i; }, offsets,
                  scratch.fill, members);

    if (!gaussian) {
        if (!has_coupler_limit(layer)) {
            disc_rows<CloudCount>(grains, nullptr, layer, max_density, x0, y0, x1, y1, px_um,
                                  py_um, samples, scratch, transmittance);
            return;
        }
        std::vector<uint8_t>& population = scratch.population;
        population.resize(grains.size());
        size_t begin = 0;
        for (size_t p = 0; p < population_end.size(); ++p) {
            std::fill(population.begin() + static_cast<std::ptrdiff_t>(begin),
                      population.begin() + static_cast<std::ptrdiff_t>(population_end[p]),
                      static_cast<uint8_t>(p));
            begin = population_end[p];
        }
        LimitedCloudCount::clear_memo(scratch);
        disc_rows<LimitedCloudCount>(grains, population.data(), layer, max_density, x0, y0, x1,
                                     y1, px_um, py_um, samples, scratch, transmittance);
        return;
    }

    // Gaussian clouds, per pixel row: the density at its s x (tw s) sample
    // points, then the mean of 10^-D per pixel.
    const int64_t width = tw * s;
    std::vector<int64_t>& density = scratch.density;
    density.resize(static_cast<size_t>(width * s));
    const double sx = px_um / static_cast<double>(s), sy = py_um / static_cast<double>(s);
    // Sample columns by absolute index (x0 s + i), so that every block
    // computes a sample's position, and so its sum, the same way.
    const int64_t first = x0 * s;
    for (int64_t row = y0; row < y1; ++row) {
        std::fill(density.begin(), density.end(), 0);
        const size_t b = offsets[static_cast<size_t>(row - y0)];
        const size_t e = offsets[static_cast<size_t>(row - y0 + 1)];
        for (size_t m = b; m < e; ++m) {
            const Disc& g        = grains[members[m]];
            const double rc      = layer.cloud_diameter_ratio * g.r_um;
            const double extent  = reach * g.r_um;
            const double inv_rc2 = 1.0 / (rc * rc);
            // The profile is separable: peak exp(-2 dx^2 / rc^2) times
            // exp(-2 dy^2 / rc^2), each factor computed once per column and
            // per row of the cloud (the same in every block: both depend on
            // the absolute sample index only).
            const int64_t c0 = std::max<int64_t>(
                0, static_cast<int64_t>(std::ceil((g.x_um - extent) / sx - 0.5)) - first);
            const int64_t c1 = std::min<int64_t>(
                width - 1, static_cast<int64_t>(std::floor((g.x_um + extent) / sx - 0.5)) - first);
            if (c0 > c1)
                continue;
            std::vector<double>& ex = scratch.factor;
            ex.resize(static_cast<size_t>(c1 - c0 + 1));
            for (int64_t i = c0; i <= c1; ++i) {
                const double dx = (static_cast<double>(first + i) + 0.5) * sx - g.x_um;
                ex[static_cast<size_t>(i - c0)] = peak * kFixedPoint * std::exp(-2.0 * dx * dx * inv_rc2);
            }
            for (int64_t j = 0; j < s; ++j) {
                const double y  = (static_cast<double>(row * s + j) + 0.5) * sy;
                const double dy = y - g.y_um;
                if (std::fabs(dy) >= extent)
                    continue;
                const double half = std::sqrt(extent * extent - dy * dy);
                const double ey   = std::exp(-2.0 * dy * dy * inv_rc2);
                // Sample columns a (absolute) with centre (a + 0.5) sx in
                // [g.x - half, g.x + half].
                const int64_t i0 = std::max<int64_t>(
                    c0, static_cast<int64_t>(std::ceil((g.x_um - half) / sx - 0.5)) - first);
                const int64_t i1 = std::min<int64_t>(
                    c1, static_cast<int64_t>(std::floor((g.x_um + half) / sx - 0.5)) - first);
                int64_t* d = density.data() + j * width;
                for (int64_t i = i0; i <= i1; ++i)
                    d[i] += static_cast<int64_t>(ex[static_cast<size_t>(i - c0)] * ey + 0.5);
            }
        }
        for (int64_t ix = 0; ix < tw; ++ix) {
            double sum = 0.0;
            for (int64_t j = 0; j < s; ++j)
                for (int64_t i = ix * s; i < (ix + 1) * s; ++i) {
                    const int64_t di = density[static_cast<size_t>(j * width + i)];
                    if (di == 0) {  // no cloud here
                        sum += 1.0;
                        continue;
                    }
                    const double dd = std::min(static_cast<double>(di) / kFixedPoint, max_density);
                    sum += std::exp(-kLn10 * dd);
                }
            transmittance[static_cast<size_t>((row - y0) * tw + ix)]
                = sum / static_cast<double>(s * s);
        }
    }
}

}  // namespace filmgrain
