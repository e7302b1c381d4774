// The calibrated stocks (issue 10). Tolerances are the issue's (speed 1/3
// stop, slope 0.05, D-min 0.03, RMS granularity 10%, reciprocity 1/3 stop
// and 1/6 stop inside none_between; ours for what it names none: each half
// of the slope's range 0.1, a datasheet curve's points 0.1 density), never
// widened. The figures are analytic (expected curves and the Boolean model's aperture variance):
// deterministic, with the chain tables' fixed Monte Carlo streams; each
// comes with the bound its table error implies, printed beside it (the
// render-based check of the same figures is docs/stocks/*/render_check.md).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "expect/expected_curve_model.h"
#include "model/dye.h"
#include "fit.h"
#include "recipe.h"
#include "filmgrain/render.h"

namespace filmgrain {
namespace {

namespace sm = sensitometry;

sm::Datasheet datasheet(const std::string& file)
{
    sm::Datasheet d;
    const Status s = sm::load_datasheet(std::string(FILMGRAIN_DATASHEETS) + "/" + file, d);
    EXPECT_TRUE(s) << s.message();
    return d;
}

void expect_all_met(const std::vector<sm::Comparison>& comparisons, const std::string& what)
{
    ASSERT_FALSE(comparisons.empty());
    for (const sm::Comparison& c : comparisons)
        EXPECT_TRUE(c.met()) << what << ": " << c.figure << ": target " << c.target
                             << ", achieved " << c.achieved << " (bound " << c.error
                             << "), miss " << c.miss << " " << c.unit << " > tolerance "
                             << c.tolerance;
}

/// Measures a built-in stock against its datasheet: every figure within
/// the issue's tolerance, except exactly those named in `missed` (figures
/// the model cannot reach, fit::model_limits, or that its fit did not: each
/// stated in docs/stocks/README.md and docs/stocks/built-in.md), which
/// must still miss, so that the list stays what the documents say.
void check_builtin(const std::string& preset, const std::string& sheet_file,
                   size_t expected_figures, const std::set<std::string>& missed = {})
{
    Stock stock;
    ASSERT_TRUE(load_stock(preset, stock));
    EXPECT_NE(stock.description.find("published figures"), std::string::npos)
        << "a fitted stock says what it imitates";
    const sm::Datasheet sheet = datasheet(sheet_file);
    sm::DatasheetFigures figures;
    std::vector<sm::Comparison> comparisons;
    const Status s = fit::measure(stock, sheet, ExpectedCurveOptions(), figures, comparisons);
    ASSERT_TRUE(s) << s.message();
    // Every target the datasheet gives is measured.
    EXPECT_EQ(comparisons.size(), expected_figures);
    std::cout << fit::comparison_table(comparisons);
    std::vector<sm::Comparison> held;
    for (const sm::Comparison& c : comparisons) {
        if (missed.count(c.figure))
            EXPECT_FALSE(c.met()) << preset << ": " << c.figure
                                  << " now meets its target: update the list and the documents";
        else
            held.push_back(c);
    }
    expect_all_met(held, preset);
}

TEST(BuiltInStocks, TriX400MeetsItsDatasheet)
{
    // speed, D-min, slope and its two halves, RMS at net 1.0, reciprocity
    // at 1e-3, 0.1, 1, 10 and 100 s.
    check_builtin("tri-x-400", "kodak-tri-x-400.json", 11);
}

TEST(BuiltInStocks, TMax100MeetsItsDatasheet)
{
    // As Tri-X, plus reciprocity at 1e-4 s.
    check_builtin("t-max-100", "kodak-t-max-100.json", 12);
}

// The colour stocks (dye clouds, two coupler-limited populations a layer,
// self-inhibition: docs/model.md) meet speed, every slope and each half of
// its range, D-min, granularity and reciprocity figure; 500T every point of
// the datasheet's characteristic curve too, 250D all but the named two in
// its toe (0.1 density, our tolerance; by 0.103 and 0.110), 200T all but
// one at its green shoulder (by 0.111);
// docs/stocks/built-in.md and docs/stocks/README.md say so.
TEST(BuiltInStocks, Vision3_500tMeetsItsDatasheet)
{
    // speed, per layer D-min, slope and its halves, RMS at net 0.5 / 1 /
    // 1.5 and 19 curve points, reciprocity at 1e-3, 0.1 and 1 s.
    check_builtin("vision3-500t", "kodak-vision3-500t-5219.json", 82);
}

TEST(BuiltInStocks, Vision3_250dMeetsItsDatasheetButTheNamedFigures)
{
    // As 500T with 20 curve points a layer.
    check_builtin("vision3-250d", "kodak-vision3-250d-5207.json", 85,
                  { "R D at log H -2.5", "G D at log H -2.5" });
}

TEST(BuiltInStocks, Vision3_200tMeetsItsDatasheetButTheNamedFigure)
{
    // As 500T with 21 curve points a layer; its green's top point (the
    // shoulder at log H 1.116) by 0.111.
    check_builtin("vision3-200t", "kodak-vision3-200t-5213.json", 88,
                  { "G D at log H 1.116" });
}

// Every built-in stock's characteristic curves rise with exposure: grains
// develop with a probability that grows with their photons (MODEL.md 3-4),
// and inhibition (MODEL.md 10) must not turn that round. With a layer's
// self-inhibition a alone its density above base is S exp(-a min(S, M))
// for the uninhibited S (Dbar clamped at max_density M, as every density),
// falling where a S > 1 below the clamp: a <= 1 / M keeps it rising
// (filmgrain-fit's bound). Checked on the curves themselves: between
// neighbouring points (one chain table, so no independent noise between
// them) no drop beyond 1e-4 density, at every shutter of the datasheets'
// reciprocity tables.
TEST(BuiltInStocks, CarryTheirDatasheetsPrintingDensityMaps)
{
    // MODEL.md 11: a stock fitted to a datasheet that publishes an Annex C
    // Status M -> APD map (S-2008-002) carries it exactly; no-remjet is
    // 500T's emulsion (tools/look/make_no_remjet.py), so 5219's map. The
    // black and white sheets and the paper's stocks have none.
    const std::pair<const char*, const char*> fitted[] = {
        { "vision3-500t", "kodak-vision3-500t-5219.json" },
        { "no-remjet", "kodak-vision3-500t-5219.json" },
        { "vision3-250d", "kodak-vision3-250d-5207.json" },
        { "tri-x-400", "kodak-tri-x-400.json" },
        { "t-max-100", "kodak-t-max-100.json" },
    };
    for (const auto& [preset, sheet_file] : fitted) {
        Stock stock;
        ASSERT_TRUE(load_stock(preset, stock));
        const sm::Datasheet sheet = datasheet(sheet_file);
        ASSERT_EQ(stock.status_m_to_apd.has_value(), sheet.printing_density.has_value())
            << preset;
        if (!sheet.printing_density)
            continue;
        EXPECT_EQ(stock.status_m_to_apd->matrix, sheet.printing_density->matrix) << preset;
        EXPECT_EQ(stock.status_m_to_apd->offset, sheet.printing_density->offset) << preset;
    }
    // The colour sheets do publish one (5219's first entry, by hand).
    const sm::Datasheet d5219 = datasheet("kodak-vision3-500t-5219.json");
    ASSERT_TRUE(d5219.printing_density);
    EXPECT_EQ(d5219.printing_density->matrix[0][0], 1.100481);
    EXPECT_EQ(d5219.printing_density->offset[2], 0.010549);
    for (const char* preset : { "color-negative", "paper" }) {
        Stock stock;
        ASSERT_TRUE(load_stock(preset, stock));
        EXPECT_FALSE(stock.status_m_to_apd) << preset;
    }
    // A datasheet's map is read by the stock's rules: errors name the key.
    sm::Datasheet bad;
    const Status s = sm::parse_datasheet_json(
        R"({"name": "x", "kind": "colour-negative", "printing_density": {"status_m_to_apd":
            {"matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "offset": [0, 0]}}})",
        "x.json", bad);
    ASSERT_FALSE(s);
    EXPECT_NE(s.message().find("printing_density.status_m_to_apd.offset must be an array of 3 "
                               "numbers"),
              std::string::npos)
        << s.message();
}

TEST(BuiltInStocks, CharacteristicCurvesRiseWithExposure)
{
    for (const std::string& name : preset_names()) {
        Stock stock;
        ASSERT_TRUE(load_stock(name, stock));
        for (double shutter_s : { 1e-3, 1e-2, 1.0 }) {
            SceneSettings scene;
            scene.shutter_s = shutter_s;
            std::vector<ExpectedCurve> curves;
            const Status s = expected_curves(stock, scene, ExpectedCurveOptions(), curves);
            ASSERT_TRUE(s) << s.message();
            for (size_t l = 0; l < curves.size(); ++l) {
                const std::vector<CurvePoint>& p = curves[l].points;
                for (size_t i = 1; i < p.size(); ++i)
                    EXPECT_GE(p[i].density, p[i - 1].density - 1e-4)
                        << name << " layer " << stock.layers[l].name << ", shutter " << shutter_s
                        << " s: density falls from " << p[i - 1].density << " to " << p[i].density
                        << " between " << p[i - 1].exposure_lxs << " and " << p[i].exposure_lxs
                        << " lx s";
            }
        }
    }
}

// A datasheet's characteristic curve (layers[].curve, stocks/datasheets/
// README.md): parsed strictly, and measured on the stock's own curve: the
// slope figure over [-2, -1] is the difference of the curve figures at
// those two points (one reading of the curve for both).
TEST(Datasheet, CurvePointsAreReadOffTheStocksCurve)
{
    const sm::Datasheet sheet = datasheet("kodak-vision3-500t-5219.json");
    ASSERT_EQ(sheet.layers.size(), 3u);
    Stock stock;
    ASSERT_TRUE(load_stock("vision3-500t", stock));
    sm::DatasheetFigures f;
    std::vector<sm::Comparison> comparisons;
    ASSERT_TRUE(fit::measure(stock, sheet, ExpectedCurveOptions(), f, comparisons));
    for (size_t l = 0; l < sheet.layers.size(); ++l) {
        const sm::LayerTargets& t = sheet.layers[l];
        ASSERT_EQ(t.curve.size(), 19u);
        ASSERT_EQ(f.layers[l].curve.size(), t.curve.size());
        double at_lo = NAN, at_hi = NAN;
        for (size_t k = 0; k < t.curve.size(); ++k) {
            if (t.curve[k].first == t.slope_log10_h_lo)
                at_lo = f.layers[l].curve[k].value;
            if (t.curve[k].first == t.slope_log10_h_hi)
                at_hi = f.layers[l].curve[k].value;
        }
        EXPECT_NEAR(f.layers[l].slope.value,
                    (at_hi - at_lo) / (t.slope_log10_h_hi - t.slope_log10_h_lo), 1e-12)
            << t.name;
    }
    const auto parse = [](const std::string& curve) {
        sm::Datasheet d;
        return sm::parse_datasheet_json(
            R"({"name": "x", "kind": "bw-negative", "layers": [{"name": "Y", "curve": )" + curve
                + "}]}",
            "test", d);
    };
    EXPECT_TRUE(parse(R"({"log_h": [-2, -1], "density": [0.3, 0.8]})"));
    EXPECT_FALSE(parse(R"({"log_h": [-1, -2], "density": [0.3, 0.8]})"));   // not increasing
    EXPECT_FALSE(parse(R"({"log_h": [-2, -1], "density": [0.3]})"));        // lengths differ
    EXPECT_FALSE(parse(R"({"log_h": [-2], "density": [0.3]})"));            // one point
    EXPECT_FALSE(parse(R"({"log_h": [-2, -1], "density": [0.3, 0.8], "x": 1})"));  // unknown key
}

// MODEL.md 9 on a datasheet's uniform patches: halation returns its
// fraction h of the light (H' = (1 + h) H), scatter only moves it. A
// layer with halation h measures as the same layer with its sensitivity
// times 1 + h (every figure: curves, speed, granularity, inhibition), and
// its speed point lies log10(1 + h) lower than without it (to the chain
// tables' bound: 0.301 here, more than 5 times that bound; h = 0.5 gave
// 0.176, below 5 bounds (0.231) of 2026-12-07's red layer, whose toe is
// long where the speed point lies, so h is the largest allowed). The halo
// is the stock's own kernel, the film base's (docs/model.md), as a disc's would
// be: every kernel is normalised.
TEST(Datasheet, HalationAddsItsFractionOnAUniformPatch)
{
    const sm::Datasheet sheet = datasheet("kodak-vision3-500t-5219.json");
    Stock plain;
    ASSERT_TRUE(load_stock("vision3-500t", plain));
    for (Layer& l : plain.layers)  // without the stock's own spread
        l.scatter = l.scatter_sigma_um = l.halation = l.halation_radius_um = 0.0;
    Stock halo = plain, brighter = plain;
    ASSERT_EQ(halo.layers[0].halation_kernel, HalationKernel::base);
    halo.layers[0].halation           = 1.0;
    halo.layers[0].scatter            = 0.25;
    halo.layers[0].scatter_sigma_um   = 5.0;
    for (double& w : brighter.layers[0].sensitivity)
        w *= 2.0;
    ASSERT_EQ(plain.layers[0].name, "R");
    struct Measured {
        sm::DatasheetFigures figures;
        std::vector<sm::Comparison> comparisons;
    };
    const auto measure = [&](const Stock& s) {
        Measured m;
        const Status st = fit::measure(s, sheet, ExpectedCurveOptions(), m.figures, m.comparisons);
        EXPECT_TRUE(st) << st.message();
        return m;
    };
    const Measured a = measure(plain), b = measure(halo), c = measure(brighter);
    ASSERT_EQ(b.comparisons.size(), c.comparisons.size());
    for (size_t k = 0; k < b.comparisons.size(); ++k) {
        const sm::Comparison &x = b.comparisons[k], &y = c.comparisons[k];
        ASSERT_EQ(x.figure, y.figure);
        EXPECT_NEAR(x.achieved, y.achieved, 1e-9 * std::max(1.0, std::fabs(y.achieved)))
            << x.figure;
    }
    const sm::Figure& ra = a.figures.layers[0].speed_log10_h;
    const sm::Figure& rb = b.figures.layers[0].speed_log10_h;
    EXPECT_NEAR(ra.value - rb.value, std::log10(2.0), ra.error + rb.error);
    EXPECT_GT(std::log10(2.0), 5.0 * (ra.error + rb.error)) << "the test can tell";
}

TEST(Fitter, RecoversAPerturbedSyntheticTarget)
{
    // A stock's own figures, perturbed, as a datasheet; the fitter must
    // reach them from its physical guess (no reciprocity table: the rates
    // stay MODEL.md 7's, as in the guess).
    sm::Datasheet own;
    own.name           = "synthetic";
    own.kind           = "bw-negative";
    own.speed          = 1.0;
    own.speed_standard = "ISO 6";
    sm::LayerTargets t;
    t.name             = "Y";
    t.d_min            = 0.0;
    t.slope            = 0.0;
    t.slope_log10_h_lo = -1.5;
    t.slope_log10_h_hi = -0.5;
    t.granularity      = { { 0.5, true, 1.0 }, { 1.0, true, 1.0 } };
    own.layers         = { t };
    // The figures of a real-scale stock: the fitted T-MAX, 1/100 s.
    Stock stock;
    ASSERT_TRUE(load_stock("t-max-100", stock));
    sm::DatasheetFigures f;
    std::vector<sm::Comparison> unused;
    ASSERT_TRUE(fit::measure(stock, own, ExpectedCurveOptions(), f, unused));
    // Perturbed: 1/2 stop faster, slope +0.06, RMS +8% and -5%, D-min
    // +0.05: each beyond the tolerance, so the guess does not pass by luck.
    sm::Datasheet sheet = own;
    sheet.speed                        = f.speed.value * std::exp2(0.5);
    sheet.layers[0].slope              = f.layers[0].slope.value + 0.06;
    sheet.layers[0].d_min              = f.layers[0].d_min.value + 0.05;
    sheet.layers[0].granularity[0].rms = f.layers[0].granularity[0].value * 1.08;
    sheet.layers[0].granularity[1].rms = f.layers[0].granularity[1].value * 0.95;

    fit::FitOptions o;
    o.seed   = 7;
    o.rounds = 1;
    fit::FitResult r;
    const Status s = fit::fit_stock(sheet, o, r);
    ASSERT_TRUE(s) << s.message();
    std::cout << fit::comparison_table(r.comparisons);
    EXPECT_EQ(r.comparisons.size(), 7u);  // speed, D-min, slope and its halves, 2 RMS
    expect_all_met(r.comparisons, "synthetic");

    // Deterministic for a seed, whatever the threads (the starts run side
    // by side: Search::populations).
    fit::FitResult again;
    ASSERT_TRUE(fit::fit_stock(sheet, o, again));
    EXPECT_EQ(stock_to_json(again.stock), stock_to_json(r.stock));
    for (int threads : { 1, 3 }) {
        fit::FitOptions t = o;
        t.search_curve.nthreads = t.rate_curve.nthreads = t.final_curve.nthreads = threads;
        fit::FitResult other;
        ASSERT_TRUE(fit::fit_stock(sheet, t, other));
        EXPECT_EQ(stock_to_json(other.stock), stock_to_json(r.stock)) << threads << " threads";
    }
}

// A short search of the green layer's populations from `start` (one round,
// one start, the rates kept).
fit::FitOptions quick_green_search(const Stock& start, int population_evals)
{
    fit::FitOptions o;
    o.start            = start;
    o.layers           = { "G" };
    o.rounds           = 1;
    o.starts           = 1;
    o.fit_rates        = false;
    o.population_evals = population_evals;
    return o;
}

// --layers: only the named layers' populations are searched; the others
// stay the start's, key for key; a name the datasheet lacks, no start, or
// a start with --start-cloud-ratio (which sets the guess) is an error.
TEST(Fitter, SearchesOnlyTheNamedLayers)
{
    sm::Datasheet sheet = datasheet("kodak-vision3-500t-5219.json");
    Stock start;
    ASSERT_TRUE(load_stock("vision3-500t", start));
    // A start whose green layer is off, so that the search moves it.
    start.layers[1].populations[0].quantum_efficiency *= 0.5;
    fit::FitOptions o = quick_green_search(start, 30);
    fit::FitResult r;
    const Status s = fit::fit_stock(sheet, o, r);
    ASSERT_TRUE(s) << s.message();
    ASSERT_EQ(r.stock.layers.size(), 3u);
    const auto populations = [](const Layer& l) {
        Stock one;
        one.layers = { l };
        one.layers[0].base_density = 0.0;  // fitted for every layer
        return stock_to_json(one);
    };
    EXPECT_EQ(populations(r.stock.layers[0]), populations(start.layers[0]));
    EXPECT_EQ(populations(r.stock.layers[2]), populations(start.layers[2]));
    EXPECT_NE(populations(r.stock.layers[1]), populations(start.layers[1]));
    EXPECT_EQ(r.stock.inhibition[0][0], start.inhibition[0][0]);
    EXPECT_EQ(r.stock.inhibition[2][2], start.inhibition[2][2]);

    o.layers = { "X" };
    EXPECT_FALSE(fit::fit_stock(sheet, o, r));
    o.layers            = { "G" };
    o.start_cloud_ratio = 2.0;  // the guess's: not with a start
    EXPECT_FALSE(fit::fit_stock(sheet, o, r));
    o.start_cloud_ratio = 1.0;
    o.layers = { "G" };
    o.start.reset();
    EXPECT_FALSE(fit::fit_stock(sheet, o, r));
}

// --halation / --scatter (FitOptions::light_spread): the fitted stock gets
// the named layers' spread and, since uniform patches see halation as
// 1 + halation times the light (MODEL.md 9), their quantum efficiencies
// divided by the gain it adds (from a start that already had a halo: by
// the ratio of the two gains); the search is unchanged. The figures are
// read off the tabulated expected curves (MODEL.md 2's exposure values,
// now g times further along the table's grid for the same photons), so
// they agree to the tables' interpolation, not to rounding: measured, at
// most 4e-5 density on a curve point and 1.6e-4 on a slope's half (blue;
// 1.1e-5 relative on the red RMS 7.07). 1e-3 (relative above 1) is 6
// times that and 4 to 25 times below what the spread without the
// compensation moves (the red curve by log10(1.25 / 1.1) = 0.056 log H,
// about 0.025 density; the blue by log10(1.02): 0.004).
TEST(Fitter, LightSpreadLeavesTheFiguresWhereTheSearchPutThem)
{
    sm::Datasheet sheet = datasheet("kodak-vision3-500t-5219.json");
    Stock start;
    ASSERT_TRUE(load_stock("vision3-500t", start));
    start.layers[0].halation           = 0.1;
    start.layers[0].halation_radius_um = 100.0;
    start.layers[0].halation_kernel    = HalationKernel::disc;
    fit::FitOptions o = quick_green_search(start, 10);
    fit::FitResult plain, spread;
    Status s = fit::fit_stock(sheet, o, plain);
    ASSERT_TRUE(s) << s.message();
    o.light_spread["R"] = { 0.2, 5.0, 0.25, 220.0, HalationKernel::ring };
    o.light_spread["B"] = { 0.0, 0.0, 0.02, 0.0, HalationKernel::base };
    o.film_base         = { 140.0, 1.65, RearFace::bare };
    s                   = fit::fit_stock(sheet, o, spread);
    ASSERT_TRUE(s) << s.message();
    const Layer& r = spread.stock.layers[0];
    EXPECT_EQ(r.scatter, 0.2);
    EXPECT_EQ(r.scatter_sigma_um, 5.0);
    EXPECT_EQ(r.halation, 0.25);
    EXPECT_EQ(r.halation_radius_um, 220.0);
    EXPECT_EQ(r.halation_kernel, HalationKernel::ring);
    EXPECT_EQ(spread.stock.layers[1].halation, start.layers[1].halation);  // not named: kept
    EXPECT_EQ(spread.stock.layers[2].halation_kernel, HalationKernel::base);
    EXPECT_EQ(spread.stock.base_thickness_um, 140.0);
    EXPECT_EQ(spread.stock.base_refractive_index, 1.65);
    EXPECT_EQ(spread.stock.rear_face, RearFace::bare);
    const double gain[3] = { 1.1 / 1.25, 1.0, 1.0 / 1.02 };
    for (size_t l = 0; l < 3; ++l)
        for (size_t p = 0; p < r.populations.size(); ++p)
            EXPECT_NEAR(spread.stock.layers[l].populations[p].quantum_efficiency,
                        plain.stock.layers[l].populations[p].quantum_efficiency * gain[l],
                        1e-15 * plain.stock.layers[l].populations[p].quantum_efficiency)
                << "layer " << l << ", population " << p;
    ASSERT_EQ(spread.comparisons.size(), plain.comparisons.size());
    for (size_t i = 0; i < plain.comparisons.size(); ++i)
        EXPECT_NEAR(spread.comparisons[i].achieved, plain.comparisons[i].achieved,
                    1e-3 * std::max(1.0, std::abs(plain.comparisons[i].achieved)))
            << plain.comparisons[i].figure;

    o.light_spread["X"] = {};  // not a layer of the datasheet
    EXPECT_FALSE(fit::fit_stock(sheet, o, spread));
    o.light_spread.erase("X");
    o.light_spread["G"] = { 0.0, 0.0, 0.1, 0.0, HalationKernel::disc };  // no radius
    EXPECT_FALSE(fit::fit_stock(sheet, o, spread));
    o.light_spread["G"] = { 0.0, 0.0, 0.1, 220.0, HalationKernel::base };  // base and a radius
    EXPECT_FALSE(fit::fit_stock(sheet, o, spread));
    o.light_spread.erase("G");
    o.film_base->thickness_um = 0.0;  // the base kernel without a base
    EXPECT_FALSE(fit::fit_stock(sheet, o, spread));
}

TEST(Fitter, SaysWhatTheModelCannotReach)
{
    // A slope of 5 over a decade needs 5 density units, beyond the stock's
    // max_density clamp of 4 (MODEL.md 5): no grains can give it. The fit
    // must come back with the figure reported as missed, not a silent
    // success.
    sm::Datasheet sheet = datasheet("kodak-t-max-100.json");
    sheet.has_reciprocity = false;
    sheet.layers[0].slope = 5.0;
    fit::FitOptions o;
    o.rounds           = 1;
    o.starts           = 1;
    o.population_evals = 150;
    fit::FitResult r;
    ASSERT_TRUE(fit::fit_stock(sheet, o, r));
    bool slope_missed = false;
    for (const sm::Comparison& c : r.comparisons)
        if (c.figure.find("slope") != std::string::npos)
            slope_missed = !c.met();
    EXPECT_TRUE(slope_missed);
}

TEST(Fitter, AGranularityDensityTheCurveNeverReachesIsMissedNotAnError)
{
    // Tri-X against its datasheet with one more granularity target at a
    // gross density of 6, above the stock's max_density (4, the clamp of
    // MODEL.md 5): the measurement still succeeds (a fit then writes its
    // stock and reports the figure), the figure is NaN, missed, and said
    // so in the table; every other figure is measured as without it.
    Stock stock;
    ASSERT_TRUE(load_stock("tri-x-400", stock));
    sm::Datasheet sheet = datasheet("kodak-tri-x-400.json");
    sm::DatasheetFigures before, after;
    std::vector<sm::Comparison> was, is;
    ASSERT_TRUE(fit::measure(stock, sheet, ExpectedCurveOptions(), before, was));
    sheet.layers.at(0).granularity.push_back({ 6.0, false, 20.0 });
    const Status s = fit::measure(stock, sheet, ExpectedCurveOptions(), after, is);
    ASSERT_TRUE(s) << s.message();
    ASSERT_EQ(is.size(), was.size() + 1);
    size_t unreached = 0;
    for (const sm::Comparison& c : is) {
        if (!std::isnan(c.achieved))
            continue;
        ++unreached;
        EXPECT_NE(c.figure.find("RMS at gross 6"), std::string::npos) << c.figure;
        EXPECT_FALSE(c.met());
    }
    EXPECT_EQ(unreached, 1u);
    for (const sm::Comparison& c : was) {
        const auto same = std::find_if(is.begin(), is.end(), [&](const sm::Comparison& d) {
            return d.figure == c.figure;
        });
        ASSERT_NE(same, is.end()) << c.figure;
        EXPECT_EQ(same->achieved, c.achieved) << c.figure;
    }
    EXPECT_NE(fit::comparison_table(is).find("| never reached |"), std::string::npos);
    // A search's measurement keeps the error (its objective costs the
    // shortfall instead).
    DevelopModels models(stock, ExpectedCurveOptions());
    sm::FigureOptions strict;
    sm::DatasheetFigures f;
    EXPECT_FALSE(sm::measure_datasheet_figures(stock, sheet, models, strict, f));
}

TEST(Fitter, ASpeedPointTheCurveNeverReachesIsMissedNotAnError)
{
    // Grains that absorb almost nothing: the curve never rises 0.1 above
    // fog. The speed, the reciprocity measured from it and the granularity
    // are never reached, and missed; the measurement succeeds.
    Stock stock;
    ASSERT_TRUE(load_stock("tri-x-400", stock));
    for (Population& pop : stock.layers.at(0).populations)
        pop.quantum_efficiency = 1e-9;
    const sm::Datasheet sheet = datasheet("kodak-tri-x-400.json");
    sm::DatasheetFigures figures;
    std::vector<sm::Comparison> comparisons;
    const Status s = fit::measure(stock, sheet, ExpectedCurveOptions(), figures, comparisons);
    ASSERT_TRUE(s) << s.message();
    EXPECT_TRUE(std::isnan(figures.speed.value));
    for (const sm::Comparison& c : comparisons) {
        const bool from_speed = c.figure.rfind("speed", 0) == 0
                                || c.figure.rfind("reciprocity", 0) == 0
                                || c.figure.find("RMS") != std::string::npos;
        if (from_speed) {
            EXPECT_FALSE(c.met()) << c.figure;
            EXPECT_TRUE(std::isinf(c.miss)) << c.figure << ": " << c.miss;
        }
    }
    DevelopModels models(stock, ExpectedCurveOptions());
    sm::FigureOptions strict;
    EXPECT_FALSE(sm::measure_datasheet_figures(stock, sheet, models, strict, figures));
}

TEST(Fitter, NamesTheGranularityNoStockCanReach)
{
    // VISION3's granularity falls with density in places; without
    // inhibition the model's cannot, so at least one of a falling pair
    // misses by (t_a - t_b) / (t_a + t_b): 500T R 7.1 -> 5.7 (10.9%),
    // G 9.6 -> 7.1 (15%), B 25.1 -> 19.3 (13.1%); 250D R 7.2 -> 4.6 (22%),
    // its G (10.0%) and B (6.7%) within the 10% tolerance. Tri-X: one target.
    const auto limits = [](const std::string& file) {
        return fit::model_limits(datasheet(file), false, {});
    };
    const std::vector<std::string> v500t = limits("kodak-vision3-500t-5219.json");
    ASSERT_EQ(v500t.size(), 3u);
    EXPECT_NE(v500t[0].find("R RMS granularity falls from 7.1 at net D 0.5 to 5.7 at net D 1.5"),
              std::string::npos) << v500t[0];
    EXPECT_NE(v500t[0].find("10.9%"), std::string::npos) << v500t[0];
    EXPECT_NE(v500t[1].find("15%"), std::string::npos) << v500t[1];
    EXPECT_NE(v500t[2].find("13.1%"), std::string::npos) << v500t[2];
    const std::vector<std::string> v250d = limits("kodak-vision3-250d-5207.json");
    ASSERT_EQ(v250d.size(), 1u);
    EXPECT_NE(v250d[0].find("22%"), std::string::npos) << v250d[0];
    EXPECT_TRUE(limits("kodak-tri-x-400.json").empty());
    // With inhibition the granularity can fall, as steeply as the layer's
    // grains allow (fit::smallest_falling_miss; tools/fit/fit.h derives
    // it): with the fit's 4 populations of at most 15 grains per um^2,
    // 250D R's 7.2 -> 4.6 still misses by 21.8% or more, 500T's falls
    // are within reach; with 30 grains per um^2 (issue 9's real-emulsion
    // range tops out there) 500T R's 7.1 -> 5.7 misses by 19.8% or more.
    const auto inhibited = [](const std::string& file, double grains_per_um2) {
        return fit::model_limits(datasheet(file), true,
                                 std::vector<double>(3, grains_per_um2));
    };
    const std::vector<std::string> i250d = inhibited("kodak-vision3-250d-5207.json", 60.0);
    ASSERT_EQ(i250d.size(), 1u);
    EXPECT_NE(i250d[0].find("R RMS granularity falls from 7.2 at net D 0.5 to 4.6 at net D 1.5"),
              std::string::npos) << i250d[0];
    EXPECT_NE(i250d[0].find("21.8%"), std::string::npos) << i250d[0];
    EXPECT_NE(i250d[0].find("at most 60 grains per um^2"), std::string::npos) << i250d[0];
    EXPECT_TRUE(inhibited("kodak-vision3-500t-5219.json", 60.0).empty());
    const std::vector<std::string> i500t = inhibited("kodak-vision3-500t-5219.json", 30.0);
    ASSERT_EQ(i500t.size(), 1u);
    EXPECT_NE(i500t[0].find("R RMS granularity falls from 7.1"), std::string::npos) << i500t[0];
    EXPECT_NE(i500t[0].find("19.8%"), std::string::npos) << i500t[0];
}

TEST(Fitter, NoStockFallsBelowTheGranularityBound)
{
    // fit::smallest_granularity_after bounds what any layer of at most N
    // grains per um^2 can reach at a higher density, inhibition included.
    // A bound set too high would claim impossible what a stock achieves:
    // measure stocks whose granularity falls with density and check every
    // pair of their own figures against it (each stock's own grains, its
    // achieved D-min as the density above base a net density stands on:
    // larger than the true one, which only weakens the bound's first term).
    sm::Datasheet sheet = datasheet("kodak-vision3-500t-5219.json");
    sheet.has_reciprocity = false;
    Stock base;
    ASSERT_TRUE(load_stock("vision3-500t", base));
    // The bound is for images that add: the built-in stock's coupler limits
    // (docs/model.md) are taken off (see CouplerLimitedLayersFallBelowIt).
    for (Layer& l : base.layers)
        for (Population& p : l.populations)
            p.max_dye_density = 0.0;
    // The R and G layers made to fall: a few large fast grains that
    // develop early, many small slow ones that carry the density above, and
    // strong self-inhibition that thins the large ones as the layer grows
    // dense. (Built here, so that the falls the test needs do not depend on
    // the built-in stock's fit.)
    std::vector<Stock> stocks(3, base);
    const double self_inhibition[3] = { 0.0, 0.3, 0.45 };
    for (int v = 1; v < 3; ++v)
        for (size_t l : { 0, 1 }) {
            Layer& r         = stocks[v].layers[l];
            Population large = r.populations[0], small = r.populations[0];
            large.grains_per_um2       = l == 0 ? 1.0 : 0.7;  // two different falls
            large.diameter_um          = l == 0 ? 1.5 : 1.8;
            large.diameter_log_sigma   = 0.2;
            large.quantum_efficiency   = 0.5;
            small.grains_per_um2       = 60.0;
            small.diameter_um          = 0.5;
            small.diameter_log_sigma   = 0.3;
            small.quantum_efficiency   = 0.1;
            r.populations              = { large, small };
            r.cloud_profile            = CloudProfile::gaussian;
            r.cloud_diameter_ratio     = 2.0;
            r.cloud_density            = 1.0;
            stocks[v].inhibition[l][l] = self_inhibition[v];
        }
    int falling = 0;
    for (const Stock& stock : stocks) {
        sm::DatasheetFigures f;
        std::vector<sm::Comparison> comparisons;
        const Status s = fit::measure(stock, sheet, ExpectedCurveOptions(), f, comparisons);
        ASSERT_TRUE(s) << s.message();
        for (size_t i = 0; i < sheet.layers.size(); ++i) {
            const auto& targets = sheet.layers[i].granularity;
            const auto& got     = f.layers[i].granularity;
            double grains_per_um2 = 0.0;
            for (const Population& p : stock.layers[i].populations)
                grains_per_um2 += p.grains_per_um2;
            for (size_t a = 0; a < targets.size(); ++a)
                for (size_t b = a + 1; b < targets.size(); ++b) {
                    ASSERT_TRUE(targets[a].net && targets[a].density < targets[b].density);
                    falling += got[b].value < got[a].value ? 1 : 0;
                    const double bound = fit::smallest_granularity_after(
                        got[a].value - got[a].error, targets[a].density, targets[b].density,
                        grains_per_um2, targets[a].density + f.layers[i].d_min.value);
                    EXPECT_LE(bound, got[b].value + got[b].error)
                        << stock.layers[i].name << " (inhibition " << stock.inhibition[i][i]
                        << "): " << got[a].value << " at net " << targets[a].density << ", "
                        << got[b].value << " at net " << targets[b].density;
                }
        }
    }
    // The check covers falls, not only rising pairs.
    EXPECT_GE(falling, 2);
}

// The bound does not hold for coupler-limited populations (docs/model.md),
// which is why filmgrain-fit reports no model_limits for such a stock: the
// built-in vision3-250d's red layer (two of its four populations
// coupler-limited) falls from net 0.5 to 1.5 below the bound its own
// figure at 0.5 and its own grain count give, beyond both figures' error
// bounds (what no layer of additive clouds can do, inhibited or not).
TEST(Fitter, CouplerLimitedLayersFallBelowTheGranularityBound)
{
    sm::Datasheet sheet = datasheet("kodak-vision3-250d-5207.json");
    sheet.has_reciprocity = false;
    Stock stock;
    ASSERT_TRUE(load_stock("vision3-250d", stock));
    ASSERT_TRUE(has_coupler_limit(stock.layers[0]));
    sm::DatasheetFigures f;
    std::vector<sm::Comparison> comparisons;
    const Status s = fit::measure(stock, sheet, ExpectedCurveOptions(), f, comparisons);
    ASSERT_TRUE(s) << s.message();
    const auto& targets = sheet.layers[0].granularity;
    const auto& got     = f.layers[0].granularity;
    ASSERT_EQ(targets.size(), 3u);
    double grains_per_um2 = 0.0;
    for (const Population& p : stock.layers[0].populations)
        grains_per_um2 += p.grains_per_um2;
    const double bound = fit::smallest_granularity_after(
        got[0].value - got[0].error, targets[0].density, targets[2].density, grains_per_um2,
        targets[0].density + f.layers[0].d_min.value);
    EXPECT_LT(got[2].value + got[2].error, bound)
        << "R: " << got[0].value << " at net " << targets[0].density << ", " << got[2].value
        << " at net " << targets[2].density << ", bound " << bound;
}

// The render check renders a layer alone where no other layer inhibits it
// (fit::layer_alone): that layer's image must be the one it has in the
// whole stock. Grains are numbered per layer index, so on the same frame
// and scan layer 0 alone is bit for bit layer 0 of the whole stock (exact
// engine, a 40 um frame of vision3-500t at 2 um pixels, some 1e5 red
// grains, self-inhibition on); a layer that another inhibits is not
// reduced.
TEST(Fitter, RenderCheckRendersALayerAloneAsInTheWholeStock)
{
    Stock stock;
    ASSERT_TRUE(load_stock("vision3-500t", stock));
    ASSERT_TRUE(stock.inhibits());
    for (size_t l = 0; l < stock.layers.size(); ++l)
        EXPECT_TRUE(fit::layer_develops_alone(stock, l)) << l;
    const Stock red = fit::layer_alone(stock, 0);
    ASSERT_EQ(red.layers.size(), 1u);
    ASSERT_TRUE(red.validate());
    EXPECT_EQ(red.inhibition[0][0], stock.inhibition[0][0]);

    const float grey = 0.18f;
    const ImageView input { &grey, 1, 1, 1 };
    SceneSettings scene;
    scene.exposure_stops = 2.0;
    scene.width_mm = 0.04;
    scene.seed           = 7;
    RenderSettings rs;
    rs.engine      = Engine::exact;
    rs.nthreads    = 2;
    rs.scan_width  = 20;
    rs.scan_height = 20;
    const size_t n = 20 * 20, nl = stock.layers.size();
    std::vector<float> whole(n * nl), alone(n);
    ASSERT_TRUE(render_negative(stock, scene, input, rs, whole.data(), nullptr));
    ASSERT_TRUE(render_negative(red, scene, input, rs, alone.data(), nullptr));
    size_t differ = 0;
    double developed = 0.0;
    for (size_t i = 0; i < n; ++i) {
        differ += alone[i] != whole[i * nl] ? 1 : 0;
        developed += (alone[i] - red.layer_base_density(0)) / static_cast<double>(n);
    }
    EXPECT_EQ(differ, 0u) << "pixels of the red layer that differ, of " << n;
    // Not a blank frame (two blank images would prove nothing).
    EXPECT_GT(developed, 0.1);

    Stock coupled = stock;
    coupled.inhibition[0][2] = 0.1;
    EXPECT_FALSE(fit::layer_develops_alone(coupled, 0));
    EXPECT_TRUE(fit::layer_develops_alone(coupled, 2));
}

// The recipe (issue 43): what filmgrain-fit chooses for the options a user
// leaves unset, by the datasheet's kind and figures.
TEST(Recipe, GranularitySpreadIsTheLargestRatioAtTheLowestSharedDensity)
{
    // VISION3 500T at net 0.5: B 25.1, R 7.1; 250D: B 13.1, R 7.2.
    EXPECT_DOUBLE_EQ(fit::granularity_spread_across_layers(
                         datasheet("kodak-vision3-500t-5219.json")),
                     25.1 / 7.1);
    EXPECT_DOUBLE_EQ(fit::granularity_spread_across_layers(
                         datasheet("kodak-vision3-250d-5207.json")),
                     13.1 / 7.2);
    EXPECT_EQ(fit::granularity_spread_across_layers(datasheet("kodak-tri-x-400.json")), 1.0);
    // No density every layer shares: no spread to read.
    sm::Datasheet sheet = datasheet("kodak-vision3-500t-5219.json");
    for (sm::GranularityTarget& g : sheet.layers[0].granularity)
        g.density += 0.01;
    EXPECT_EQ(fit::granularity_spread_across_layers(sheet), 1.0);
}

TEST(Recipe, DyeCloudsStartLargeWhereOneLayerIsMuchGrainier)
{
    sm::Datasheet sheet = datasheet("kodak-vision3-250d-5207.json");
    EXPECT_EQ(fit::recipe_for(sheet).options.start_cloud_ratio, 1.0);
    // Blue made grainier until it is just past the threshold: clouds start at
    // twice their grain; just short of it, at their grain.
    for (const double factor : { 1.01, 0.99 }) {
        sm::Datasheet grainy = sheet;
        const double spread  = fit::granularity_spread_across_layers(sheet);
        for (sm::GranularityTarget& g : grainy.layers[2].granularity)
            g.rms *= factor * fit::kBigCloudGranularitySpread / spread;
        EXPECT_EQ(fit::recipe_for(grainy).options.start_cloud_ratio, factor > 1.0 ? 2.0 : 1.0)
            << "factor " << factor;
    }
    const sm::Datasheet v500t = datasheet("kodak-vision3-500t-5219.json");
    EXPECT_EQ(fit::recipe_for(v500t).options.start_cloud_ratio, 2.0);
}

/// The recipe for a colour negative asks for the structure the built-in
/// colour stocks (fitted by docs/stocks' hand-written recipes) have.
void expect_recipe_is_the_stocks(const std::string& preset, const std::string& sheet_file)
{
    Stock stock;
    ASSERT_TRUE(load_stock(preset, stock));
    const fit::FitRecipe r = fit::recipe_for(datasheet(sheet_file));
    EXPECT_FALSE(r.reasons.empty());
    for (const Layer& l : stock.layers) {
        SCOPED_TRACE(preset + " layer " + l.name);
        ASSERT_EQ(l.populations.size(), static_cast<size_t>(r.options.populations));
        EXPECT_EQ(l.cloud_profile, r.options.cloud_profile);
        for (size_t p = 0; p < l.populations.size(); ++p) {
            EXPECT_EQ(l.populations[p].coupler_limited(),
                      p < static_cast<size_t>(r.options.coupler_limited));
            EXPECT_LE(l.populations[p].diameter_log_sigma, r.options.max_log_sigma);
        }
        const auto it = r.options.light_spread.find(l.name);
        ASSERT_NE(it, r.options.light_spread.end());
        EXPECT_EQ(l.scatter, it->second.scatter);
        EXPECT_EQ(l.scatter_sigma_um, it->second.scatter_sigma_um);
        EXPECT_EQ(l.halation, it->second.halation);
        EXPECT_EQ(l.halation_radius_um, it->second.halation_radius_um);
        EXPECT_EQ(l.halation_kernel, it->second.halation_kernel);
    }
    ASSERT_TRUE(r.options.film_base.has_value());
    EXPECT_EQ(stock.base_thickness_um, r.options.film_base->thickness_um);
    EXPECT_EQ(stock.base_refractive_index, r.options.film_base->refractive_index);
    EXPECT_EQ(stock.rear_face, r.options.film_base->rear_face);
}

TEST(Recipe, AColourNegativeGetsTheBuiltInColourStocksStructure)
{
    expect_recipe_is_the_stocks("vision3-500t", "kodak-vision3-500t-5219.json");
    expect_recipe_is_the_stocks("vision3-250d", "kodak-vision3-250d-5207.json");
}

TEST(Recipe, ABlackAndWhiteNegativeGetsSilverWithoutSpread)
{
    using Pair = std::pair<std::string, std::string>;
    for (const auto& [preset, file] : { Pair{ "tri-x-400", "kodak-tri-x-400.json" },
                                        Pair{ "t-max-100", "kodak-t-max-100.json" } }) {
        const fit::FitRecipe r = fit::recipe_for(datasheet(file));
        EXPECT_EQ(r.options.coupler_limited, 0);
        EXPECT_TRUE(r.options.light_spread.empty());
        EXPECT_FALSE(r.options.film_base.has_value());
        EXPECT_EQ(r.options.rounds, 3);
        Stock stock;
        ASSERT_TRUE(load_stock(preset, stock));
        for (const Layer& l : stock.layers)
            EXPECT_EQ(l.populations.size(), static_cast<size_t>(r.options.populations)) << preset;
    }
}

TEST(Recipe, AnUnknownKindGetsTheLibrarysDefaultsAndSaysSo)
{
    sm::Datasheet sheet = datasheet("kodak-tri-x-400.json");
    sheet.kind          = "reversal";
    const fit::FitRecipe r = fit::recipe_for(sheet);
    const fit::FitOptions library;
    EXPECT_EQ(r.options.populations, library.populations);
    EXPECT_EQ(r.options.rounds, library.rounds);
    ASSERT_EQ(r.reasons.size(), 1u);
    EXPECT_NE(r.reasons[0].find("'reversal' has no recipe"), std::string::npos);
}

}  // namespace
}  // namespace filmgrain
