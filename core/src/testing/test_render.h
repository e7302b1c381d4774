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

/// The determinism guarantee for `engine`: 1 thread with 64-pixel tiles and
/// 2 threads with 7-pixel tiles give the same bits, and a render of `roi`
/// (2 threads, 7-pixel tiles) is a crop of the full one. The scan is the
/// input's size. `scale`: the scale setting (unset: the engine's choice).
inline void expect_deterministic(const TestScene& s, Engine engine, const Roi& roi,
                                 std::optional<ScaleMethod> scale = {})
{
    RenderSettings one;
    one.engine       = engine;
    one.scale        = scale;
    one.nthreads     = 1;
    one.tile_size_px = 64;
    RenderSettings two = one;
    two.nthreads       = 2;
    two.tile_size_px   = 7;
    const auto a = render_scene(s, one);
    EXPECT_TRUE(bit_identical(a, render_scene(s, two))) << engine_name(engine);
    RenderSettings part = two;
    part.roi            = roi;
    const auto crop     = render_scene(s, part);
    const size_t nl     = s.stock.layers.size();
    for (int64_t y = roi.y_begin; y < roi.y_end; ++y)
        for (int64_t x = roi.x_begin; x < roi.x_end; ++x)
            for (size_t l = 0; l < nl; ++l)
                ASSERT_EQ(a[static_cast<size_t>(y * s.view.width + x) * nl + l],
                          crop[static_cast<size_t>((y - roi.y_begin) * roi.width()
                                                   + (x - roi.x_begin))
                                   * nl
                               + l])
                    << engine_name(engine) << " " << x << "," << y << " layer " << l;
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
