// Tests of the pixel-scale model against Monte Carlo renders of the
// Boolean model it summarises: developed discs drawn grain by grain (the
// fast kernel's grains and curve), exact pixel coverage, and the pixel
// transmittances' mean, variance and neighbour correlation compared with
// PixelModel's, tolerances from the sampling variance.
#include "pixel_model.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "dye.h"
#include "grain_kernel.h"
#include "image_formation.h"
#include "test_tables.h"

namespace filmgrain {
namespace {

struct Sample {
    double mean = 0.0, var = 0.0, rho_x = 0.0;
    double se_mean = 0.0, se_var = 0.0, se_rho = 0.0;
};

/// Pixel transmittances of several 48x48 blocks of 4 um pixels, grain by
/// grain: exact coverage of silver discs, or (`dye`) the dye image of
/// MODEL.md 8 at 32 samples per pixel and axis.
Sample monte_carlo(const PixelPopulation& pp, double v, const Layer* dye = nullptr,
                   double factor = 1.0)
{
    constexpr int kBlocks = 12, kN = 48;
    constexpr double kPitch = 4.0;
    std::vector<double> t_all;
    double sxy = 0.0;
    int pairs = 0;
    std::vector<double> means;
    for (int b = 0; b < kBlocks; ++b) {
        const PopulationGrains grains(*pp.population, 100 + b, 0, 0);
        const FastGrains fast(grains);
        const RectUm rect { 0.0, 0.0, kN * kPitch, kN * kPitch };
        // Grains whose image may reach the block (clouds: to their reach).
        const double margin = dye ? image_reach_factor(*dye) * grains.radius_at_z_um(9.0) : 0.0;
        const RectUm near { -margin, -margin, kN * kPitch + margin, kN * kPitch + margin };
        std::vector<Disc> discs;
        fast.for_each_grain_near(near, [&](double x, double y, double r, uint32_t bits, uint64_t) {
            const Disc d { x, y, dye ? r * image_reach_factor(*dye) : r };
            if (!disc_touches_rect(d, rect.x0_um, rect.y0_um, rect.x1_um, rect.y1_um))
                return;
            const double u = (bits + 0.5) * 0x1.0p-32;
            if (u >= 1.0 - factor * pixel_develop_probability(
                               pp, pp.photons_per_value_um2 * v * M_PI * r * r))
                discs.push_back({ x, y, r });
        });
        std::vector<double> f(kN * kN);
        if (dye) {
            DyeScratch scratch;
            dye_transmittance(discs, *dye, 20.0, 0, 0, kN, kN, kPitch, kPitch, 32, scratch,
                              f.data());
            for (double& c : f)
                c = 1.0 - c;  // as a covered fraction, like grid_coverage's
        } else {
            GridCoverageScratch scratch;
            grid_coverage(discs, 0, 0, kN, kN, kPitch, kPitch, scratch, f.data());
        }
        double m = 0.0;
        for (double c : f) {
            t_all.push_back(1.0 - c);
            m += 1.0 - c;
        }
        means.push_back(m / (kN * kN));
        for (int y = 0; y < kN; ++y)
            for (int x = 0; x + 1 < kN; ++x) {
                sxy += (1.0 - f[y * kN + x]) * (1.0 - f[y * kN + x + 1]);
                ++pairs;
            }
    }
    Sample s;
    const double n = static_cast<double>(t_all.size());
    for (double t : t_all)
        s.mean += t / n;
    for (double t : t_all)
        s.var += (t - s.mean) * (t - s.mean) / (n - 1);
    s.rho_x = (sxy / pairs - s.mean * s.mean) / s.var;
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
    return s;
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

/// The model's mean, variance and neighbour correlation against a Monte
/// Carlo sample, within 5 of its standard errors.
void expect_moments(const Sample& s, const PixelModel::Moments& m, const std::string& what)
{
    EXPECT_NEAR(s.mean, m.mean, 5 * s.se_mean + 1e-4) << what;
    EXPECT_NEAR(s.var, m.variance, 5 * s.se_var) << what;
    EXPECT_NEAR(s.rho_x, m.rho_x, 5 * s.se_rho) << what;
}

TEST(PixelModel, MomentsMatchTheBooleanModelGrainByGrain)
{
    const TestLayer t;
    const std::vector<PixelPopulation>& pops = t.pops;
    for (double v : { 0.05, 0.4, 1.0 }) {
        const PixelModel::Moments m = PixelModel::compute(pops, 4.0, 4.0, v);
        expect_moments(monte_carlo(pops[0], v), m, "v " + std::to_string(v));
        EXPECT_LT(m.rho_x, 0.3);  // the n / 2 effective pixels above
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
        layer.image                = LayerImage::dye;
        layer.cloud_profile        = profile;
        layer.cloud_diameter_ratio = profile == CloudProfile::disc ? 1.5 : 0.9;
        layer.cloud_density        = 0.7;
        const ImageOverlap image(layer);
        for (double v : { 0.4, 1.0 }) {
            const PixelModel::Moments m = PixelModel::compute(pops, 4.0, 4.0, v, image);
            const Sample s = monte_carlo(pops[0], v, &layer);
            const std::string what = std::string(cloud_profile_name(profile)) + " v "
                                     + std::to_string(v);
            expect_moments(s, m, what);
            // Not the silver statistics of the same grains (the clouds
            // block 1.8 and 0.66 times a disc's light).
            const PixelModel::Moments silver = PixelModel::compute(pops, 4.0, 4.0, v);
            EXPECT_GT(std::fabs(silver.mean - m.mean), 5 * s.se_mean) << what;
        }
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

TEST(PixelModel, MovingAverageTapsHaveTheirCorrelation)
{
    for (double rho : { 0.0, 0.05, 0.2, 0.5 }) {
        double t[3];
        moving_average_taps(rho, t);
        EXPECT_NEAR(t[0] * t[0] + t[1] * t[1] + t[2] * t[2], 1.0, 1e-12);
        EXPECT_NEAR(t[0] * t[1] + t[1] * t[2], rho, 1e-12);
    }
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

}  // namespace
}  // namespace filmgrain
