// Tests of the pixel-scale model against Monte Carlo renders of the
// Boolean model it summarises: developed discs drawn grain by grain (the
// fast kernel's grains and curve), exact pixel coverage, and the pixel
// transmittances' mean, variance and neighbour correlation compared with
// PixelModel's, tolerances from the sampling variance.
#include "kernels/pixel_model.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "model/dye.h"
#include "kernels/grain_kernel.h"
#include "model/image_formation.h"
#include "kernels/coverage_grid.h"
#include "util/rng.h"
#include "util/sampling.h"
#include "testing/test_tables.h"
#include "testing/test_layers.h"

namespace filmgrain {
namespace {

struct Sample {
    double mean = 0.0, var = 0.0;
    /// Correlation at lags (1, 0), (2, 0), (1, 1) (x and y pooled).
    double rho_x = 0.0, rho_2x = 0.0, rho_xy = 0.0;
    double se_mean = 0.0, se_var = 0.0, se_rho = 0.0;
};

/// The correlation of a square field (n x n, row-major) at lags (1, 0),
/// (2, 0) and (1, 1), pooled over the axes (and both diagonals), from its
/// mean and variance.
struct LagSums {
    double s10 = 0.0, s20 = 0.0, s11 = 0.0;
    int n10 = 0, n20 = 0, n11 = 0;
    void add(const std::vector<double>& t, int n)
    {
        const auto at = [&](int x, int y) { return t[static_cast<size_t>(y * n + x)]; };
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
                if (x + 1 < n) {
                    s10 += at(x, y) * at(x + 1, y) + at(y, x) * at(y, x + 1);
                    n10 += 2;
                }
                if (x + 2 < n) {
                    s20 += at(x, y) * at(x + 2, y) + at(y, x) * at(y, x + 2);
                    n20 += 2;
                }
                if (x + 1 < n && y + 1 < n) {
                    s11 += at(x, y) * at(x + 1, y + 1) + at(x + 1, y) * at(x, y + 1);
                    n11 += 2;
                }
            }
    }
    void correlations(double mean, double var, double& r10, double& r20, double& r11) const
    {
        r10 = (s10 / n10 - mean * mean) / var;
        r20 = (s20 / n20 - mean * mean) / var;
        r11 = (s11 / n11 - mean * mean) / var;
    }
};

/// Pixel transmittances of several 48x48 blocks of 4 um pixels, grain by
/// grain: exact coverage of silver discs, or (`dye`) the dye image of
/// MODEL.md 8 at 32 samples per pixel and axis.
/// Of every population of `pps` (a layer's, in order: population p's
/// grains seeded 100 + block with population index p).
Sample monte_carlo(const std::vector<PixelPopulation>& pps, double v, const Layer* dye = nullptr,
                   double factor = 1.0, int dye_samples = 32,
                   std::vector<double>* values = nullptr)
{
    constexpr int kBlocks = 12, kN = 48;
    constexpr double kPitch = 4.0;
    std::vector<double> t_all;
    LagSums lags;
    std::vector<double> means;
    for (int b = 0; b < kBlocks; ++b) {
        std::vector<Disc> discs;
        std::vector<size_t> population_end;
        for (size_t p = 0; p < pps.size(); ++p) {
            const PixelPopulation& pp = pps[p];
            const PopulationGrains grains(*pp.population, 100 + b, 0, static_cast<uint32_t>(p));
            const FastGrains fast(grains);
            const RectUm rect { 0.0, 0.0, kN * kPitch, kN * kPitch };
            // Grains whose image may reach the block (clouds: to their reach).
            const double margin
                = dye ? image_reach_factor(*dye) * grains.radius_at_z_um(9.0) : 0.0;
            const RectUm near { -margin, -margin, kN * kPitch + margin, kN * kPitch + margin };
            fast.for_each_grain_near(
                near, [&](double x, double y, double r, uint32_t bits, uint64_t) {
                    const Disc d { x, y, dye ? r * image_reach_factor(*dye) : r };
                    if (!disc_touches_rect(d, rect.x0_um, rect.y0_um, rect.x1_um, rect.y1_um))
                        return;
                    const double u = uniform_from_bits(bits);
                    if (u >= 1.0 - factor * pixel_develop_probability(
                                       pp, pp.photons_per_value_um2 * v * M_PI * r * r))
                        discs.push_back({ x, y, r });
                });
            population_end.push_back(discs.size());
        }
        std::vector<double> f(kN * kN);
        if (dye) {
            DyeScratch scratch;
            dye_transmittance(discs, population_end, *dye, 20.0, 0, 0, kN, kN, kPitch, kPitch,
                              dye_samples, scratch, f.data());
            for (double& c : f)
                c = 1.0 - c;  // as a covered fraction, like grid_coverage's
        } else {
            GridCoverageScratch scratch;
            grid_coverage(discs, 0, 0, kN, kN, kPitch, kPitch, scratch, f.data());
        }
        double m = 0.0;
        for (double& c : f) {
            c = 1.0 - c;  // transmittance
            t_all.push_back(c);
            m += c;
        }
        means.push_back(m / (kN * kN));
        lags.add(f, kN);
    }
    Sample s;
    const double n = static_cast<double>(t_all.size());
    for (double t : t_all)
        s.mean += t / n;
    for (double t : t_all)
        s.var += (t - s.mean) * (t - s.mean) / (n - 1);
    lags.correlations(s.mean, s.var, s.rho_x, s.rho_2x, s.rho_xy);
    // Standard errors: the mean from the spread of the block means (blocks
    // are independent); the variance and the correlation as for n / 2
    // independent pixels (neighbour correlation is small here, checked
    // below), which overstates the precision by little.
    double vb = 0.0, mb = 0.0;
    for (double m : means)
        mb += m / kBlocks;
    for (double m : means)
        vb += (m - mb) * (m - mb) / (kBlocks - 1);
    s.se_mean = std::sqrt(vb / kBlocks);
    s.se_var  = s.var * std::sqrt(2.0 / (n / 2));
    s.se_rho  = 1.0 / std::sqrt(n / 2);
    if (values)
        *values = std::move(t_all);
    return s;
}

Sample monte_carlo(const PixelPopulation& pp, double v, const Layer* dye = nullptr,
                   double factor = 1.0, int dye_samples = 32)
{
    return monte_carlo(std::vector<PixelPopulation> { pp }, v, dye, factor, dye_samples);
}

/// The test layer of the tests below: one population of 0.8 um grains at
/// 1.5 per um^2, about 20 photons per mean grain at v = 1, the small
/// development table.
struct TestLayer {
    DevelopTable table = small_develop_table();
    DevelopCurve curve { table };
    Population pop = [] {
        Population p;
        p.grains_per_um2     = 1.5;
        p.diameter_um        = 0.8;
        p.diameter_log_sigma = 0.3;
        return p;
    }();
    PopulationGrains grains { pop, 1, 0, 0 };
    std::vector<PixelPopulation> pops { { &pop, &grains, 40.0, &curve, &table } };
};

/// The test layer's population and a fine one (4 per um^2, 0.4 um) in one
/// dye layer of disc clouds 1.5 times the grain, density 0.7, the first
/// population coupler-limited at 0.45 (dye.h FilledImage).
struct CouplerLimitedLayer {
    TestLayer t;
    Population fine = [this] {
        Population p     = t.pop;
        p.grains_per_um2 = 4.0;
        p.diameter_um    = 0.4;
        return p;
    }();
    PopulationGrains fine_grains { fine, 1, 0, 1 };
    Layer layer = [this] {
        Layer l;
        make_dye(l, CloudProfile::disc, 1.5, 0.7);
        l.populations                    = { t.pop, fine };
        l.populations[0].max_dye_density = 0.45;
        return l;
    }();
    /// The pixel populations of `l` (this layer or a variant of it).
    std::vector<PixelPopulation> pops_of(const Layer& l) const
    {
        return { { &l.populations[0], &t.grains, 40.0, &t.curve, &t.table },
                 { &l.populations[1], &fine_grains, 40.0, &t.curve, &t.table } };
    }
};

/// The model's mean, variance and neighbour correlation against a Monte
/// Carlo sample, within 5 of its standard errors.
void expect_moments(const Sample& s, const PixelModel::Moments& m, const std::string& what)
{
    EXPECT_NEAR(s.mean, m.mean, 5 * s.se_mean + 1e-4) << what;
    EXPECT_NEAR(s.var, m.variance, 5 * s.se_var) << what;
    EXPECT_NEAR(s.rho_x, m.correlation[1], 5 * s.se_rho) << what;
    EXPECT_NEAR(s.rho_2x, m.correlation[2], 5 * s.se_rho) << what;
    EXPECT_NEAR(s.rho_xy, m.correlation[kLagSide + 1], 5 * s.se_rho) << what;
}

TEST(PixelModel, MomentsMatchTheBooleanModelGrainByGrain)
{
    const TestLayer t;
    const std::vector<PixelPopulation>& pops = t.pops;
    for (double v : { 0.05, 0.4, 1.0 }) {
        const PixelModel::Moments m = PixelModel::compute(pops, 4.0, 4.0, v);
        expect_moments(monte_carlo(pops[0], v), m, "v " + std::to_string(v));
        EXPECT_LT(m.correlation[1], 0.3);  // the n / 2 effective pixels above
        // The table interpolates the direct computation closely.
        const PixelModel table_model(pops, 4.0, 4.0);
        EXPECT_NEAR(table_model.at(v).mean, m.mean, 1e-3 * m.mean);
    }
}

// The same for dye clouds (MODEL.md 8): the pixel statistics take each
// grain's blocking area and overlap from ImageOverlap (disc and gaussian
// clouds larger and smaller than the grain), against dye images rendered
// grain by grain at 32 samples per pixel and axis (the sampling's own
// per-pixel noise, measured in Dye.SamplingConverges, is far below the
// grain noise here).
TEST(PixelModel, DyeMomentsMatchTheCloudsGrainByGrain)
{
    const TestLayer t;
    const std::vector<PixelPopulation>& pops = t.pops;
    for (const CloudProfile profile : { CloudProfile::disc, CloudProfile::gaussian }) {
        Layer layer;
        make_dye(layer, profile, profile == CloudProfile::disc ? 1.5 : 0.9, 0.7);
        const ImageOverlap image(layer);
        for (double v : { 0.4, 1.0 }) {
            const PixelModel::Moments m = PixelModel::compute(pops, 4.0, 4.0, v, image);
            const Sample s = monte_carlo(pops[0], v, &layer);
            const std::string what = std::string(name_of(profile)) + " v "
                                     + std::to_string(v);
            expect_moments(s, m, what);
            // Not the silver statistics of the same grains (the clouds
            // block 1.8 and 0.66 times a disc's light).
            const PixelModel::Moments silver = PixelModel::compute(pops, 4.0, 4.0, v);
            EXPECT_GT(std::fabs(silver.mean - m.mean), 5 * s.se_mean) << what;
        }
    }
}

// Coupler-limited populations (dye.h FilledImage): a layer of one whose
// clouds fill (density max_dye_density wherever one lies) and one whose
// clouds add, against the same grains rendered grain by grain (disc clouds
// exact along rows: dye_transmittance's LimitedCloudCount), from thin to
// dense (v = 6: nearly every grain developed, the limited population's
// clouds over about four fifths of the plane: m ~ 1.5 per um^2 x E[pi
// (0.75 d)^2] = 1.24 um^2). Tolerances: expect_moments's, from the
// sampling variance.
TEST(PixelModel, CouplerLimitedMomentsMatchTheCloudsGrainByGrain)
{
    const CouplerLimitedLayer c;
    const Layer& layer                       = c.layer;
    const std::vector<PixelPopulation> pops = c.pops_of(layer);
    const ImageOverlap image(layer);
    Layer added = layer;  // the same clouds, all adding
    added.populations[0].max_dye_density = 0.0;
    for (double v : { 0.4, 1.5, 6.0 }) {
        const PixelModel::Moments m = PixelModel::compute(pops, 4.0, 4.0, v, image);
        const Sample s              = monte_carlo(pops, v, &layer);
        expect_moments(s, m, "coupler-limited v " + std::to_string(v));
        // The mean is layer_mean_transmittance's.
        EXPECT_NEAR(m.mean, layer_mean_transmittance(layer, population_covers(pops, v)),
                    1e-12);
        // Not the statistics of the same clouds adding.
        const std::vector<PixelPopulation> added_pops = c.pops_of(added);
        const PixelModel::Moments a
            = PixelModel::compute(added_pops, 4.0, 4.0, v, ImageOverlap(added));
        EXPECT_GT(std::fabs(a.mean - m.mean), 5 * s.se_mean) << v;
    }
}

// MODEL.md 10 at pixel scale: an inhibited layer's moments are those of
// every P thinned by exp(-L), against grains developed with the thinned P;
// the table's second axis interpolates them.
TEST(PixelModel, InhibitedMomentsAreThinnedOnes)
{
    const TestLayer t;
    const std::vector<PixelPopulation>& pops = t.pops;
    const PixelModel table_model(pops, 4.0, 4.0, ImageOverlap(), 1.0);
    for (double l : { 0.3, 0.77 }) {
        const double v              = 1.0;
        const PixelModel::Moments m = PixelModel::compute(pops, 4.0, 4.0, v, ImageOverlap(), l);
        const Sample s              = monte_carlo(pops[0], v, nullptr, std::exp(-l));
        expect_moments(s, m, "L " + std::to_string(l));
        // Between log-factor nodes (0.05 apart) and exposure nodes.
        EXPECT_NEAR(table_model.at(v, l).mean, m.mean, 1e-3 * m.mean) << "L " << l;
        EXPECT_NEAR(table_model.at(v, l).variance, m.variance, 2e-3 * m.variance) << "L " << l;
        // Thinner than the uninhibited layer, beyond the noise.
        EXPECT_GT(m.mean - PixelModel::compute(pops, 4.0, 4.0, v).mean, 5 * s.se_mean);
    }
    EXPECT_LT(table_model.max_mean_error(), 1e-3);
}

// The table's interpolation errors count where the density clamp lets the
// mean through (MODEL.md 5: -log10 T at most max_density): the table is
// the same whatever the clamp; a clamp at 0 (floor 1) hides every error; a
// clamp at density 1 hides the errors of the darker nodes only.
TEST(PixelModel, InterpolationErrorsCountAboveTheDensityClamp)
{
    const TestLayer t;
    const PixelModel plain(t.pops, 4.0, 4.0, ImageOverlap(), 1.0, 1);
    const PixelModel at_one(t.pops, 4.0, 4.0, ImageOverlap(), 1.0, 1, 1.0);
    const PixelModel at_zero(t.pops, 4.0, 4.0, ImageOverlap(), 1.0, 1, 0.0);
    for (double v : { 0.0, 0.01, 0.3, 1.0, 7.0 })
        EXPECT_EQ(plain.at(v, 0.4).mean, at_one.at(v, 0.4).mean) << v;
    EXPECT_GT(plain.max_mean_error(), 0.0);
    EXPECT_LE(at_one.max_mean_error(), plain.max_mean_error());
    EXPECT_EQ(at_zero.max_mean_error(), 0.0);
    EXPECT_EQ(at_zero.max_sd_error(), 0.0);
}

// Images larger than a pixel (gaussian clouds 9 times the grain, about
// 3.6 um radius on 4 um pixels): the correlations reach past the
// neighbours, the model keeps them (to 2 lags or more) and has them
// against the clouds grain by grain; and the pixel kernel's field has them
// too, where each pixel's law is near normal (clouds of density 0.02: mean
// transmittance 0.24, Gamma shape 41) and where it is skewed (density 0.1:
// mean 0.001, shape 1.4, where normals of the model's correlation would
// give 0.44 at lag 1 for the model's 0.47: copula_normal_correlation).
TEST(PixelModel, CorrelationsBeyondTheNeighbours)
{
    const TestLayer t;
    const std::vector<PixelPopulation>& pops = t.pops;
    for (const double density : { 0.02, 0.1 }) {
        Layer layer;
        layer.image                = LayerImage::dye;
        layer.cloud_profile        = CloudProfile::gaussian;
        layer.cloud_diameter_ratio = 9.0;
        layer.cloud_density        = density;
        const ImageOverlap image(layer);
        const std::string what      = "cloud density " + std::to_string(density);
        const double v              = 1.0;
        const PixelModel::Moments m = PixelModel::compute(pops, 4.0, 4.0, v, image);
        EXPECT_GT(m.correlation[2], 0.05) << what;  // the lag (2, 0) carries weight
        if (density == 0.02) {
            // 8 samples per pixel and axis: 3.6 um clouds vary little over 0.5 um.
            expect_moments(monte_carlo(pops[0], v, &layer, 1.0, 8), m, what);
        }
        const PixelModel model(pops, 4.0, 4.0, image);
        EXPECT_GE(model.lags(), 2) << what;
        EXPECT_LE(model.max_dropped_correlation(), PixelModel::kDroppedCorrelation) << what;
        EXPECT_LT(model.max_copula_error(), 0.01) << what;
        const PixelModel::Moments at = model.at(v);
        // 4 fields of 128 x 128 pixels at v.
        constexpr int kN = 128;
        const std::vector<double> values(kN * kN, v);
        LagSums sums;
        double sum = 0.0, sum2 = 0.0;
        for (uint64_t key = 1; key <= 4; ++key) {
            std::vector<double> field(kN * kN);
            sample_pixel_transmittance(model, key, 0, 0, kN, kN, values.data(), nullptr,
                                       field.data());
            for (double x : field) {
                sum += x;
                sum2 += x * x;
            }
            sums.add(field, kN);
        }
        const double n = 4.0 * kN * kN, mean = sum / n, var = sum2 / n - mean * mean;
        double r10, r20, r11;
        sums.correlations(mean, var, r10, r20, r11);
        // Standard error of a correlation of a correlated field: about
        // sqrt(sum of rho^2 over lags / n) (Bartlett); the model's sum of
        // rho bounds that sum (rho <= 1).
        const double se  = std::sqrt(at.correlation_sum / n);
        const double tol = 5 * se + model.max_copula_error();
        EXPECT_NEAR(r10, at.correlation[1], tol) << what;
        EXPECT_NEAR(r20, at.correlation[2], tol) << what;
        EXPECT_NEAR(r11, at.correlation[kLagSide + 1], tol) << what;
        EXPECT_NEAR(var, at.variance, 5 * var * std::sqrt(2.0 * at.correlation_sum / n)) << what;
    }
}

// The lag weights cover the plane: the correlations summed over every lag
// the model keeps equal the integral of C over the plane (correlation_sum)
// when the correlations end within kMaxLag pixels (a row of pixels'
// overlaps sums to the pitch), for silver discs within one pixel and
// clouds reaching past two (gaussian clouds of 2 um radius around the
// mean grain, cut at 3 radii: no overlap beyond 12 um, none at lags 4 and
// more of 4 um pixels, but for the rare larger grains).
TEST(PixelModel, LagsSumToThePlane)
{
    const TestLayer t;
    Layer clouds;
    clouds.image                = LayerImage::dye;
    clouds.cloud_profile        = CloudProfile::gaussian;
    clouds.cloud_diameter_ratio = 5.0;
    clouds.cloud_density        = 0.02;
    for (const ImageOverlap& image : { ImageOverlap(), ImageOverlap(clouds) }) {
        const PixelModel::Moments m = PixelModel::compute(t.pops, 4.0, 4.0, 1.0, image);
        double kept = 0.0;
        for (int j = 0; j <= kMaxLag; ++j)
            for (int i = 0; i <= kMaxLag; ++i)
                kept += (i ? 2.0 : 1.0) * (j ? 2.0 : 1.0) * m.correlation[j * kLagSide + i];
        EXPECT_NEAR(kept, m.correlation_sum, 1e-4 * m.correlation_sum);
        EXPECT_GT(m.correlation_sum, 1.0);
    }
}

// The covariance integral converges on the table's distance grid: its
// variance, neighbour correlation and correlation sum against the same
// integral on 32 times as many cells, for narrow silver grains and for
// wide (log sigma 0.7, like VISION3 500T's blue layer) grains with gaussian
// clouds twice their size, whose images span a factor ~10^6 in size. A
// uniform grid (the table's until commit f6987bb) fails here: 512 cells
// against 16384 put this wide layer's variance 3-8% high (and VISION3
// 500T's blue layer's ~16%: cells of ~1 um against clouds of ~0.5 um).
TEST(PixelModel, VarianceConverges)
{
    const TestLayer t;
    Population wide_pop = t.pop;
    wide_pop.diameter_um        = 0.45;
    wide_pop.grains_per_um2     = 15.0;
    wide_pop.diameter_log_sigma = 0.7;
    const PopulationGrains wide_grains(wide_pop, 1, 0, 0);
    const std::vector<PixelPopulation> wide { { &wide_pop, &wide_grains, 40.0, &t.curve,
                                                &t.table } };
    Layer clouds;
    clouds.image                = LayerImage::dye;
    clouds.cloud_profile        = CloudProfile::gaussian;
    clouds.cloud_diameter_ratio = 2.0;
    clouds.cloud_density        = 0.255;
    struct Case {
        const char* what;
        const std::vector<PixelPopulation>* pops;
        ImageOverlap image;
    };
    const Case cases[] = { { "silver", &t.pops, ImageOverlap() },
                           { "wide dye", &wide, ImageOverlap(clouds) } };
    for (const Case& c : cases)
        for (const double v : { 0.05, 0.5, 2.0 }) {
            const std::string what = std::string(c.what) + " at v " + std::to_string(v);
            const PixelModel::Moments m = PixelModel::compute(*c.pops, 6.25, 6.25, v, c.image);
            const PixelModel::Moments ref
                = PixelModel::compute(*c.pops, 6.25, 6.25, v, c.image, 0.0, 16384);
            ASSERT_GT(ref.variance, 0.0) << what;
            EXPECT_NEAR(m.variance / ref.variance, 1.0, 1e-3) << what;
            EXPECT_NEAR(m.correlation[1], ref.correlation[1], 1e-3) << what;
            EXPECT_NEAR(m.correlation_sum / ref.correlation_sum, 1.0, 1e-3) << what;
        }
}

// The normals' correlation that skewed_draw bends into a given one:
// against draws of correlated normal pairs, in a near-normal and a skewed
// pixel law.
TEST(PixelModel, CopulaNormalCorrelationGivesTheDrawsTheirCorrelation)
{
    // Open-part shapes 45 and 1.6; at 0.5 both parts' 20; at 0.9 the
    // covered part's 2.
    for (const auto& [mean, variance] : { std::pair { 0.3, 0.002 }, std::pair { 0.002, 2.5e-6 },
                                          std::pair { 0.5, 0.0125 }, std::pair { 0.9, 0.005 } }) {
        for (const double rho : { 0.1, 0.5, 0.9 }) {
            const double r = copula_normal_correlation(mean, variance, rho);
            EXPECT_GE(r, rho);
            // 200000 pairs of normals with correlation r, through skewed_draw.
            constexpr int kPairs = 200000;
            double sa = 0.0, sb = 0.0, saa = 0.0, sbb = 0.0, sab = 0.0;
            for (int i = 0; i < kPairs; ++i) {
                const double u1 = uniform_from_bits53(counter_u64(hash_ids(5, i), 0));
                const double u2 = uniform_from_bits53(counter_u64(hash_ids(6, i), 0));
                const double z1 = normal_quantile(u1), z2 = normal_quantile(u2);
                const double a = skewed_draw(mean, variance, z1);
                const double b = skewed_draw(mean, variance, r * z1 + std::sqrt(1 - r * r) * z2);
                sa += a, sb += b, saa += a * a, sbb += b * b, sab += a * b;
            }
            const double n = kPairs;
            const double cov = sab / n - sa / n * sb / n;
            const double corr
                = cov / std::sqrt((saa / n - sa * sa / (n * n)) * (sbb / n - sb * sb / (n * n)));
            // Standard error of a correlation: (1 - rho^2) / sqrt(n) for
            // normals; skewed draws widen it, so 6 of them.
            EXPECT_NEAR(corr, rho, 6 * (1 - rho * rho) / std::sqrt(n) + 2e-3)
                << "mean " << mean << " rho " << rho;
        }
    }
}

// skewed_draw has the model's mean and variance (to the Wilson-Hilferty
// cubes' own bias, c^3 of the mean with c = V / (9 m^2), and the clamps
// to [0, 1]) from mostly open to mostly covered pixels, near-normal and
// skewed, and no jump in its law at a mean of 1/2 (the same normal a hair
// either side gives the same draw).
TEST(PixelModel, SkewedDrawHasTheMeanAndVariance)
{
    constexpr int kDraws = 400000;
    for (const double mean : { 0.002, 0.05, 0.3, 0.5, 0.7, 0.95, 0.998 })
        for (const double shape : { 40.0, 2.0 }) {
            // Shape of the smaller part's Gamma law: (min(m, 1 - m))^2 / V,
            // the variance at most 5% of a single grain's m (1 - m) (the
            // pixel scale's pixels hold many).
            const double part     = std::min(mean, 1.0 - mean);
            const double variance = std::min(part * part / shape, 0.05 * mean * (1.0 - mean));
            double s = 0.0, s2 = 0.0;
            for (int i = 0; i < kDraws; ++i) {
                // Midpoint quantiles: a stratified sample of the normal.
                const double t = skewed_draw(mean, variance, normal_quantile((i + 0.5) / kDraws));
                s += t;
                s2 += t * t;
            }
            const double m = s / kDraws, v = s2 / kDraws - m * m;
            const std::string what = "mean " + std::to_string(mean) + " shape "
                                     + std::to_string(shape);
            EXPECT_NEAR(m, mean, 2e-3 * part) << what;
            EXPECT_NEAR(v / variance, 1.0, 0.02) << what;
        }
    for (const double z : { -3.0, -1.0, 0.0, 1.0, 3.0 })
        EXPECT_NEAR(skewed_draw(0.5 - 1e-9, 0.01, z), skewed_draw(0.5 + 1e-9, 0.01, z), 1e-6)
            << "z " << z;
}

// The batch of draws a block takes (vectorised: two or more pixels a
// step, the rest one by one) gives every pixel what it would alone, to the
// bit, at every offset in the batch: a pixel's value cannot depend on its
// tile. Means and variances with no law (0, 1, no variance) included.
TEST(PixelModel, BatchDrawsAreTheSingleDrawsToTheBit)
{
    std::vector<double> mean, variance, z;
    Rng rng(7, Stage::cell);
    for (int i = 0; i < 257; ++i) {
        const int kind = i % 11;
        mean.push_back(kind == 0 ? 0.0 : kind == 1 ? 1.0 : rng.uniform());
        variance.push_back(kind == 2 ? 0.0 : 0.05 * rng.uniform() * rng.uniform());
        z.push_back(normal_quantile(rng.uniform()));
    }
    for (size_t start : { size_t(0), size_t(1), size_t(3) }) {
        const size_t n = mean.size() - start;
        std::vector<double> batch(n, -1.0);
        skewed_draws(&mean[start], &variance[start], &z[start], batch.data(), n);
        for (size_t i = 0; i < n; ++i) {
            const double one = skewed_draw(mean[start + i], variance[start + i], z[start + i]);
            EXPECT_EQ(std::memcmp(&batch[i], &one, sizeof one), 0)
                << "pixel " << start + i << ": " << batch[i] << " against " << one;
            EXPECT_TRUE(batch[i] >= 0.0 && batch[i] <= 1.0);
        }
    }
}

// The copula's filter has the correlation it is given: Gaussian-shaped
// correlations of widths up to 1.2 pixels on the lags that hold them (the
// correlation beyond them below 0.4%), and the 3x3 correlations of a small
// grain's pixels.
TEST(PixelModel, CopulaFilterHasItsCorrelation)
{
    for (const double width : { 0.3, 0.6, 1.2 }) {
        const int lags = std::min(kMaxLag, static_cast<int>(std::ceil(3.5 * width)));
        LagArray rho {}, f {};
        for (int j = 0; j <= lags; ++j)
            for (int i = 0; i <= lags; ++i)
                rho[j * kLagSide + i] = std::exp(-0.5 * (i * i + j * j) / (width * width));
        const double error = copula_filter(rho, lags, f);
        EXPECT_LT(error, 0.01) << "width " << width;
        // The error it reports is the one its taps have.
        const int support = filter_lags(lags);
        double sum2 = 0.0, lag1 = 0.0;
        for (int b = -support; b <= support; ++b)
            for (int a = -support; a <= support; ++a) {
                const double t = f[std::abs(b) * kLagSide + std::abs(a)];
                sum2 += t * t;
                if (a + 1 <= support)
                    lag1 += t * f[std::abs(b) * kLagSide + std::abs(a + 1)];
            }
        EXPECT_NEAR(sum2, 1.0, 1e-12);
        EXPECT_NEAR(lag1, rho[1], error + 1e-12) << "width " << width;
    }
    LagArray rho {}, f {};
    rho[0] = 1.0;
    rho[1] = rho[kLagSide] = 0.2;
    rho[kLagSide + 1] = 0.04;
    EXPECT_LT(copula_filter(rho, 1, f), 0.01);
    // No correlation: the identity.
    LagArray none {};
    none[0] = 1.0;
    EXPECT_LT(copula_filter(none, 2, f), 1e-12);
    EXPECT_NEAR(f[0], 1.0, 1e-12);
}

TEST(PixelModel, SamplesAreTileIndependent)
{
    const DevelopTable table = small_develop_table(128, 1e-2);
    const DevelopCurve curve(table);
    Population pop;
    pop.grains_per_um2 = 2.0;
    pop.diameter_um    = 0.6;
    const PopulationGrains grains(pop, 1, 0, 0);
    const PixelModel model({ { &pop, &grains, 50.0, &curve, &table } }, 5.0, 5.0);
    std::vector<double> v(32 * 32), whole(32 * 32), part(16 * 16);
    for (size_t i = 0; i < v.size(); ++i)
        v[i] = 0.01 * static_cast<double>(i % 97);
    sample_pixel_transmittance(model, 7, 0, 0, 32, 32, v.data(), nullptr, whole.data());
    std::vector<double> vp(16 * 16);
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x)
            vp[y * 16 + x] = v[(y + 16) * 32 + x + 16];
    sample_pixel_transmittance(model, 7, 16, 16, 32, 32, vp.data(), nullptr, part.data());
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x)
            EXPECT_EQ(part[y * 16 + x], whole[(y + 16) * 32 + x + 16]);
}

// The sampled law's shape (pixel_shape.h) against the same layer's pixels
// rendered grain by grain by the fast kernel (monte_carlo: its own grains,
// 12 blocks of 48^2 pixels, the dye image at 32 samples, as the shape's):
// the coupler-limited layer above and its grains under gaussian clouds,
// sparse to dense. The shape's window has the moments' mean and variance
// (within 5 standard errors: the mean's sqrt(V correlation_sum / n), the
// variance's as expect_moments's), and its standardised quantiles at z =
// -1.645, 0 and 1.645 are the grains' (standardised by their own mean and
// sd) within 5 standard errors of the difference of two sample quantiles,
// each sqrt(p (1 - p) / n) / f with f the density there (from the grains'
// quantiles 0.02 either side) plus its standardisation's (the mean's
// 1 / sqrt(n), the sd's z sqrt((m4 - 1) / (4 n)), m4 the grains'
// standardised fourth moment), n halved for the neighbours' correlation as
// expect_moments halves it.
TEST(PixelModel, SampledShapeIsTheGrainsLaw)
{
    const CouplerLimitedLayer c;
    Layer gaussian;  // the same grains under gaussian clouds, none limited
    make_dye(gaussian, CloudProfile::gaussian, 0.9, 0.7);
    gaussian.populations                    = c.layer.populations;
    gaussian.populations[0].max_dye_density = 0.0;
    for (const Layer* layer : { &c.layer, static_cast<const Layer*>(&gaussian) }) {
        const std::vector<PixelPopulation> pops = c.pops_of(*layer);
        const ImageOverlap image(*layer);
        for (double v : { 0.1, 0.4, 1.5 }) {
            const std::string what = std::string(name_of(layer->cloud_profile)) + " v "
                                     + std::to_string(v);
            const PixelModel::Moments m = PixelModel::compute(pops, 4.0, 4.0, v, image);
            ShapeWindow window;
            const PixelShape shape = sample_pixel_shape(pops, *layer, 4.0, 4.0, 32, 20.0, v,
                                                        0.0, hash_ids(11, v * 10), &window);
            constexpr double kWindow = kShapeWindow * kShapeWindow;
            EXPECT_NEAR(window.mean, m.mean, 5.0 * std::sqrt(m.variance * m.correlation_sum
                                                             / kWindow))
                << what;
            EXPECT_NEAR(window.variance, m.variance,
                        5.0 * m.variance * std::sqrt(2.0 / (kWindow / 2)))
                << what;
            std::vector<double> grains;
            const Sample s = monte_carlo(pops, v, layer, 1.0, 32, &grains);
            std::sort(grains.begin(), grains.end());
            const double sd = std::sqrt(s.var), n = static_cast<double>(grains.size());
            double m4 = 0.0;
            for (double x : grains)
                m4 += std::pow((x - s.mean) / sd, 4) / n;
            const auto quantile = [&](double p) {
                const double pos = std::clamp(p * n - 0.5, 0.0, n - 2.0);
                const size_t i   = static_cast<size_t>(pos);
                return (grains[i] + (pos - i) * (grains[i + 1] - grains[i]) - s.mean) / sd;
            };
            const double both = 1.0 / (kWindow / 2) + 1.0 / (n / 2);
            for (double z : { -1.645, 0.0, 1.645 }) {
                const double p = normal_cdf(z);
                const double f = 0.04 / (quantile(p + 0.02) - quantile(p - 0.02));
                const double se
                    = std::sqrt((p * (1.0 - p) / (f * f) + 1.0 + z * z * (m4 - 1.0) / 4.0) * both);
                EXPECT_NEAR(shape_value(shape, z), quantile(p), 5.0 * se) << what << " z " << z;
            }
        }
    }
}

// The on-disk cache's form: a model read back from its bytes draws the
// same pixels bit for bit, inhibited (two axes) or not, its law's shape
// sampled or not; bytes cut short, lengthened or not a model are refused.
TEST(PixelModel, BytesGiveTheSameModel)
{
    const TestLayer t;
    Layer dye;  // a shaped model too (pixel_shape.h)
    make_dye(dye, CloudProfile::gaussian, 0.9, 0.7);
    const PixelModel::ShapeSampling shape { &dye, 8 };
    for (double max_log_factor : { 0.0, 0.3, -0.3 }) {
        const bool shaped = max_log_factor < 0.0;
        const PixelModel model(t.pops, 4.0, 4.0, shaped ? ImageOverlap(dye) : ImageOverlap(),
                               std::fabs(max_log_factor), 0,
                               std::numeric_limits<double>::infinity(),
                               shaped ? &shape : nullptr);
        EXPECT_EQ(model.shaped(), shaped);
        const std::string bytes = model.serialize();
        const std::shared_ptr<const PixelModel> back = PixelModel::deserialize(bytes);
        ASSERT_TRUE(back) << max_log_factor;
        EXPECT_EQ(back->serialize(), bytes);
        EXPECT_EQ(back->lags(), model.lags());
        EXPECT_EQ(back->max_mean_error(), model.max_mean_error());
        std::vector<double> v(24 * 24), log_factor(v.size()), a(v.size()), b(v.size());
        for (size_t i = 0; i < v.size(); ++i) {
            v[i]          = 0.02 * static_cast<double>(i % 89);
            log_factor[i] = max_log_factor * static_cast<double>(i % 7) / 6.0;
        }
        EXPECT_EQ(back->shaped(), shaped);
        EXPECT_EQ(back->shapes_sampled(), model.shapes_sampled());
        for (size_t i = 0; i < v.size(); ++i)
            log_factor[i] = std::fabs(log_factor[i]);
        sample_pixel_transmittance(model, 3, 0, 0, 24, 24, v.data(), log_factor.data(), a.data());
        sample_pixel_transmittance(*back, 3, 0, 0, 24, 24, v.data(), log_factor.data(), b.data());
        EXPECT_EQ(a, b) << max_log_factor;
        EXPECT_FALSE(PixelModel::deserialize(bytes.substr(0, bytes.size() - 1)));
        EXPECT_FALSE(PixelModel::deserialize(bytes + "x"));
        EXPECT_FALSE(PixelModel::deserialize(bytes.substr(0, bytes.size() / 2)));
    }
    EXPECT_FALSE(PixelModel::deserialize(""));
    EXPECT_FALSE(PixelModel::deserialize(std::string(64, '\xff')));
}

}  // namespace
}  // namespace filmgrain
