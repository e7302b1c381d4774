// Test helper: a scene (stock, scene settings, input pixels) and its render,
// the determinism check every render-level feature test makes, and the
// mean of independent units with its standard error.
#pragma once

#include <cmath>
#include <cstring>
#include <utility>
#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "filmgrain/render.h"

namespace filmgrain {

struct TestScene {
    Stock stock;
    SceneSettings scene;
    std::vector<float> pixels;
    ImageView view;
};

/// The render of `s` (its ROI or the whole scan), densities layer by layer
/// per pixel; a failed render fails the test.
inline std::vector<float> render_scene(const TestScene& s, const RenderSettings& settings,
                                       RenderStats* stats = nullptr)
{
    ScanGeometry scan;
    EXPECT_TRUE(scan_geometry(s.scene, s.view.width, s.view.height, settings, scan));
    const Roi roi = settings.roi.empty() ? Roi { 0, 0, scan.width, scan.height } : settings.roi;
    std::vector<float> out(static_cast<size_t>(roi.npixels()) * s.stock.layers.size(), -1.0f);
    const Status st = render_negative(s.stock, s.scene, s.view, settings, out.data(), stats);
    EXPECT_TRUE(st) << st.message();
    return out;
}

inline bool bit_identical(const std::vector<float>& a, const std::vector<float>& b)
{
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

/// The determinism guarantee for `base` (its engine, scale, scan and ROI;
/// an empty ROI: the whole scan): 1 thread with 64-pixel tiles and 2
/// threads with `tile_px`-pixel tiles give the same bits, and a render of
/// `roi` (2 threads, the same tiles) is a crop of the whole. Returns the
/// whole render.
inline std::vector<float> expect_deterministic(const TestScene& s, const RenderSettings& base,
                                               const Roi& roi, int tile_px = 7)
{
    RenderSettings one = base;
    one.nthreads       = 1;
    one.tile_size_px   = 64;
    RenderSettings two = one;
    two.nthreads       = 2;
    two.tile_size_px   = tile_px;
    const std::vector<float> a = render_scene(s, one);
    EXPECT_TRUE(bit_identical(a, render_scene(s, two))) << name_of(base.engine);
    ScanGeometry scan;
    EXPECT_TRUE(scan_geometry(s.scene, s.view.width, s.view.height, base, scan));
    const Roi whole = base.roi.empty() ? Roi { 0, 0, scan.width, scan.height } : base.roi;
    RenderSettings part = two;
    part.roi            = roi;
    const auto crop     = render_scene(s, part);
    const size_t nl     = s.stock.layers.size();
    for (int64_t y = roi.y_begin; y < roi.y_end; ++y)
        for (int64_t x = roi.x_begin; x < roi.x_end; ++x)
            for (size_t l = 0; l < nl; ++l) {
                const auto at_whole
                    = static_cast<size_t>((y - whole.y_begin) * whole.width() + x - whole.x_begin);
                const auto at_crop
                    = static_cast<size_t>((y - roi.y_begin) * roi.width() + x - roi.x_begin);
                if (a[at_whole * nl + l] != crop[at_crop * nl + l]) {
                    ADD_FAILURE() << name_of(base.engine) << " " << x << "," << y
                                  << " layer " << l << ": " << a[at_whole * nl + l]
                                  << " in the whole, " << crop[at_crop * nl + l] << " in the crop";
                    return a;
                }
            }
    return a;
}

/// The same for `engine` (and `scale`; unset: the engine's choice) over
/// the whole scan, the input's size.
inline void expect_deterministic(const TestScene& s, Engine engine, const Roi& roi,
                                 std::optional<ScaleMethod> scale = {})
{
    RenderSettings base;
    base.engine = engine;
    base.scale  = scale;
    expect_deterministic(s, base, roi);
}

/// The mean of independent units (e.g. block means) and its standard error
/// (sample standard deviation over the square root of their count).
inline std::pair<double, double> mean_and_standard_error(const std::vector<double>& units)
{
    double mean = 0.0, var = 0.0;
    for (double u : units)
        mean += u;
    mean /= static_cast<double>(units.size());
    for (double u : units)
        var += (u - mean) * (u - mean);
    var /= static_cast<double>(units.size() - 1);
    return { mean, std::sqrt(var / static_cast<double>(units.size())) };
}

}  // namespace filmgrain
