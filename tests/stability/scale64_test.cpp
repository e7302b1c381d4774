// 64-bit scale (MODEL.md 1: "every count is 64-bit"): a frame 1e8 mm wide
// (1e11 um) scanned at 2^36 pixels across, of which a small ROI at the far
// corner is rendered. The frame holds ~2.5e20 grains and ~1e21 absorbed
// photons, its scan pixel indices exceed 2^32 and so do its grain-cell
// indices (cells are ~12.6 um). The ROI must be right (agree with
// expectations.h) and cost only what it needs (the statistics scale with
// the ROI, not the frame). scripts/sanitize runs this under UBSan.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "checks.h"
#include "expect/expectations.h"
#include "model/exposure.h"
#include "filmgrain/render.h"

namespace filmgrain::stability {
namespace {

constexpr double kFrameWidthMm  = 1e8;
constexpr int64_t kInputWidth   = 4;  // 4 x 1 input pixels of 2.5e10 um
constexpr int64_t kScanWidth    = int64_t(1) << 36;
constexpr double kStops         = -2.0;
constexpr double kShutterS      = 1e-2;

/// The paper's scale, as in tests/statistical (mid-curve at these settings).
Stock paper_stock()
{
    Stock stock;
    stock.exposure_at_grey_lxs = 0.003;
    stock.max_density          = 20;  // keep the clamp out of the mean transmittance
    stock.layers[0].populations[0] = Population {};
    stock.layers[0].populations[0].quantum_efficiency = 0.05;
    return stock;
}

struct FarRender {
    Status status;
    std::vector<float> density;
    RenderStats stats;
    ScanGeometry scan;
};

/// Renders the w x h scan pixels ending `from_end` pixels before the far
/// corner (or starting at the origin when at_origin).
FarRender render_far(int64_t w, int64_t h, int64_t from_end, bool at_origin = false,
                     int tile = 64, int threads = 2)
{
    SceneSettings scene;
    scene.exposure_stops = kStops;
    scene.shutter_s      = kShutterS;
    scene.width_mm = kFrameWidthMm;
    scene.seed           = 64;
    static const std::vector<float> input(kInputWidth, 0.18f);
    const ImageView view { input.data(), kInputWidth, 1, 1 };
    RenderSettings settings;
    settings.engine       = Engine::exact;
    settings.scan_width   = kScanWidth;
    settings.nthreads     = threads;
    settings.tile_size_px = tile;
    FarRender r;
    r.status = scan_geometry(scene, view.width, view.height, settings, r.scan);
    if (!r.status)
        return r;
    const int64_t x0 = at_origin ? 0 : r.scan.width - from_end;
    const int64_t y0 = at_origin ? 0 : r.scan.height - from_end;
    settings.roi     = Roi { x0, y0, x0 + w, y0 + h };
    r.density.assign(static_cast<size_t>(w * h), -1.0f);
    r.status = render_negative(paper_stock(), scene, view, settings, r.density.data(), &r.stats);
    return r;
}

TEST(StabilityScale64, FarCornerOfAHugeFrameAgreesWithTheModel)
{
    const int64_t side = 256;
    const FarRender r  = render_far(side, side, 300);
    ASSERT_TRUE(r.status) << r.status.message();

    // The scene really is beyond 32 bits.
    const Stock stock     = paper_stock();
    const Population& pop = stock.layers[0].populations[0];
    const double frame_area_um2 = r.scan.frame_width_um * r.scan.frame_height_um;
    const double frame_grains   = pop.grains_per_um2 * frame_area_um2;
    const double exposure_lxs
        = 0.18 * exposure_lxs_per_unit_value(stock.exposure_at_grey_lxs, kStops);
    const Development dev(stock);
    DevelopGivenPhotons p_given_n({ pop.k_pair_per_s, pop.k_join_per_s, pop.k_loss_per_s },
                                  kShutterS, dev, 3000, 0x64b);
    const DevelopmentMoments m = expected_development(pop, exposure_lxs, p_given_n);
    EXPECT_GT(frame_grains, 4294967296.0);
    EXPECT_GT(frame_grains * m.mean_photons, 4294967296.0);  // total absorbed photons
    EXPECT_GT(r.scan.width - 300, int64_t(1) << 32);           // pixel indices
    EXPECT_GT(r.scan.frame_width_um / 12.6, 4294967296.0);     // cell indices (cells ~12.6 um)

    // Every density finite.
    for (float d : r.density)
        ASSERT_TRUE(std::isfinite(d) && d >= 0.0f && d <= 20.0f) << d;

    // Developed fraction: Binomial(G, p) given G grains, plus the Monte
    // Carlo error of E[P]; kSigmas (as tests/statistical).
    const LayerStats& l = r.stats.layers[0];
    const double g      = static_cast<double>(l.grains);
    const double p      = m.develop_fraction.value;
    ASSERT_GT(p, 0.05);
    ASSERT_LT(p, 0.95);
    EXPECT_NEAR(l.developed / g, p,
                kSigmas * std::sqrt(p * (1 - p) / g + std::pow(m.develop_fraction.standard_error, 2)));

    // Mean transmittance: exp(-n E[aP]) with Var <= T n E[a^2 P] / A (the
    // Boolean-model bound derived in tests/statistical/uniform_patch_test),
    // plus the Monte Carlo error of E[aP]; kSigmas.
    double sum_t = 0.0;
    for (float d : r.density)
        sum_t += std::pow(10.0, -static_cast<double>(d));
    const double mean_t  = sum_t / static_cast<double>(r.density.size());
    const double area    = std::pow(side * r.scan.pitch_x_um, 2.0);
    const double n       = pop.grains_per_um2;
    const double t       = std::exp(-n * m.area_developed_um2.value);
    const double sigma_t = std::sqrt(t * n * m.area2_developed_um4.value / area
                                     + std::pow(t * n * m.area_developed_um2.standard_error, 2));
    EXPECT_NEAR(mean_t, t, kSigmas * sigma_t);
}

TEST(StabilityScale64, CostFollowsTheRoiNotTheFrame)
{
    // Grains counted (centres in the ROI), photons and events scale with the
    // ROI's area; the input pixels read stay the one under the ROI. Grain
    // counts are Poisson(n A): kSigmas of sqrt(n A).
    const FarRender small = render_far(64, 64, 300);
    const FarRender large = render_far(128, 128, 300);
    const FarRender near  = render_far(64, 64, 0, true);
    ASSERT_TRUE(small.status && large.status && near.status);
    const double n = paper_stock().layers[0].populations[0].grains_per_um2;
    for (const FarRender* r : { &small, &large, &near }) {
        const double side_um = std::sqrt(static_cast<double>(r->density.size())) * r->scan.pitch_x_um;
        const double expected = n * side_um * side_um;
        EXPECT_NEAR(static_cast<double>(r->stats.layers[0].grains), expected,
                    kSigmas * std::sqrt(expected));
        EXPECT_EQ(r->stats.input.pixels_read, 1u);
        EXPECT_LE(r->stats.layers[0].kinetics_events, r->stats.layers[0].absorbed_photons);
    }
    // Photons per grain do not depend on where the ROI is (same exposure):
    // the far corner costs what the origin costs. Mean photons per grain
    // has relative sd ~ 1/sqrt(G * E[N]) at most sqrt(1 + CV_a^2) times
    // larger for lognormal areas (CV^2 = exp(4 s^2) - 1 = 0.43): a 10%
    // allowance is > 5 sigma for G ~ 400, E[N] ~ 6.
    const double far_ppg  = double(small.stats.layers[0].absorbed_photons) / small.stats.layers[0].grains;
    const double near_ppg = double(near.stats.layers[0].absorbed_photons) / near.stats.layers[0].grains;
    EXPECT_NEAR(far_ppg / near_ppg, 1.0, 0.1);
}

TEST(StabilityScale64, RegionIsTheSameWhateverTheRoiTilesAndThreads)
{
    // Determinism at 2^36: the 64x64 far region equals the same pixels of a
    // 96x96 render that contains it, and a render with other tiles/threads.
    const FarRender a = render_far(64, 64, 300, false, 64, 2);
    const FarRender b = render_far(64, 64, 300, false, 7, 1);
    const FarRender c = render_far(96, 96, 316, false, 32, 2);  // starts 16 px earlier
    ASSERT_TRUE(a.status && b.status && c.status);
    EXPECT_EQ(a.density, b.density);
    for (int64_t y = 0; y < 64; ++y)
        for (int64_t x = 0; x < 64; ++x)
            ASSERT_EQ(a.density[static_cast<size_t>(y * 64 + x)],
                      c.density[static_cast<size_t>((y + 16) * 96 + x + 16)])
                << x << "," << y;
}

TEST(StabilityScale64, ScanBeyondTheDocumentedLimitIsRefused)
{
    // FrameGeometry allows at most 2^40 scan pixels a side: beyond, an
    // error that names the scan, not an overflow.
    SceneSettings scene;
    scene.width_mm = kFrameWidthMm;
    std::vector<float> input(4, 0.18f);
    const ImageView view { input.data(), 4, 1, 1 };
    RenderSettings settings;
    settings.engine      = Engine::exact;
    settings.scan_width  = (int64_t(1) << 40) + 1;
    settings.scan_height = 1;
    settings.roi         = Roi { 0, 0, 1, 1 };
    float out            = 0;
    const Status s = render_negative(paper_stock(), scene, view, settings, &out, nullptr);
    ASSERT_FALSE(s);
    EXPECT_NE(s.message().find("scan"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace filmgrain::stability
