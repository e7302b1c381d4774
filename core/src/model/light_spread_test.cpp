// Tests of MODEL.md 9 (scatter and halation): the kernels' pixel weights,
// the spread exposure, and renders with spread (determinism, ROI, the halo's
// radius in micrometres whatever the scan, zero strength = no spread).
#include "model/light_spread.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "filmgrain/render.h"
#include "testing/test_render.h"

namespace filmgrain {
namespace {

double sum(const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0); }

/// The Gaussian's weight for input pixels m apart by brute force: the mean
/// over the output pixel of the Gaussian's integral over the input pixel,
/// i.e. the Gaussian against the tent (p - |u|) / p, by the midpoint rule
/// with 20000 steps on its support [-p, p].
double gaussian_weight_numeric(int64_t m, double sigma, double p)
{
    const int n = 20000;
    double s    = 0.0;
    for (int i = 0; i < n; ++i) {
        const double u = -p + (i + 0.5) * 2.0 * p / n;
        const double x = m * p + u;
        s += std::exp(-0.5 * x * x / (sigma * sigma)) / (sigma * std::sqrt(2.0 * M_PI))
             * (p - std::fabs(u)) / p * 2.0 * p / n;
    }
    return s;
}

TEST(LightSpread, GaussianWeightsAreTheTentAveragedGaussian)
{
    for (double sigma : { 0.5, 3.0, 12.0, 40.0 }) {
        const double p      = 6.25;
        const PixelKernel k = gaussian_pixel_kernel(sigma, p);
        EXPECT_NEAR(sum(k.weights), 1.0, 1e-12);
        EXPECT_GE(k.reach * p, 6.0 * sigma);
        for (int64_t m = 0; m <= std::min<int64_t>(k.reach, 6); ++m) {
            EXPECT_EQ(k.weights[k.reach + m], k.weights[k.reach - m]);
            // The midpoint rule's error is ~1e-9 here; the truncation's
            // renormalisation ~2e-9 relative.
            EXPECT_NEAR(k.weights[k.reach + m], gaussian_weight_numeric(m, sigma, p), 1e-8)
                << "sigma " << sigma << " m " << m;
        }
    }
}

TEST(LightSpread, HalationWeightsFillTheShape)
{
    const double p = 5.0, r = 100.0;
    for (HalationKernel shape : { HalationKernel::disc, HalationKernel::ring }) {
        const PixelKernel k = halation_pixel_kernel(shape, r, p);
        const int64_t n     = 2 * k.reach + 1;
        EXPECT_NEAR(sum(k.weights), 1.0, 1e-12);
        const double inner = shape == HalationKernel::ring ? kRingInnerFraction * r : 0.0;
        const double inside = p * p / (M_PI * (r * r - inner * inner));
        for (int64_t j = -k.reach; j <= k.reach; ++j)
            for (int64_t i = -k.reach; i <= k.reach; ++i) {
                const double w = k.weights[(j + k.reach) * n + (i + k.reach)];
                const double d = std::hypot(i * p, j * p);
                // Symmetric in both axes.
                EXPECT_EQ(w, k.weights[(-j + k.reach) * n + (i + k.reach)]);
                EXPECT_EQ(w, k.weights[(j + k.reach) * n + (-i + k.reach)]);
                // Nothing beyond the radius plus the tent's reach (a pixel
                // diagonal), nothing inside the ring's hole.
                if (d > r + 1.5 * p || d < inner - 1.5 * p) {
                    EXPECT_EQ(w, 0.0) << i << "," << j;
                }
                // Uniform where the tent lies wholly inside.
                if (d < r - 1.5 * p && d > inner + 1.5 * p) {
                    EXPECT_NEAR(w, inside, 1e-12 * inside) << i << "," << j;
                }
            }
        // Edge cells against a brute-force mean over the output pixel
        // (64x64 midpoints) of the shape's exact area over the input pixel.
        for (int64_t i = 0; i <= k.reach; ++i) {
            const int64_t j = static_cast<int64_t>(std::floor(std::sqrt(std::max(0.0,
                                  (r / p) * (r / p) - double(i * i)))));
            double ref = 0.0;
            for (int a = 0; a < 64; ++a)
                for (int b = 0; b < 64; ++b) {
                    const double x = (a + 0.5) * p / 64, y = (b + 0.5) * p / 64;
                    ref += disc_rect_area_um2(x, y, r, i * p, j * p, i * p + p, j * p + p)
                           - (inner > 0.0 ? disc_rect_area_um2(x, y, inner, i * p, j * p,
                                                               i * p + p, j * p + p)
                                          : 0.0);
                }
            ref /= 64.0 * 64.0 * M_PI * (r * r - inner * inner);
            // The midpoint rule's own error at a kink ~ (1/64)^2 of a cell.
            EXPECT_NEAR(k.weights[(j + k.reach) * n + (i + k.reach)], ref, 1e-3 * inside)
                << i << "," << j;
        }
    }
}

/// A frame of `w` x `h` one-channel pixels, all `ground` but a block of
/// `value` at (bx, by) of size `b`.
std::vector<float> block_image(int64_t w, int64_t h, float ground, int64_t bx, int64_t by,
                               int64_t b, float value)
{
    std::vector<float> img(static_cast<size_t>(w * h), ground);
    for (int64_t y = by; y < by + b; ++y)
        for (int64_t x = bx; x < bx + b; ++x)
            img[static_cast<size_t>(y * w + x)] = value;
    return img;
}

std::vector<float> spread(const Layer& layer, const std::vector<float>& img, int64_t w, int64_t h,
                          double pitch_um, const Stock& stock = Stock(),
                          FrameEdge edge = FrameEdge::gate)
{
    const ImageView view { img.data(), w, h, 1 };
    return spread_exposure(stock, layer,
                           LayerExposure(view, { 1.0, 0.0, 0.0 }, pitch_um,
                                         std::numeric_limits<double>::infinity(), edge),
                           w, h, pitch_um);
}

// The base kernel (docs/model.md, "Halation from the base").

/// Unpolarised Fresnel reflectance from index n into air at incidence
/// theta, written independently of the code's (Snell's angles, the sine
/// and tangent forms): 1 at and beyond the critical angle.
double fresnel_to_air(double theta, double n)
{
    const double st = n * std::sin(theta);
    if (st >= 1.0)
        return 1.0;
    if (theta == 0.0)
        return std::pow((n - 1.0) / (n + 1.0), 2.0);
    const double t  = std::asin(st);
    const double rs = std::sin(theta - t) / std::sin(theta + t);
    const double rp = std::tan(theta - t) / std::tan(theta + t);
    return 0.5 * (rs * rs + rp * rp);
}

/// The profile K(r) from the formula, independently: a Lambertian
/// 2 sin cos dtheta times R(theta) mapped to r = 2 t tan(theta), per um^2,
/// with Rbar given.
double profile_from_formula(double r, double t, double n, bool bare, double rbar)
{
    const double theta = std::atan(r / (2.0 * t));
    const double refl  = bare ? fresnel_to_air(theta, n) : 1.0;
    // dP = R 2 sin cos dtheta / Rbar over the ring 2 pi r dr, dr = 2t / cos^2 dtheta.
    return refl * 2.0 * std::sin(theta) * std::cos(theta) / rbar
           / (2.0 * M_PI * r * 2.0 * t / std::pow(std::cos(theta), 2.0));
}

TEST(LightSpread, BaseProfileIsTheFormula)
{
    const double t = 125.0, n = 1.5;
    const BaseHalation bare(t, n, RearFace::bare), remjet(t, n, RearFace::remjet);
    // R: 4% at normal incidence, Fresnel's between, 1 from the critical
    // angle asin(1 / n) = 41.81 degrees on.
    EXPECT_NEAR(bare.reflectance(1.0), 0.04, 1e-15);
    for (double deg : { 10.0, 30.0, 40.0, 41.5, 41.8, 41.82, 60.0, 89.0 }) {
        const double th = deg * M_PI / 180.0;
        EXPECT_NEAR(bare.reflectance(std::cos(th)), fresnel_to_air(th, n), 1e-12) << deg;
        EXPECT_EQ(remjet.reflectance(std::cos(th)), 1.0);
    }
    EXPECT_NEAR(bare.critical_radius_um(), 2.0 * t * std::tan(std::asin(1.0 / n)), 1e-9);
    EXPECT_FALSE(std::isfinite(remjet.critical_radius_um()));
    // Rbar = integral of R 2 sin cos dtheta: below theta_c the midpoint
    // rule in s = sqrt(theta_c - theta) (R's square-root kink at theta_c is
    // smooth in s), above it R = 1: cos^2(theta_c). 2e5 steps: error ~1e-12.
    // (The midpoint rule in theta itself errs by 1.8e-8 at the kink.)
    const int steps      = 200000;
    const double theta_c = std::asin(1.0 / n);
    double rbar          = std::pow(std::cos(theta_c), 2.0);
    for (int i = 0; i < steps; ++i) {
        const double sq = (i + 0.5) * std::sqrt(theta_c) / steps, th = theta_c - sq * sq;
        rbar += fresnel_to_air(th, n) * 2.0 * std::sin(th) * std::cos(th) * 2.0 * sq
                * std::sqrt(theta_c) / steps;
    }
    EXPECT_NEAR(bare.returned_fraction(), rbar, 1e-10);
    EXPECT_NEAR(bare.returned_fraction(), 0.596346, 1e-6);  // scipy.integrate.quad: 0.5963457597
    EXPECT_EQ(remjet.returned_fraction(), 1.0);
    // K against the formula written out, and the light beyond r against
    // 1 - the integral of K 2 pi r dr (the same midpoint rule in theta:
    // r = 2t tan(theta)).
    for (const BaseHalation* b : { &bare, &remjet }) {
        const bool is_bare = b == &bare;
        double inside      = 0.0;
        int i              = 0;
        for (double r : { 1.0, 100.0, 200.0, 223.0, 223.7, 230.0, 384.0, 993.0, 3000.0, 10000.0 }) {
            EXPECT_NEAR(b->density_per_um2(r),
                        profile_from_formula(r, t, n, is_bare, b->returned_fraction()),
                        1e-12 * b->density_per_um2(0.0))
                << r;
            const double th = std::atan(r / (2.0 * t));
            for (; (i + 0.5) * 0.5 * M_PI / steps < th; ++i) {
                const double a = (i + 0.5) * 0.5 * M_PI / steps;
                inside += (is_bare ? fresnel_to_air(a, n) : 1.0) * 2.0 * std::sin(a) * std::cos(a)
                          * 0.5 * M_PI / steps / b->returned_fraction();
            }
            // The steps end within half a step of theta: at most
            // K's density in theta (<= 2 / Rbar) times 0.5 * pi / 4e5.
            EXPECT_NEAR(b->light_beyond(r), 1.0 - inside, 1e-5) << r;
        }
        // The cut: kBaseHalationTail of the light lies beyond the reach.
        EXPECT_NEAR(b->light_beyond(b->reach_um()), kBaseHalationTail, 1e-15);
    }
    // remjet in closed form: K = (1 + (r / 2t)^2)^-2 / (4 pi t^2); half
    // its light within 2t, 90% within 6t (cos^2(theta) = 0.1: tan = 3).
    EXPECT_NEAR(remjet.density_per_um2(300.0), std::pow(1.0 + 1.44, -2.0) / (4.0 * M_PI * t * t),
                1e-20);
    EXPECT_NEAR(remjet.light_beyond(2.0 * t), 0.5, 1e-15);
    EXPECT_NEAR(remjet.light_beyond(6.0 * t), 0.1, 1e-15);
    // Cut where cos^2(theta) = kBaseHalationTail: 2t sqrt(99) at 1e-2.
    EXPECT_NEAR(remjet.reach_um(), 2.0 * t * std::sqrt(1.0 / kBaseHalationTail - 1.0), 1e-9);
    EXPECT_NEAR(remjet.reach_um(), 2487.47, 0.01);
}

/// The base kernel's weight for offset (i, j) by brute force: the mean
/// over the tent's four pixel squares of K cut at `cut` (and divided by
/// 1 - kBaseHalationTail) times the tent, by the midpoint rule with m x m
/// points per square.
double base_weight_numeric(const BaseHalation& b, int64_t i, int64_t j, double p, int m)
{
    double sum = 0.0;
    for (int sy = -1; sy <= 0; ++sy)
        for (int sx = -1; sx <= 0; ++sx)
            for (int v = 0; v < m; ++v)
                for (int u = 0; u < m; ++u) {
                    const double dx = (sx + (u + 0.5) / m) * p, dy = (sy + (v + 0.5) / m) * p;
                    const double r  = std::hypot(i * p + dx, j * p + dy);
                    if (r > b.reach_um())
                        continue;
                    const double tent = (1.0 - std::fabs(dx) / p) * (1.0 - std::fabs(dy) / p);
                    sum += profile_from_formula(std::max(r, 1e-9), b.thickness_um(), 1.5,
                                                std::isfinite(b.critical_radius_um()),
                                                b.returned_fraction())
                           * tent * (p / m) * (p / m);
                }
    return sum / (1.0 - kBaseHalationTail);
}

TEST(LightSpread, BaseWeightsAreTheProfileOverEachAnnulus)
{
    // Pixel weights (K against the tent of two pixel boxes, cut and
    // renormalised) against a brute-force midpoint rule of the formula
    // over the same cells, summed over 25 um annuli of cell centres in one
    // octant (the kernel is radial) from the centre out past the bright
    // ring at 2 t tan(theta_c) = 223.6 um to 600 um; 5 um pixels. The
    // reference is the limit: the midpoint rule (64 x 64 a pixel square)
    // errs by (h^2 / 24) K'' ~1e-7 of a cell where K is smooth, but in the
    // cells the critical angle's kink crosses (R rises as 1 - c
    // sqrt(theta_c - theta)) by ~h^1.5: measured 4.7e-5 of a cell at most
    // (with 256 x 256 points 6e-6, converging on the code's values), 1.0e-6
    // of an annulus; the bounds are 1e-4 and 5e-6. The code with a plain
    // 3x3 rule on the pixel squares at the ring too (no polar split) missed
    // by 2.5e-2 of a cell and 5.2e-4 of an annulus; sampling K at the
    // cells' centres, by 0.23 of a cell (at the ring).
    const double p = 5.0;
    const BaseHalation b(125.0, 1.5, RearFace::bare);
    const PixelKernel k = base_halation_pixel_kernel(b, p, 1 << 30);
    const int64_t n     = 2 * k.reach + 1;
    const auto code = [&](int64_t i, int64_t j) {
        return k.weights[(j + k.reach) * n + (i + k.reach)];
    };
    std::vector<double> code_annulus(24, 0.0), ref_annulus(24, 0.0);
    double worst_cell = 0.0, worst_point = 0.0;
    for (int64_t j = 0; j * p < 600.0; ++j)
        for (int64_t i = j; std::hypot(i, j) * p < 600.0; ++i) {
            const double d = std::hypot(i, j) * p;
            // Every cell of the ring's band, a sample of the others.
            if (!(std::fabs(d - 223.6) < 30.0 || j == 0 || i == j || (i + j) % 7 == 0))
                continue;
            const double ref = base_weight_numeric(b, i, j, p, 64);
            const double got = code(i, j);
            worst_cell       = std::max(worst_cell, std::fabs(got - ref) / ref);
            const double point = b.density_per_um2(d) * p * p / (1.0 - kBaseHalationTail);
            worst_point        = std::max(worst_point, std::fabs(point - ref) / ref);
            code_annulus[static_cast<size_t>(d / 25.0)] += got;
            ref_annulus[static_cast<size_t>(d / 25.0)] += ref;
        }
    double worst_annulus = 0.0;
    for (size_t a = 0; a < code_annulus.size(); ++a) {
        worst_annulus = std::max(worst_annulus,
                                 std::fabs(code_annulus[a] - ref_annulus[a]) / ref_annulus[a]);
        EXPECT_NEAR(code_annulus[a], ref_annulus[a], 5e-6 * ref_annulus[a]) << "annulus " << a;
    }
    EXPECT_LT(worst_cell, 1e-4);
    EXPECT_GT(worst_point, 1e-3) << "sampling K would pass too: the test could not tell";
    std::printf("base kernel, 5 um pixels: worst cell %.2e, worst annulus %.2e, "
                "point samples %.2e\n",
                worst_cell, worst_annulus, worst_point);
}

TEST(LightSpread, BaseKernelSumsToOne)
{
    // The weights are K's exact integrals (the quadrature's error, measured
    // at most 4.6e-11 at pitches from 6.08 um (a 4K frame's: 1.5e-11) to
    // 389 um, coarser than the base) over the
    // truncated kernel's analytic integral: they sum to 1 within 1e-9, bare
    // with n from 1.3 to 2, and remjet (whose shape has no n). The bright
    // ring's kink is where a plain rule on the pixel squares missed, by up
    // to 9e-5.
    for (RearFace face : { RearFace::bare, RearFace::remjet })
        for (double n_index : { 1.3, 1.5, 2.0 })
            for (double p : { 6.08, 25.0, 389.0 }) {
                if (face == RearFace::remjet && n_index != 1.5)
                    continue;
                const BaseHalation b(125.0, n_index, face);
                const PixelKernel k = base_halation_pixel_kernel(b, p, 1 << 30);
                EXPECT_NEAR(sum(k.weights), 1.0, 1e-9)
                    << name_of(face) << " n " << n_index << " pitch " << p;
                const int64_t nn = 2 * k.reach + 1;
                // Symmetric in both axes and the diagonal.
                for (int64_t j = 0; j <= k.reach; j += 7)
                    for (int64_t i = 0; i <= k.reach; i += 5) {
                        const double w = k.weights[(j + k.reach) * nn + (i + k.reach)];
                        EXPECT_EQ(w, k.weights[(-j + k.reach) * nn + (-i + k.reach)]);
                        EXPECT_EQ(w, k.weights[(i + k.reach) * nn + (j + k.reach)]);
                    }
            }
    // A uniform field: an input pixel farther than the reach from the
    // frame's edges gets exactly 1 + halation times the light (float
    // storage: within 1.2e-7, one unit in the last place, relative), as
    // Layer::uniform_field_gain says, with and without scatter. 100 um
    // pixels, reach 33 (bare) pixels; a frame of 240.
    Stock stock;
    stock.base_thickness_um = 125.0;
    for (RearFace face : { RearFace::bare, RearFace::remjet }) {
        stock.rear_face = face;
        Layer halo;
        halo.halation        = 0.25;
        halo.halation_kernel = HalationKernel::base;
        EXPECT_EQ(halo.uniform_field_gain(), 1.25);
        const int64_t w = 240;
        const std::vector<float> img(w * w, 3.0f);
        for (double scatter : { 0.0, 0.3 }) {
            halo.scatter          = scatter;
            halo.scatter_sigma_um = scatter > 0.0 ? 40.0 : 0.0;
            const auto out        = spread(halo, img, w, w, 100.0, stock);
            EXPECT_NEAR(out[120 * w + 120], 3.0 * 1.25, 1.2e-7 * 3.75) << name_of(face);
            std::printf("%s, scatter %.1f: uniform field gain 1.25 %+.1e relative\n",
                        name_of(face), scatter, out[120 * w + 120] / 3.75 - 1.0);
        }
        // The scene continued beyond the frame (edge=clamp, MODEL.md 2): a
        // uniform plate about the reach's size (4 mm; the kernel's light
        // comes from up to 3.2 mm away, much of it from the margin) gets
        // 1.25 at every pixel, its corners included: the whole kernel is
        // used. (Cut at the frame as under gate, the kernel missed up to
        // 7.0e-4 of the light, bare, 3.4e-4, remjet, measured with the
        // kernel cut at 1e-3.)
        const int64_t c = 40;
        const std::vector<float> plate(c * c, 3.0f);
        halo.scatter          = 0.3;
        halo.scatter_sigma_um = 40.0;
        const auto out        = spread(halo, plate, c, c, 100.0, stock, FrameEdge::clamp);
        double worst          = 0.0;
        for (float v : out)
            worst = std::max(worst, std::fabs(v / 3.75 - 1.0));
        EXPECT_LT(worst, 1.2e-7) << name_of(face);
    }
}

/// The radii within which `fraction` of the light that a bright square
/// adds around itself lies (the spread exposure less the input, over
/// pixels sorted by their centre's distance from the square's centre
/// (cx, cy) um, `total` the light the kernel returns), interpolated
/// between pixel distances.
std::vector<double> encircled_radii(const std::vector<float>& out, const std::vector<float>& in,
                                    int64_t w, double p, double cx, double cy, double total,
                                    const std::vector<double>& fractions)
{
    std::vector<std::pair<double, double>> px;
    for (int64_t y = 0; y < w; ++y)
        for (int64_t x = 0; x < w; ++x)
            px.push_back({ std::hypot((x + 0.5) * p - cx, (y + 0.5) * p - cy),
                           (static_cast<double>(out[y * w + x]) - in[y * w + x]) * p * p });
    std::sort(px.begin(), px.end());
    std::vector<double> radii;
    for (double f : fractions) {
        double acc = 0.0, r = std::numeric_limits<double>::quiet_NaN();  // NaN: never reached
        for (size_t i = 0; i < px.size(); ++i) {
            if (acc + px[i].second >= f * total) {
                const double prev = i ? px[i - 1].first : 0.0;
                r = prev + (px[i].first - prev) * (f * total - acc) / px[i].second;
                break;
            }
            acc += px[i].second;
        }
        radii.push_back(r);
    }
    return radii;
}

TEST(LightSpread, BaseHaloHasItsRadiusInMicrometresAtEveryPitch)
{
    // A 20 um square of light in a 2.6 mm frame on 5 um and 10 um input
    // pixels: the radii within which 50% and 90% of the light it returns
    // lies agree within one coarse pixel (10 um) between the two pitches
    // and with the profile's own (light_beyond), bare and remjet. (The
    // light beyond 1.3 mm leaves the frame: 7% bare, 4% remjet; the
    // radii count it, as fractions of all the kernel returns.)
    Stock stock;
    stock.base_thickness_um = 125.0;
    for (RearFace face : { RearFace::bare, RearFace::remjet }) {
        stock.rear_face = face;
        const BaseHalation b(stock);
        Layer halo;
        halo.halation        = 0.25;
        halo.halation_kernel = HalationKernel::base;
        std::vector<std::vector<double>> radii;
        for (double p : { 5.0, 10.0 }) {
            const int64_t w = static_cast<int64_t>(std::lround(2600.0 / p));
            const int64_t s = static_cast<int64_t>(std::lround(20.0 / p));
            const auto img  = block_image(w, w, 0.0f, w / 2 - s / 2, w / 2 - s / 2, s, 1000.0f);
            const auto out  = spread(halo, img, w, w, p, stock);
            radii.push_back(encircled_radii(out, img, w, p, 1300.0, 1300.0,
                                            0.25 * 1000.0 * 400.0, { 0.5, 0.9 }));
        }
        // The profile's: E(r) = (1 - light_beyond(r)) / (1 - tail), by bisection.
        std::vector<double> exact;
        for (double f : { 0.5, 0.9 }) {
            double lo = 0.0, hi = b.reach_um();
            for (int it = 0; it < 100; ++it) {
                const double mid = 0.5 * (lo + hi);
                ((1.0 - b.light_beyond(mid)) / (1.0 - kBaseHalationTail) < f ? lo : hi) = mid;
            }
            exact.push_back(lo);
        }
        for (size_t f = 0; f < 2; ++f) {
            EXPECT_NEAR(radii[0][f], radii[1][f], 10.0)
                << name_of(face) << " fraction " << f;
            EXPECT_NEAR(radii[1][f], exact[f], 10.0) << name_of(face) << " fraction " << f;
            std::printf("%s: %s%% of the halo within %.1f um (5 um pixels), %.1f um (10 um), "
                        "%.1f um (the profile)\n",
                        name_of(face), f ? "90" : "50", radii[0][f], radii[1][f], exact[f]);
        }
    }
}

/// The mean of (out - in) over pixels whose centre lies in each ring
/// [k dr, k dr + dr) um from (c, c) um.
std::vector<double> ring_profile(const std::vector<float>& out, const std::vector<float>& in,
                                 int64_t w, double p, double c, double dr, int rings)
{
    std::vector<double> s(static_cast<size_t>(rings), 0.0), k(static_cast<size_t>(rings), 0.0);
    for (int64_t y = 0; y < w; ++y)
        for (int64_t x = 0; x < w; ++x) {
            const size_t r
                = static_cast<size_t>(std::hypot((x + 0.5) * p - c, (y + 0.5) * p - c) / dr);
            if (r < s.size()) {
                s[r] += static_cast<double>(out[y * w + x]) - in[y * w + x];
                k[r] += 1.0;
            }
        }
    for (size_t r = 0; r < s.size(); ++r)
        s[r] /= k[r];
    return s;
}

TEST(LightSpread, BaseHaloHasNoStepAtItsRim)
{
    // The halo of a 5 um point of light (2.5 um input pixels, a 1 mm
    // frame), its mean over 5 um rings from 25 um (outside the point and
    // its pixel blur) to 450 um: the largest drop between neighbouring
    // rings, over the brightest ring. The base kernel (bare, n 1.5, 125 um:
    // its bright ring at 223.6 um) falls off smoothly past its ring:
    // measured 0.038 (as cos^4(theta): 4 r / (4 t^2 + r^2) of itself per
    // um, 4% over 5 um at the ring); a disc kernel of the same fraction and
    // the same radius drops from its plateau to nothing across its rim:
    // measured 0.647 (the pixels' tent spreads the rim over two rings).
    // The bound, 0.1, lies between the two.
    Stock stock;
    stock.base_thickness_um = 125.0;
    const double p = 2.5;
    const int64_t w = 400;
    const auto img  = block_image(w, w, 0.0f, w / 2 - 1, w / 2 - 1, 2, 1000.0f);
    Layer base, disc;
    base.halation        = disc.halation = 0.25;
    base.halation_kernel = HalationKernel::base;
    disc.halation_radius_um = BaseHalation(stock).critical_radius_um();
    double drop[2];
    for (const Layer* layer : { &base, &disc }) {
        const auto out        = spread(*layer, img, w, w, p, stock);
        const auto profile    = ring_profile(out, img, w, p, 500.0, 5.0, 90);
        double peak = 0.0, worst = 0.0;
        for (size_t r = 5; r < profile.size(); ++r)
            peak = std::max(peak, profile[r]);
        for (size_t r = 5; r + 1 < profile.size(); ++r)
            worst = std::max(worst, (profile[r] - profile[r + 1]) / peak);
        drop[layer == &disc] = worst;
    }
    std::printf("largest drop between 5 um rings over the peak: base %.3f, disc %.3f\n", drop[0],
                drop[1]);
    EXPECT_LT(drop[0], 0.1);
    EXPECT_GT(drop[1], 0.1) << "a disc passes: the test could not tell";
}

TEST(LightSpread, BaseKernelStockKeys)
{
    const auto parse = [](const std::string& top, const std::string& layer) {
        Stock s;
        return parse_stock_json("{" + top + (top.empty() ? "" : ", ")
                                    + R"("layers": [{"name": "R", )" + layer + "}]}",
                                "t.json", s);
    };
    const auto expect_error = [&](const std::string& top, const std::string& layer,
                                  const std::string& needle) {
        const Status st = parse(top, layer);
        ASSERT_FALSE(st) << top << " " << layer;
        EXPECT_NE(st.message().find(needle), std::string::npos) << st.message();
    };
    const std::string base = R"("halation": 0.2, "halation_kernel": "base")";
    EXPECT_TRUE(parse(R"("base_thickness_um": 125, "rear_face": "remjet")", base));
    expect_error("", base, "layers[0].halation = 0.2 with halation_kernel 'base' needs the stock's "
                           "base_thickness_um > 0 (it is 0)");
    expect_error(R"("base_thickness_um": 125)", base + R"(, "halation_radius_um": 220)",
                 "layers[0].halation_radius_um = 220 with halation_kernel 'base'");
    expect_error(R"("base_thickness_um": -1)", base,
                 "base_thickness_um = -1: must be in [0, 2000]");
    expect_error(R"("base_thickness_um": 125, "base_refractive_index": 1)", base,
                 "base_refractive_index = 1: must be in [1.3, 2]");
    expect_error(R"("base_thickness_um": 125, "rear_face": "foil")", base,
                 "rear_face = 'foil': must be one of 'remjet', 'bare'");
    expect_error(R"("base_thickness_mm": 0.125)", base, "unknown key 'base_thickness_mm'");
    expect_error("", R"("halation_kernel": "glow")",
                 "halation_kernel = 'glow': must be one of 'disc', 'ring', 'base'");
    // The keys round-trip, and a stock without them takes the defaults.
    Stock s, back;
    ASSERT_TRUE(parse_stock_json(R"({"base_thickness_um": 130, "base_refractive_index": 1.65,
        "rear_face": "remjet", "layers": [{"name": "R", "halation": 0.02,
        "halation_kernel": "base"}]})", "t.json", s));
    ASSERT_TRUE(parse_stock_json(stock_to_json(s), "back", back));
    EXPECT_EQ(back.base_thickness_um, 130.0);
    EXPECT_EQ(back.base_refractive_index, 1.65);
    EXPECT_EQ(back.rear_face, RearFace::remjet);
    EXPECT_EQ(back.layers[0].halation_kernel, HalationKernel::base);
    EXPECT_TRUE(back.layers[0].halates());
    EXPECT_EQ(layer_halation(back, back.layers[0]).reach_um(), BaseHalation(back).reach_um());
    const Stock defaults;
    EXPECT_EQ(defaults.base_thickness_um, 0.0);
    EXPECT_EQ(defaults.base_refractive_index, 1.5);
    EXPECT_EQ(defaults.rear_face, RearFace::bare);
}

TEST(LightSpread, ScatterMovesLightAndHalationAddsItsFraction)
{
    // A bright block far from the frame's edges (no light leaves the
    // frame): scatter keeps the total to float rounding (relative 1e-6 over
    // 16384 pixels of round-off ~6e-8 each); halation adds `halation` of it.
    const int64_t w = 128, h = 128;
    const auto img = block_image(w, h, 0.0f, 60, 60, 8, 100.0f);
    const double total = std::accumulate(img.begin(), img.end(), 0.0);
    Layer scatter;
    scatter.scatter          = 0.4;
    scatter.scatter_sigma_um = 20.0;
    const auto s = spread(scatter, img, w, h, 5.0);
    EXPECT_NEAR(std::accumulate(s.begin(), s.end(), 0.0), total, 1e-6 * total);
    EXPECT_LT(s[64 * w + 64], 100.0f);  // light left the block's centre
    EXPECT_GT(s[64 * w + 64 + 12], 0.0f);  // and arrived beside it
    Layer halo = scatter;
    halo.halation           = 0.25;
    halo.halation_radius_um = 100.0;
    halo.halation_kernel    = HalationKernel::ring;
    const auto hs = spread(halo, img, w, h, 5.0);
    EXPECT_NEAR(std::accumulate(hs.begin(), hs.end(), 0.0), 1.25 * total, 1e-6 * total);
    for (float v : hs)
        EXPECT_GE(v, 0.0f);
}

TEST(LightSpread, PixelMeansAreExact)
{
    // The same box-reconstructed image on a grid 4 times finer: the spread
    // exposure's means over the coarse pixels must agree (the weights are
    // exact pixel means of the convolved image). Tolerance: float storage
    // (6e-8 relative per value) for the closed-form Gaussian; for halation
    // also the Gauss-Legendre rule on the edge cells (measured: 1e-6 of the
    // value here; 3e-4 with one 8x8 rule per cell instead of four).
    const int64_t w = 48, h = 40, f = 4;
    const double p = 8.0;
    std::vector<float> coarse(static_cast<size_t>(w * h));
    for (int64_t y = 0; y < h; ++y)
        for (int64_t x = 0; x < w; ++x)
            coarse[static_cast<size_t>(y * w + x)]
                = static_cast<float>(1.0 + ((x * 7 + y * 13) % 11) + (x == 20 && y == 18) * 500.0);
    std::vector<float> fine(static_cast<size_t>(w * h * f * f));
    for (int64_t y = 0; y < h * f; ++y)
        for (int64_t x = 0; x < w * f; ++x)
            fine[static_cast<size_t>(y * w * f + x)] = coarse[static_cast<size_t>((y / f) * w + x / f)];
    Layer scatter;
    scatter.scatter          = 0.5;
    scatter.scatter_sigma_um = 11.0;
    Layer halo;
    halo.halation           = 0.5;
    halo.halation_radius_um = 60.0;
    for (const Layer* spreading : { &scatter, &halo }) {
        const Layer& layer     = *spreading;
        const double tolerance = layer.halation > 0.0 ? 5e-6 : 1e-6;
        const auto a = spread(layer, coarse, w, h, p);
        const auto b = spread(layer, fine, w * f, h * f, p / f);
        double worst = 0.0;
        for (int64_t y = 0; y < h; ++y)
            for (int64_t x = 0; x < w; ++x) {
                double mean = 0.0;
                for (int64_t j = 0; j < f; ++j)
                    for (int64_t i = 0; i < f; ++i)
                        mean += b[static_cast<size_t>((y * f + j) * w * f + x * f + i)];
                mean /= f * f;
                const double ref = a[static_cast<size_t>(y * w + x)];
                worst = std::max(worst, std::fabs(mean - ref) / ref);
            }
        EXPECT_LT(worst, tolerance) << "halation " << layer.halation;
    }
}

// SpreadMethod::direct (auto's and fast's Gaussian spreads) against the
// FFT (the exact engine's): the same values to rounding, at both edges, for
// a Gaussian narrower and wider than the pixel, on frames narrower than
// the kernel's reach; with a halo it runs the FFT, bit for bit.
TEST(LightSpread, DirectConvolutionIsTheFftToRounding)
{
    struct Case {
        int64_t w, h;
        double pitch_um, scatter, sigma_um;
    };
    const Case cases[] = { { 64, 48, 6.0, 1.0, 20.0 }, { 64, 48, 6.0, 0.2, 5.0 },
                           { 7, 3, 6.0, 1.0, 20.0 },   { 1, 1, 2.0, 0.5, 9.0 },
                           { 50, 1, 3.0, 0.7, 4.0 } };
    double worst = 0.0;
    for (const Case& c : cases)
        for (FrameEdge edge : { FrameEdge::clamp, FrameEdge::gate }) {
            std::vector<double> v(static_cast<size_t>(c.w * c.h));
            for (size_t i = 0; i < v.size(); ++i)
                v[i] = 0.01 + static_cast<double>((i * 7919) % 101) * (i % 13 == 0 ? 40.0 : 1.0);
            const auto fft    = spread_frame(v, c.w, c.h, c.pitch_um, c.scatter, c.sigma_um,
                                             HalationSpec(), edge, SpreadMethod::fft);
            const auto direct = spread_frame(v, c.w, c.h, c.pitch_um, c.scatter, c.sigma_um,
                                             HalationSpec(), edge, SpreadMethod::direct);
            ASSERT_EQ(fft.size(), direct.size());
            for (size_t i = 0; i < fft.size(); ++i) {
                ASSERT_GT(fft[i], 0.0);
                worst = std::max(worst, std::fabs(direct[i] - fft[i]) / fft[i]);
            }
        }
    // Double rounding of sums of at most a few hundred terms, against the
    // FFT's own round-off (~1e-15 of the largest value): 1e-12 is far above
    // both and far below float storage (6e-8).
    EXPECT_LT(worst, 1e-12);
    std::printf("largest relative difference, direct against FFT: %.3g\n", worst);
    HalationSpec halo;
    halo.fraction  = 0.1;
    halo.radius_um = 30.0;
    const std::vector<double> v(40 * 30, 2.0);
    EXPECT_EQ(spread_frame(v, 40, 30, 5.0, 0.3, 5.0, halo, FrameEdge::clamp, SpreadMethod::direct),
              spread_frame(v, 40, 30, 5.0, 0.3, 5.0, halo, FrameEdge::clamp, SpreadMethod::fft));
    EXPECT_EQ(spread_method(SpreadMethod::direct, true), SpreadMethod::fft);
    EXPECT_EQ(spread_method(SpreadMethod::direct, false), SpreadMethod::direct);
}

TEST(LightSpread, AKernelFarWiderThanThePixelsIsAnError)
{
    // A 5 mm halo on 0.01 um pixels: 5e5 pixels of reach. Refused before
    // anything is allocated, with the keys to change. The base kernel's
    // offsets beyond the frame are left out, so it needs a frame that
    // large: 40000 pixels of 0.25 um, its reach (3.2 mm: 12900 pixels) on
    // top, 6.8e8 values.
    Layer halo;
    halo.halation           = 0.5;
    halo.halation_radius_um = 5000.0;
    const std::vector<float> img(16, 1.0f);
    try {
        spread(halo, img, 4, 4, 0.01);
        FAIL() << "no error";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("halation_radius_um"), std::string::npos) << e.what();
    }
    HalationSpec base;
    base.fraction          = 0.5;
    base.kernel            = HalationKernel::base;
    base.base_thickness_um = 125.0;
    try {
        spread_frame(std::vector<double>(40000, 1.0), 40000, 1, 0.25, 0.0, 0.0, base,
                     FrameEdge::gate);
        FAIL() << "no error";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("base_thickness_um"), std::string::npos) << e.what();
    }
}

// Renders.

/// A dark frame (0.18 * 2^-6) with one input pixel 12 stops over grey in
/// its middle, 1.2 mm wide in 12.5 um input pixels; the colour preset with
/// halation (and scatter) on its red layer.
TestScene point_light_scene()
{
    TestScene s;
    EXPECT_TRUE(load_stock("color-negative", s.stock));
    Layer& red             = s.stock.layers[0];
    red.halation           = 0.5;
    red.halation_radius_um = 200.0;
    red.scatter            = 0.2;
    red.scatter_sigma_um   = 4.0;
    s.scene.width_mm = 1.2;
    const int64_t n        = 96;
    s.pixels               = block_image(n, n, static_cast<float>(0.18 / 64), n / 2, n / 2, 1,
                                         static_cast<float>(0.18 * 4096));
    s.view                 = ImageView { s.pixels.data(), n, n, 1 };
    return s;
}

TEST(LightSpread, RendersAreBitIdenticalForThreadsTilesAndRois)
{
    // A ROI beside the point: its halo (200 um = 16 pixels) reaches in
    // from outside; it reads the whole frame (the spread is computed over
    // it). The same with the base kernel (a bare 100 um base: a ring at
    // 179 um, a glow over the whole frame).
    TestScene base = point_light_scene();
    base.stock.base_thickness_um            = 100.0;
    base.stock.layers[0].halation_kernel    = HalationKernel::base;
    base.stock.layers[0].halation_radius_um = 0.0;
    ASSERT_TRUE(base.stock.validate());
    const Roi roi { 50, 30, 70, 45 };
    for (const TestScene& s : { point_light_scene(), base })
    for (Engine engine : { Engine::exact, Engine::automatic }) {
        expect_deterministic(s, engine, roi);
        RenderSettings part;
        part.roi = roi;
        Roi window;
        ASSERT_TRUE(required_input_window(s.stock, s.scene, 96, 96, part, window));
        EXPECT_EQ(window.x_begin, 0);
        EXPECT_EQ(window.y_begin, 0);
        EXPECT_EQ(window.x_end, 96);
        EXPECT_EQ(window.y_end, 96);
    }
}

TEST(LightSpread, LayersSharingAHaloTransformGetTheImageOfTheirOwn)
{
    // Three layers of one stock on a bare 100 um base: R and G share the
    // kernel and the period (the same Gaussian reach) with other strengths,
    // B scatters wider (another period, by a few pixels of a halo's 280).
    // Spread with one HaloTransforms for all, from two threads at once or
    // in turn, each is bit for bit what it is with a transform of its own
    // (in double: the far tail a wrong period moves is below float's
    // rounding). spread_exposure's image is that spread_frame of its
    // exposure values (which it held as a copy before it read the exposure
    // in place), stored as float.
    Stock stock;
    stock.base_thickness_um = 100.0;
    Layer r, g, b;
    r.scatter = 0.3, r.scatter_sigma_um = 5.0, r.halation = 0.02;
    g.scatter = 0.2, g.scatter_sigma_um = 5.0, g.halation = 0.004;
    b.scatter = 0.3, b.scatter_sigma_um = 12.0, b.halation = 0.01;
    for (Layer* l : { &r, &g, &b })
        l->halation_kernel = HalationKernel::base;
    const int64_t w = 96, h = 64;
    const double pitch_um = 7.0;
    // A ramp up to the edges (a period too short for a kernel's reach
    // would wrap one edge's light onto the other) and a bright block.
    auto img = block_image(w, h, 0.0f, 40, 20, 6, 30.0f);
    for (int64_t y = 0; y < h; ++y)
        for (int64_t x = 0; x < w; ++x)
            img[static_cast<size_t>(y * w + x)] += 0.05f * static_cast<float>(1 + x + 2 * y);
    const ImageView view { img.data(), w, h, 1 };
    const std::vector<Layer> layers { r, g, b };
    for (FrameEdge edge : { FrameEdge::clamp, FrameEdge::gate }) {
        const LayerExposure exposure(view, { 1.0, 0.0, 0.0 }, pitch_um,
                                     std::numeric_limits<double>::infinity(), edge);
        std::vector<double> values(static_cast<size_t>(w * h));
        for (int64_t y = 0; y < h; ++y)
            for (int64_t x = 0; x < w; ++x)
                values[static_cast<size_t>(y * w + x)] = exposure.value(x, y);
        const auto frame = [&](const Layer& l, HaloTransforms* shared) {
            return spread_frame(values, w, h, pitch_um, l.scatter, l.scatter_sigma_um,
                                layer_halation(stock, l), edge, SpreadMethod::fft, shared);
        };
        std::vector<std::vector<double>> own, parallel(3), in_turn;
        HaloTransforms together, one_by_one;
        std::thread other([&] { parallel[1] = frame(g, &together); });
        parallel[0] = frame(r, &together);
        other.join();
        parallel[2] = frame(b, &together);
        for (const Layer& l : layers) {
            own.push_back(frame(l, nullptr));
            in_turn.push_back(frame(l, &one_by_one));
            const std::vector<float> as_float(own.back().begin(), own.back().end());
            EXPECT_EQ(spread_exposure(stock, l, exposure, w, h, pitch_um), as_float);
        }
        EXPECT_EQ(parallel, own);
        EXPECT_EQ(in_turn, own);
        EXPECT_NE(own[0], own[1]);  // the strengths differ, and so do the images
        // The renderer's call: floats, two layers at once, one transform.
        HaloTransforms layers_of_a_frame;
        std::vector<float> g_shared;
        std::thread second([&] {
            g_shared = spread_exposure(stock, g, exposure, w, h, pitch_um, SpreadMethod::fft,
                                       &layers_of_a_frame);
        });
        EXPECT_EQ(spread_exposure(stock, r, exposure, w, h, pitch_um, SpreadMethod::fft,
                                  &layers_of_a_frame),
                  spread_exposure(stock, r, exposure, w, h, pitch_um));
        second.join();
        EXPECT_EQ(g_shared, spread_exposure(stock, g, exposure, w, h, pitch_um));
    }
}

TEST(LightSpread, ZeroStrengthIsNoSpread)
{
    // Radii without strength spread nothing: bit-identical to the stock
    // without the keys, in every engine.
    TestScene plain = point_light_scene();
    for (Layer& l : plain.stock.layers) {
        l.scatter = l.scatter_sigma_um = l.halation = l.halation_radius_um = 0.0;
        l.halation_kernel = HalationKernel::disc;
    }
    TestScene zero = plain;
    for (Layer& l : zero.stock.layers) {
        l.scatter_sigma_um   = 30.0;
        l.halation_radius_um = 300.0;
        l.halation_kernel    = HalationKernel::ring;
    }
    for (Engine engine : { Engine::exact, Engine::automatic, Engine::fast }) {
        RenderSettings settings;
        settings.engine = engine;
        EXPECT_TRUE(bit_identical(render_scene(plain, settings), render_scene(zero, settings)))
            << name_of(engine);
    }
}

/// Mean and standard error of the red layer's density over scan pixels
/// whose centre lies between r0 and r1 micrometres from the frame's centre.
/// Standard error from the pixels' variance, with pixels in blocks of 4x4
/// as the unit (neighbouring pixels share grains: blocks of 4 pixels, wider
/// than a grain, are nearly independent).
std::pair<double, double> ring_density(const std::vector<float>& d, int64_t n, double pitch_um,
                                       double r0_um, double r1_um)
{
    const double c = 0.5 * n * pitch_um;
    std::vector<double> blocks;
    for (int64_t by = 0; by < n; by += 4)
        for (int64_t bx = 0; bx < n; bx += 4) {
            double s = 0.0;
            int k    = 0;
            for (int64_t y = by; y < by + 4; ++y)
                for (int64_t x = bx; x < bx + 4; ++x) {
                    const double r = std::hypot((x + 0.5) * pitch_um - c, (y + 0.5) * pitch_um - c);
                    if (r >= r0_um && r < r1_um) {
                        s += d[static_cast<size_t>((y * n + x) * 3)];
                        ++k;
                    }
                }
            if (k == 16)
                blocks.push_back(s / k);
        }
    return mean_and_standard_error(blocks);
}

TEST(LightSpread, TheHaloHasItsRadiusInMicrometresAtEveryScan)
{
    // Two scans of the same frame (9.4 and 6.25 um pixels): inside the
    // 200 um halo the red layer is denser than the ground (> 10 standard
    // errors); just outside it (1.15 to 1.6 radii) it is the ground (within
    // 4 standard errors of the difference), so the halo ends at its radius
    // in micrometres whatever the scan.
    const TestScene s = point_light_scene();
    for (int64_t scan : { 128, 192 }) {
        RenderSettings settings;
        settings.scan_width  = scan;
        settings.scan_height = scan;
        const auto d         = render_scene(s, settings);
        const double pitch   = 1200.0 / scan;
        const auto inside    = ring_density(d, scan, pitch, 60.0, 170.0);
        const auto outside   = ring_density(d, scan, pitch, 230.0, 320.0);
        const auto ground    = ring_density(d, scan, pitch, 420.0, 600.0);
        const auto se = [](std::pair<double, double> a, std::pair<double, double> b) {
            return std::hypot(a.second, b.second);
        };
        EXPECT_GT(inside.first - ground.first, 10.0 * se(inside, ground)) << "scan " << scan;
        EXPECT_LT(std::fabs(outside.first - ground.first), 4.0 * se(outside, ground))
            << "scan " << scan;
    }
}

}  // namespace
}  // namespace filmgrain
