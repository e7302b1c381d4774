// Tests of the planner's choices (engine_plan.h): what it plans, not what
// --stats says of it.
#include "engine/engine_plan.h"

#include <cmath>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "filmgrain/render.h"

namespace filmgrain {
namespace {

/// A plate of `w` x `h` pixels of one colour.
struct Plate {
    std::vector<float> pixels;
    ImageView view;
    Plate(int64_t w, int64_t h, float r, float g, float b)
        : pixels(static_cast<size_t>(w * h * 3))
    {
        for (size_t i = 0; i < pixels.size(); i += 3) {
            pixels[i]     = r;
            pixels[i + 1] = g;
            pixels[i + 2] = b;
        }
        view = ImageView { pixels.data(), w, h, 3 };
    }
};

/// The plan of a render of `plate` (the whole scan, or `roi`).
std::vector<LayerPlan> plan_of(const Stock& stock, const SceneSettings& scene, const Plate& plate,
                               const RenderSettings& settings = {}, Roi roi = {})
{
    FrameGeometry frame;
    EXPECT_TRUE(FrameGeometry::make(scene.width_mm, plate.view.width, plate.view.height,
                                    settings.scan_width, settings.scan_height, frame));
    if (roi.empty())
        roi = Roi { 0, 0, frame.scan_width, frame.scan_height };
    std::vector<LayerPlan> plan;
    const Status s = plan_layers(stock, scene, plate.view, frame, roi, settings, plan);
    EXPECT_TRUE(s) << s.message();
    return plan;
}

bool all_fog(const LayerPlan& plan)
{
    for (const PopulationPlan& pp : plan.populations)
        if (pp.kinetics != KineticsMethod::fog)
            return false;
    return !plan.populations.empty();
}

TEST(EnginePlan, AnUnlitLayerGeneratesOnlyItsFogsGrainsWhereThatIsCheapest)
{
    // A 1.2 mm frame of the paper's colour stock, black: few fog grains
    // (f n = 0.016 per um^2), cheaper than a pixel model's build.
    Stock stock;
    ASSERT_TRUE(load_stock("color-negative", stock));
    SceneSettings scene;
    scene.width_mm = 1.2;
    const Plate black(48, 32, 0.0f, 0.0f, 0.0f);
    for (Engine engine : { Engine::automatic, Engine::fast }) {
        RenderSettings settings;
        settings.engine = engine;
        for (const LayerPlan& plan : plan_of(stock, scene, black, settings)) {
            EXPECT_TRUE(plan.unlit);
            EXPECT_TRUE(all_fog(plan));
            EXPECT_EQ(plan.pixel_model, nullptr);
            for (const PopulationPlan& pp : plan.populations) {
                ASSERT_NE(pp.fast, nullptr);
                // The thinned process: f times the grains.
                double per_um2 = 0.0;
                for (const PopulationGrains::Bin& bin : pp.grains.bins())
                    per_um2 += bin.grains_per_um2;
                const double f = 1 - std::exp(-stock.development_time_s / stock.fog_tau_s);
                EXPECT_NEAR(per_um2, f * stock.layers[0].populations[&pp - &plan.populations[0]]
                                             .grains_per_um2,
                            1e-12);
            }
            EXPECT_GT(plan.estimated_seconds, 0.0);
            EXPECT_TRUE(plan.notes.fog_alone);
            EXPECT_TRUE(plan.notes.kinetics.empty());
            EXPECT_FALSE(plan.notes.pixel_scale);
            if (engine == Engine::automatic) {  // chosen by cost: the grains
                ASSERT_TRUE(plan.notes.unlit_scale);
                EXPECT_LE(plan.notes.unlit_scale->grain_s, plan.notes.unlit_scale->pixel_s);
            }
        }
    }
    // The exact engine is the reference: every grain, its chain.
    RenderSettings exact;
    exact.engine = Engine::exact;
    for (const LayerPlan& plan : plan_of(stock, scene, black, exact)) {
        EXPECT_FALSE(plan.unlit);
        for (const PopulationPlan& pp : plan.populations)
            EXPECT_EQ(pp.kinetics, KineticsMethod::chain);
    }
}

TEST(EnginePlan, AnUnlitLayerOfAFineStockTakesThePixelScale)
{
    // A Super 35 frame of vision3-500t at 64x48, black: ~3.5e8 fog grains a
    // layer, far dearer than its 3072 pixels at pixel scale.
    Stock stock;
    ASSERT_TRUE(load_stock("vision3-500t", stock));
    const Plate black(64, 48, 0.0f, 0.0f, 0.0f);
    const std::vector<LayerPlan> plans = plan_of(stock, SceneSettings {}, black);
    const double f = 1 - std::exp(-stock.development_time_s / stock.fog_tau_s);
    const double pixel_um2 = std::pow(24.89e3 / 64, 2);
    for (size_t l = 0; l < plans.size(); ++l) {
        const LayerPlan& plan = plans[l];
        EXPECT_TRUE(plan.unlit);
        EXPECT_TRUE(all_fog(plan));
        ASSERT_NE(plan.pixel_model, nullptr);
        // Its model at zero exposure is the fog's: f n developed centres
        // per square micrometre (MODEL.md 4 with n4 = 0).
        double n = 0.0;
        for (const Population& pop : stock.layers[l].populations)
            n += pop.grains_per_um2;
        EXPECT_NEAR(plan.pixel_model->at(0.0).developed_per_pixel / (f * n * pixel_um2), 1.0,
                    1e-9);
        // Chosen by cost, and said so.
        EXPECT_TRUE(plan.notes.fog_alone);
        ASSERT_TRUE(plan.notes.unlit_scale);
        EXPECT_GT(plan.notes.unlit_scale->grain_s, plan.notes.unlit_scale->pixel_s);
        ASSERT_TRUE(plan.notes.pixel_scale);
        EXPECT_NEAR(plan.notes.pixel_scale->pitch_um, std::sqrt(pixel_um2), 1e-9);
        EXPECT_NEAR(plan.notes.pixel_scale->fog_grains / (f * n * pixel_um2), 1.0, 1e-9);
    }
}

TEST(EnginePlan, TheNotesSayWhatTheKineticsChoosersFound)
{
    // A grey plate of the paper stock: each population's note says what
    // its kinetics became: the chain on a 0.2 mm frame, whose few grains
    // cost less than a table; a table on a Super 35 frame.
    Stock stock;
    ASSERT_TRUE(load_stock("paper", stock));
    SceneSettings scene;
    const Plate grey(48, 32, 0.18f, 0.18f, 0.18f);
    using Kind = PlanNotes::Kinetics::Kind;
    for (const auto& [width_mm, kind] :
         { std::pair { 0.2, Kind::table_refused }, std::pair { 24.89, Kind::table } }) {
        scene.width_mm = width_mm;
        for (const LayerPlan& plan : plan_of(stock, scene, grey)) {
            ASSERT_EQ(plan.notes.kinetics.size(), plan.populations.size());
            for (const PlanNotes::Kinetics& note : plan.notes.kinetics) {
                const PopulationPlan& pp = plan.populations.at(note.population);
                EXPECT_EQ(note.kind, kind) << width_mm;
                EXPECT_EQ(note.kind == Kind::table, pp.table != nullptr) << width_mm;
                if (note.kind == Kind::table_refused) {
                    EXPECT_EQ(pp.kinetics, KineticsMethod::early_stop);
                    EXPECT_GT(note.grain_steps, 0.0);
                }
            }
            EXPECT_FALSE(plan.notes.fog_alone);
        }
    }
    scene.width_mm = 1.2;
    // Sizes that change the rates: no table for any population, said so
    // for each, in order.
    for (Layer& layer : stock.layers)
        for (Population& pop : layer.populations)
            pop.rate_area_exponent = 0.5;
    for (const LayerPlan& plan : plan_of(stock, scene, grey)) {
        ASSERT_EQ(plan.notes.kinetics.size(), plan.populations.size());
        for (size_t p = 0; p < plan.populations.size(); ++p) {
            EXPECT_EQ(plan.notes.kinetics[p].kind, Kind::size_dependent);
            EXPECT_EQ(plan.notes.kinetics[p].population, p);
            EXPECT_EQ(plan.populations[p].kinetics, KineticsMethod::early_stop);
        }
    }
}

TEST(EnginePlan, OnlyTheUnlitLayersTakeTheFogPath)
{
    // Layers reading only their own channel; red light only.
    Stock stock;
    ASSERT_TRUE(load_stock("color-negative", stock));
    stock.layers[0].sensitivity = { 1.0, 0.0, 0.0 };
    stock.layers[1].sensitivity = { 0.0, 1.0, 0.0 };
    stock.layers[2].sensitivity = { 0.0, 0.0, 1.0 };
    SceneSettings scene;
    scene.width_mm = 1.2;
    const Plate red(48, 32, 0.18f, 0.0f, 0.0f);
    const std::vector<LayerPlan> plan = plan_of(stock, scene, red);
    EXPECT_FALSE(plan[0].unlit);
    for (const PopulationPlan& pp : plan[0].populations)
        EXPECT_NE(pp.kinetics, KineticsMethod::fog);
    EXPECT_TRUE(plan[1].unlit && all_fog(plan[1]));
    EXPECT_TRUE(plan[2].unlit && all_fog(plan[2]));
}

TEST(EnginePlan, FramesAndSeedsShareOneDevelopTable)
{
    // The P(develop | N) table's stream does not depend on the seed or the
    // frame: every frame of a sequence reads the same table (its error the
    // same on every frame; built once per process). Asserted on the tables
    // the plans hold, value for value (their serialisation).
    Stock stock;
    ASSERT_TRUE(load_stock("color-negative", stock));
    RenderSettings settings;
    settings.kinetics = KineticsMethod::table;
    const Plate grey(48, 32, 0.18f, 0.18f, 0.18f);
    const auto tables = [&](uint64_t seed, int64_t frame) {
        SceneSettings scene;
        scene.width_mm = 1.2;
        scene.seed           = seed;
        scene.frame          = frame;
        std::vector<std::string> out;
        for (const LayerPlan& layer : plan_of(stock, scene, grey, settings))
            for (const PopulationPlan& pp : layer.populations) {
                EXPECT_EQ(pp.kinetics, KineticsMethod::table);
                EXPECT_TRUE(pp.table);
                out.push_back(pp.table ? pp.table->serialize() : std::string());
            }
        return out;
    };
    const std::vector<std::string> a = tables(7, 1001);
    ASSERT_FALSE(a.empty());
    EXPECT_EQ(tables(7, 1002), a);
    EXPECT_EQ(tables(8, 1001), a);
}

TEST(EnginePlan, WhereTheRenderReadsTheWholeFrameAROIDecidesAsTheFrameDoes)
{
    // vision3-500t spreads light, so a render reads the whole frame
    // (read_region): one lit pixel far from a ROI makes its layers lit
    // there as in the full render (whose pixels the ROI must reproduce).
    Stock stock;
    ASSERT_TRUE(load_stock("vision3-500t", stock));
    Plate plate(64, 48, 0.0f, 0.0f, 0.0f);
    for (int c = 0; c < 3; ++c)
        plate.pixels[c] = 0.18f;  // pixel (0, 0)
    const Roi far { 48, 32, 64, 48 };
    for (const LayerPlan& plan : plan_of(stock, SceneSettings {}, plate, {}, far))
        EXPECT_FALSE(plan.unlit);
}

TEST(EnginePlan, ALayerWithTooFewGrainsAtFogIsMixedWithASampledLaw)
{
    // VISION3 500T in 3.06 um pixels (a 16 mm frame's, scanned 4K wide):
    // its blue fog develops about 2.4 grains a pixel, too few for the
    // two-moment pixel law, its red and green 7.4 and 6.6. auto and
    // scale=mixed draw at pixel scale, from a sampled law's shape, the
    // blue pixels whose exposure develops enough and keep the grains'
    // image for the others, and take red and green wholly at pixel scale;
    // scale=pixel takes blue wholly at pixel scale, shaped. A silver layer
    // as sparse has no sampled law: auto keeps its grains.
    Stock stock;
    ASSERT_TRUE(load_stock("vision3-500t", stock));
    SceneSettings scene;
    scene.width_mm = 256 * 3.06e-3;
    const Plate grey(256, 64, 0.18f, 0.18f, 0.18f);
    RenderSettings mixed;
    mixed.scale = ScaleMethod::mixed;
    for (const std::vector<LayerPlan>& plan :
         { plan_of(stock, scene, grey), plan_of(stock, scene, grey, mixed) }) {
        ASSERT_EQ(plan.size(), 3u);
        for (size_t l = 0; l < 2; ++l) {
            EXPECT_TRUE(plan[l].pixel_model) << l;
            EXPECT_FALSE(plan[l].pixel_model && plan[l].pixel_model->shaped()) << l;
            EXPECT_EQ(plan[l].min_developed_per_pixel, 0.0) << l;
            EXPECT_EQ(plan[l].dye_samples, 0) << l;
        }
        const LayerPlan& blue = plan[2];
        ASSERT_TRUE(blue.pixel_model);
        EXPECT_TRUE(blue.pixel_model->shaped());
        EXPECT_GT(blue.pixel_model->shapes_sampled(), 0);
        EXPECT_GT(blue.min_developed_per_pixel, 0.0);
        EXPECT_GT(blue.dye_samples, 0);  // its grains keep their image
        ASSERT_TRUE(blue.notes.pixel_scale);
        EXPECT_LT(blue.notes.pixel_scale->fog_grains, blue.min_developed_per_pixel);
        EXPECT_GE(blue.pixel_model->at(0.18, blue.notes.pixel_scale->max_log_factor)
                      .developed_per_pixel,
                  blue.min_developed_per_pixel);
    }
    RenderSettings pixel;
    pixel.scale = ScaleMethod::pixel;
    const LayerPlan blue = plan_of(stock, scene, grey, pixel)[2];
    ASSERT_TRUE(blue.pixel_model);
    EXPECT_TRUE(blue.pixel_model->shaped());
    EXPECT_EQ(blue.min_developed_per_pixel, 0.0);
    stock.layers[2].image = LayerImage::silver;
    for (Population& p : stock.layers[2].populations)
        p.max_dye_density = 0.0;  // a coupler limit is a dye layer's
    EXPECT_FALSE(plan_of(stock, scene, grey)[2].pixel_model);
}

}  // namespace
}  // namespace filmgrain
