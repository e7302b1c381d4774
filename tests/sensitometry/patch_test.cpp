// expose_patch with light spread (MODEL.md 9; docs/model.md, "Halation from
// the base"): the measured square sees a uniform field's light however far
// the kernels reach.
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "model/light_spread.h"
#include "test_support.h"

namespace filmgrain::sensitometry {
namespace {

// `paper`'s silver layer with all its light returned by a bare base 125 um
// thick (halation 1: the base kernel reaches 3.2 mm) on a 1 mm patch of
// 2 um pixels: its margin is that reach, a scan of 3.7k pixels a side; an
// input of the scan's pixels would need a transform of 4.8e7 values
// (0.8 GB in its two grids; 2.5e8 and 4 GB when the kernel was cut at
// 1e-3, 10.2 mm), so the input has at most kMaxPatchInputPx. The square
// gets the light of the layer with twice its sensitivity and no halation
// (MODEL.md 9 on a uniform field: 1 + halation times the light): its grains
// absorb as many photons each. Tolerance: a grain's count X has
// Var(X) / E[X]^2 = CV_a^2 + 1 / E[X] (its disc's area a, lognormal with
// log sigma 2 s = 1: CV_a^2 = e - 1 = 1.72; E[X] ~ 11), so the mean over
// the square's ~1e5 grains has a relative standard deviation of 0.43%, the
// ratio of two patches 0.60%: 4 of those, 2.4% (measured: -0.45%). The
// margin without the base kernel's reach (the rule before it: a one-pixel
// input, the halo's light beyond the square's frame lost) gave 23.7% fewer
// photons a grain (measured with the kernel cut at 1e-3, 10.2 mm).
// The densities agree too, within 4 standard errors of their difference
// (the patch's blocks); the curve is flat here (2x the light is +0.05), so
// that alone would not tell.
TEST(Patch, ABaseHaloOnAFinePatchReadsAsAUniformField)
{
    Stock halo = testing::load_test_stock("paper");
    halo.base_thickness_um         = 125.0;
    halo.rear_face                 = RearFace::bare;
    halo.layers[0].halation        = 1.0;
    halo.layers[0].halation_kernel = HalationKernel::base;
    ASSERT_TRUE(halo.validate());
    Stock brighter = testing::load_test_stock("paper");
    for (double& w : brighter.layers[0].sensitivity)
        w *= 2.0;
    // The reach (3.2 mm) is over three times the square's side (1 mm).
    ASSERT_GT(patch_spread_reach_um(halo), 3000.0);
    PatchSpec spec;
    spec.exposure_lxs = halo.exposure_at_grey_lxs;
    spec.side_um      = 1000.0;
    spec.pitch_um     = 2.0;
    spec.blocks       = 8;
    spec.seed         = 7;
    PatchReading a, b;
    Status s = expose_patch(halo, spec, testing::exact_settings(), a);
    ASSERT_TRUE(s) << s.message();
    s = expose_patch(brighter, spec, testing::exact_settings(), b);
    ASSERT_TRUE(s) << s.message();
    const LayerReading &x = a.layers[0], &y = b.layers[0];
    ASSERT_GT(x.grains, 50000u);
    ASSERT_GT(y.grains, 50000u);
    const double per_grain_x = static_cast<double>(x.absorbed_photons) / x.grains;
    const double per_grain_y = static_cast<double>(y.absorbed_photons) / y.grains;
    std::printf("photons a grain: %.3f with the halo, %.3f with twice the sensitivity (%+.2f%%); "
                "density %.4f +- %.4f, %.4f +- %.4f\n",
                per_grain_x, per_grain_y, 100.0 * (per_grain_x / per_grain_y - 1.0), x.density,
                x.density_se, y.density, y.density_se);
    EXPECT_NEAR(per_grain_x / per_grain_y, 1.0, 0.024);
    EXPECT_NEAR(x.density, y.density, 4.0 * std::hypot(x.density_se, y.density_se));
}

}  // namespace
}  // namespace filmgrain::sensitometry
