// Hang guard: plates that leave a layer without light (a black frame, a
// frame with one unlit channel, frames of NaN or of negative values only)
// on every built-in stock, at scans of 16, 64 and 256 pixels across a Super
// 35 frame, with engines auto and fast. Such a layer once made auto and fast
// generate every grain of the frame (about 5e10 on the VISION3 stocks: an
// hour or more a frame); now it takes the fog's path (KineticsMethod::fog)
// or its pixel scale, whichever the planner estimates cheaper.
//
// Asserted: each stock's renders of one plate and engine finish within a
// deadline in a child process (deadline.h: a hang is killed, not waited
// for); every density is finite and at least the layer's base density;
// each layer no light reaches takes the fog's path; a layer that fog alone
// develops reads, over the frame, the fog's expected density within 5% of
// its net density (the tolerance is far wider than the per-pixel noise over
// these many pixels; it catches a fog path that dropped the fog, or a
// layer drawn as if lit).
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "deadline.h"
#include "filmgrain/expected_curve.h"
#include "filmgrain/render.h"

namespace filmgrain::stability {
namespace {

enum class PlateKind { black, red_only, nan_only, negative_only };

const char* plate_name(PlateKind kind)
{
    switch (kind) {
    case PlateKind::black: return "black";
    case PlateKind::red_only: return "red_only";
    case PlateKind::nan_only: return "nan_only";
    case PlateKind::negative_only: return "negative_only";
    }
    return "?";
}

/// A 64x48 plate of one value per channel: (0.18, 0, 0) for red_only (the
/// layers that do not see red are unlit), NaN or -1 in every channel for
/// the others.
std::vector<float> plate_pixels(PlateKind kind)
{
    const float nan = std::numeric_limits<float>::quiet_NaN();
    float rgb[3] = { 0.0f, 0.0f, 0.0f };
    if (kind == PlateKind::red_only)
        rgb[0] = 0.18f;
    for (float& v : rgb)
        v = kind == PlateKind::nan_only ? nan : kind == PlateKind::negative_only ? -1.0f : v;
    std::vector<float> px(64 * 48 * 3);
    for (size_t i = 0; i < px.size(); ++i)
        px[i] = rgb[i % 3];
    return px;
}

/// Seconds the renders of one stock, plate and engine (three scans) may
/// take. In Release they take 1-5 s on two cores, most of it the lit
/// layers' tables (red_only) or the pixel models; the sanitizer build
/// (scripts/sanitize, no table cache) is several times slower. A hang of
/// the kind this guards against takes an hour.
constexpr double kDeadlineSeconds = 120.0;

struct Case {
    std::string stock;
    PlateKind plate;
    Engine engine;
};

class UnlitPlate : public ::testing::TestWithParam<Case> {};

/// The renders of a case, in the calling (child) process: true when every
/// check holds (failures are printed: the child's gtest state is lost).
bool render_case(const Case& c)
{
    Stock stock;
    if (!load_stock(c.stock, stock))
        return false;
    const std::vector<float> px = plate_pixels(c.plate);
    const ImageView view { px.data(), 64, 48, 3 };
    // The fog's expected density of each layer: its expected curve at zero
    // exposure, D-min (the Boolean model, MODEL.md 5 and 8; inhibited by the
    // other layers' fog where the stock inhibits, MODEL.md 10).
    ExpectedCurveOptions fog_only;
    fog_only.fog_only = true;
    std::vector<ExpectedCurve> curves;
    if (Status s = expected_curves(stock, SceneSettings {}, fog_only, curves); !s) {
        std::fprintf(stderr, "%s: %s\n", c.stock.c_str(), s.message().c_str());
        return false;
    }
    bool ok = true;
    for (int64_t scan : { 16, 64, 256 }) {
        RenderSettings settings;
        settings.engine     = c.engine;
        settings.scan_width = scan;
        ScanGeometry geometry;
        if (!scan_geometry(SceneSettings {}, 64, 48, settings, geometry))
            return false;
        const size_t nl = stock.layers.size();
        std::vector<float> density(static_cast<size_t>(geometry.width * geometry.height) * nl);
        RenderStats stats;
        const Status s = render_negative(stock, SceneSettings {}, view, settings, density.data(),
                                         &stats);
        if (!s) {
            std::fprintf(stderr, "%s scan %lld: %s\n", c.stock.c_str(),
                         static_cast<long long>(scan), s.message().c_str());
            return false;
        }
        std::fprintf(stderr, "%s %s %s scan %lld: simulated in %.2f s\n", c.stock.c_str(),
                     plate_name(c.plate), name_of(c.engine), static_cast<long long>(scan),
                     stats.simulate_seconds);
        for (size_t i = 0; i < density.size(); ++i)
            if (!std::isfinite(density[i])
                || density[i] < static_cast<float>(stock.layer_base_density(i % nl))) {
                std::fprintf(stderr, "density[%zu] = %g\n", i, density[i]);
                return false;
            }
        for (size_t l = 0; l < nl; ++l) {
            const LayerStats& ls = stats.layers[l];
            const bool unlit     = c.plate != PlateKind::red_only
                               || (stock.layers[l].sensitivity[0] == 0.0
                                   && !stock.layers[l].spreads_light() && !stock.inhibits());
            if (!unlit)
                continue;
            if (ls.path.find("kinetics=fog") == std::string::npos) {
                std::fprintf(stderr, "layer %s: path '%s' is not the fog's\n", ls.name.c_str(),
                             ls.path.c_str());
                ok = false;
            }
            // Only fog: the mean density is the fog's (the mean of -log10 T
            // over pixels lies a little above -log10 of the mean T where
            // pixels are small and noisy; 5% of the net density covers it
            // at these pixel sizes).
            const double base = stock.layer_base_density(l);
            const double fog  = curves[l].min_density();
            if (std::fabs(ls.mean_density - fog) > 0.05 * (fog - base) + 0.002) {
                std::fprintf(stderr, "layer %s scan %lld: mean density %.4f, fog's %.4f\n",
                             ls.name.c_str(), static_cast<long long>(scan), ls.mean_density,
                             fog);
                ok = false;
            }
        }
    }
    return ok;
}

TEST_P(UnlitPlate, RendersInTimeWithTheFogsDensity)
{
    const Case c = GetParam();
    EXPECT_TRUE(finishes_within(kDeadlineSeconds, [&] { return render_case(c); }))
        << c.stock << " " << plate_name(c.plate) << " " << name_of(c.engine);
}

std::vector<Case> all_cases()
{
    std::vector<Case> out;
    for (const std::string& stock : preset_names())
        for (PlateKind plate : { PlateKind::black, PlateKind::red_only, PlateKind::nan_only,
                                 PlateKind::negative_only })
            for (Engine engine : { Engine::automatic, Engine::fast })
                out.push_back({ stock, plate, engine });
    return out;
}

std::string case_name(const ::testing::TestParamInfo<Case>& info)
{
    std::string name = info.param.stock + "_" + plate_name(info.param.plate) + "_"
                       + name_of(info.param.engine);
    for (char& ch : name)
        if (!std::isalnum(static_cast<unsigned char>(ch)))
            ch = '_';
    return name;
}

INSTANTIATE_TEST_SUITE_P(EveryStock, UnlitPlate, ::testing::ValuesIn(all_cases()), case_name);

}  // namespace
}  // namespace filmgrain::stability
