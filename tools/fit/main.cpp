// filmgrain-fit: fits a stock to a datasheet's published figures, or
// measures a stock against one. Usage: see --help.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "model/dye.h"
#include "util/parse_number.h"
#include "util/whole_file.h"
#include "fit.h"
#include "recipe.h"

namespace sm = filmgrain::sensitometry;
using filmgrain::Status;
using filmgrain::Stock;

namespace {

void usage(std::ostream& os)
{
    const filmgrain::fit::FitOptions d;
    sm::Datasheet bw, colour;
    bw.kind     = "bw-negative";
    colour.kind = "colour-negative";
    const filmgrain::fit::FitRecipe b = filmgrain::fit::recipe_for(bw);
    const filmgrain::fit::FitRecipe c = filmgrain::fit::recipe_for(colour);
    // "(default B)" or "(default: B black and white, C colour negative)".
    const auto by_kind = [](const auto& bv, const auto& cv) {
        std::ostringstream o;
        if (bv == cv)
            o << "(default " << bv << ")";
        else
            o << "(default: " << bv << " black and white, " << cv << " colour negative)";
        return o.str();
    };
    os << "usage: filmgrain-fit DATASHEET.json -o STOCK.json [options]\n"
          "       filmgrain-fit DATASHEET.json --measure STOCK|PRESET [--report DIR]\n"
          "Fits a film stock's grain populations, latent-image rates and base density to\n"
          "the published figures of a datasheet file (speed, slope, D-min, RMS\n"
          "granularity, reciprocity, characteristic curve points; format:\n"
          "stocks/datasheets/README.md), measuring\n"
          "every candidate analytically the datasheet way (tools/sensitometry/datasheet.h).\n"
          "Options left unset are chosen by the datasheet's kind and figures (the recipe\n"
          "the progress lines state; tools/fit/recipe.h says why each).\n"
          "  -o FILE            write the fitted stock (JSON, every key) to FILE\n"
          "  --report DIR       write report.md (target vs achieved, every figure),\n"
          "                     figures.json, curves.csv and granularity.csv to DIR\n"
          "                     (created); tools/fit/plot_report.py DIR DATASHEET plots them\n"
          "  --measure STOCK    measure a stock (file or built-in preset) instead of fitting\n"
          "  --seed N           multi-start seed; the fit is deterministic for it (default "
       << d.seed
       << ")\n"
          "  --populations N    grain populations per layer, 1 to 4 "
       << by_kind(b.options.populations, c.options.populations)
       << "\n"
          "  --starts N         starts of the population search per layer and round\n"
          "                     "
       << by_kind(b.options.starts, c.options.starts)
       << "\n"
          "  --population-evals N  evaluations per start\n"
          "                     "
       << by_kind(b.options.population_evals, c.options.population_evals)
       << "\n"
          "  --rate-evals N     evaluations of the rate search per round (default "
       << d.rate_evals
       << ")\n"
          "  --rounds N         rounds of (populations, rates), 1 to 8; one round fits no\n"
          "                     rates "
       << by_kind(b.options.rounds, c.options.rounds)
       << "\n"
          "  --no-rates         keep the starting rates (MODEL.md 7's, or --start's)\n"
          "  --image silver|dye the layers' image (MODEL.md 8); dye searches each layer's\n"
          "                     cloud_diameter_ratio and cloud_density too (default: dye\n"
          "                     for a colour negative datasheet, silver for black and\n"
          "                     white; with --start, the start stock's own)\n"
          "  --cloud-profile disc|gaussian  dye clouds' profile\n"
          "                     "
       << by_kind(std::string(filmgrain::name_of(b.options.cloud_profile)),
                  std::string(filmgrain::name_of(c.options.cloud_profile)))
       << "\n"
          "  --start-cloud-ratio X  dye clouds of the physical guess, in grain\n"
          "                     diameters, 0.5 to 2: its grains are Siedentopf's\n"
          "                     developed size over X (default 2 where one layer is\n"
          "                     "
       << filmgrain::fit::kBigCloudGranularitySpread
       << " times as grainy as another at the same density, else 1)\n"
          "  --coupler-limited N  the first N populations of each dye layer are\n"
          "                     coupler-limited (max_dye_density, searched as 0.05 to 1\n"
          "                     times cloud_density; needs --cloud-profile disc), 0 to 4\n"
          "                     (default "
       << c.options.coupler_limited
       << " for dye layers of disc clouds, else 0)\n"
          "  --max-log-sigma X  largest diameter_log_sigma of a population, 0.05 to 0.8\n"
          "                     "
       << by_kind(b.options.max_log_sigma, c.options.max_log_sigma)
       << "\n"
          "  --scatter L=F,...  the fitted stock's scatter (MODEL.md 9): fraction F of\n"
          "                     layer L's light, a Gaussian of --scatter-sigma-um\n"
          "                     (default: none for black and white, VISION3's for a\n"
          "                     colour negative, the recipe's line says it; with\n"
          "                     --start, the start stock's own)\n"
          "  --scatter-sigma-um X  micrometres, 0 to 1000 (needed with --scatter)\n"
          "  --halation L=F,... the fitted stock's halation (MODEL.md 9): fraction F of\n"
          "                     layer L's light reflected back, in the kernel below\n"
          "                     (default: as --scatter's).\n"
          "                     A layer named in either list gets exactly these keys.\n"
          "                     Uniform patches see halation as 1 + F times the light\n"
          "                     and scatter not at all: the search runs without them,\n"
          "                     then every quantum efficiency of the layer is divided\n"
          "                     by 1 + F (the same figures)\n"
          "  --halation-kernel disc|ring|base  (default disc); base: the glow the film\n"
          "                     base returns (docs/model.md), sized by the base below\n"
          "  --halation-radius-um X  micrometres, 0 to 5000 (needed with --halation and\n"
          "                     a disc or ring kernel; an error with base)\n"
          "  --base-thickness-um X  the film base's thickness, micrometres, 0 to 2000\n"
          "                     (needed with --halation-kernel base unless --start\n"
          "                     has one; only with it)\n"
          "  --base-refractive-index X  the base's index, 1.3 to 2 (default 1.5)\n"
          "  --rear-face remjet|bare  what lies behind the base (default bare)\n"
          "  --no-light-spread  a colour negative without the default spread and base\n"
          "  --inhibition, --no-inhibition  search each layer's self-inhibition (MODEL.md\n"
          "                     10, diffusion "
       << d.inhibitor_diffusion_um
       << " um) or fit none (default: on for a colour negative\n"
          "                     datasheet, off for black and white; with --start, the\n"
          "                     start stock's own)\n"
          "  --start STOCK      start from this stock (file or preset) instead of the\n"
          "                     physical guess\n"
          "  --layers A,B,...   search only these layers' populations (the others, and\n"
          "                     the rates with --no-rates, stay the --start stock's;\n"
          "                     needs --start; default: every layer)\n"
          "  --name NAME        name of the fitted stock (default: the datasheet's)\n"
          "  --render-check     also render the patches that check every analytic figure\n"
          "                     (exact engine; minutes to hours; each row printed as it\n"
          "                     is measured) and compare (render_check.md)\n"
          "  --threads N        threads of the population search's starts (run side by\n"
          "                     side) and of the chain tables (default 0: all); the\n"
          "                     fit is the same for any N\n"
          "  -q                 no progress lines\n"
          "  --help             this text\n"
          "Exit status: 0 when every figure is within the issue's tolerances, 3 when the\n"
          "fit or measurement completed but some missed (the report says which), 1 on\n"
          "errors, 2 on usage errors.\n";
}

/// A comma-separated list of non-empty items (exits 2 on an empty one).
std::vector<std::string> split_commas(const std::string& option, const std::string& v)
{
    std::vector<std::string> out;
    size_t b = 0;
    while (b <= v.size()) {
        const size_t e = std::min(v.find(',', b), v.size());
        if (e == b) {
            std::cerr << "filmgrain-fit: " << option << " " << v << ": an empty item\n";
            std::exit(2);
        }
        out.push_back(v.substr(b, e - b));
        b = e + 1;
    }
    return out;
}

std::string stamp(double seconds)
{
    char buf[32];
    std::snprintf(buf, sizeof buf, "[%6.1f s] ", seconds);
    return buf;
}

/// curves.csv: each layer's expected density over log10 H at 1/100 s and
/// at every reciprocity time.
Status write_curves(const Stock& stock, const sm::Datasheet& sheet,
                    const filmgrain::ExpectedCurveOptions& curve, const std::string& path)
{
    std::ofstream out(path);
    out << "shutter_s,layer,log10_h_lxs,density\n";
    std::vector<double> times = { sm::kDatasheetShutterS };
    for (double t : sheet.reciprocity_times_s())
        times.push_back(t);
    for (double t : times) {
        filmgrain::SceneSettings scene;
        scene.shutter_s = t;
        std::vector<filmgrain::ExpectedCurve> curves;
        if (Status s = filmgrain::expected_curves(stock, scene, curve, curves); !s)
            return s;
        for (size_t l = 0; l < curves.size(); ++l) {
            const double sens = stock.layers[l].neutral_weight();
            for (size_t k = 1; k < curves[l].points.size(); k += 4)
                out << t << "," << curves[l].layer << ","
                    << std::log10(curves[l].points[k].exposure_lxs / sens) << ","
                    << curves[l].points[k].density << "\n";
        }
    }
    return out ? Status() : Status::errorf("cannot write ", path);
}

/// granularity.csv: each datasheet layer's RMS granularity against net
/// density at 1/100 s, every 0.05 from 0.05 to 3 where its curve reaches.
Status write_granularity(const Stock& stock, const sm::Datasheet& sheet,
                         const filmgrain::ExpectedCurveOptions& curve, const std::string& path)
{
    std::vector<double> nets;
    for (int k = 1; k <= 60; ++k)
        nets.push_back(0.05 * k);
    std::vector<std::vector<std::pair<double, sm::Figure>>> g;
    if (Status s = filmgrain::fit::granularity_curve(stock, sheet, curve, nets, g); !s)
        return s;
    std::ofstream out(path);
    out << "layer,net_density,rms_granularity,error\n";
    for (size_t i = 0; i < g.size(); ++i)
        for (const auto& [net, rms] : g[i])
            out << sheet.layers[i].name << "," << net << "," << rms.value << "," << rms.error
                << "\n";
    return out ? Status() : Status::errorf("cannot write ", path);
}

nlohmann::json figures_json(const sm::DatasheetFigures& f,
                            const std::vector<sm::Comparison>& comparisons)
{
    nlohmann::json j;
    j["speed"] = { { "value", f.speed.value }, { "error", f.speed.error } };
    j["speed_log10_h"] = { { "value", f.speed_log10_h.value }, { "error", f.speed_log10_h.error } };
    for (const auto& l : f.layers) {
        nlohmann::json jl = { { "name", l.name },
                              { "d_min", { l.d_min.value, l.d_min.error } },
                              { "slope", { l.slope.value, l.slope.error } },
                              { "slope_halves",
                                { { l.slope_halves[0].value, l.slope_halves[0].error },
                                  { l.slope_halves[1].value, l.slope_halves[1].error } } },
                              { "speed_log10_h", { l.speed_log10_h.value, l.speed_log10_h.error } } };
        for (const auto& g : l.granularity)
            jl["rms_granularity"].push_back({ g.value, g.error });
        j["layers"].push_back(jl);
    }
    for (size_t k = 0; k < f.reciprocity.size(); ++k)
        j["reciprocity"].push_back({ { "shutter_s", f.reciprocity[k].first },
                                     { "extra_stops", f.reciprocity[k].second.value },
                                     { "error", f.reciprocity[k].second.error },
                                     { "per_layer", f.reciprocity_layer_stops[k] } });
    for (const auto& c : comparisons)
        j["comparisons"].push_back({ { "figure", c.figure },
                                     { "target", c.target },
                                     { "achieved", c.achieved },
                                     { "error", c.error },
                                     { "miss", c.miss },
                                     { "tolerance", c.tolerance },
                                     { "unit", c.unit },
                                     { "met", c.met() } });
    return j;
}

/// What the command line asks for.
struct FitCommand {
    filmgrain::fit::FitOptions opt;
    std::string sheet_path, out_path, report_dir, measure_path, start_path, name;
    bool quiet = false, check = false;
    /// The options given (what the recipe leaves alone).
    std::set<std::string> given;
    bool no_light_spread = false;
};

/// Parses argv into `cmd`: nothing, or the exit status (0 after --help, 2
/// on a usage error, said on stderr).
std::optional<int> parse_command_line(int argc, char** argv, FitCommand& cmd)
{
    filmgrain::fit::FitOptions& opt = cmd.opt;
    std::map<std::string, double> scatter, halation;
    std::optional<double> scatter_sigma_um, halation_radius_um;
    std::optional<filmgrain::HalationKernel> halation_kernel;
    std::optional<double> base_thickness_um, base_refractive_index;
    std::optional<filmgrain::RearFace> rear_face;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a.size() > 1 && a[0] == '-')
            cmd.given.insert(a);
        const auto next = [&](const char* what) -> std::string {
            if (i + 1 >= argc) {
                std::cerr << "filmgrain-fit: " << a << " needs " << what << "\n";
                std::exit(2);
            }
            return argv[++i];
        };
        const auto integer = [&](const char* what, long lo, long hi) -> long {
            const std::string v = next(what);
            uint64_t x          = 0;
            std::string why;
            if (!filmgrain::parse_count(v, static_cast<uint64_t>(hi), x, why)
                || x < static_cast<uint64_t>(lo)) {
                std::cerr << "filmgrain-fit: " << a << " " << v << ": must be an integer in ["
                          << lo << ", " << hi << "]\n";
                std::exit(2);
            }
            return x;
        };
        const auto number = [&](const char* what, double lo, double hi) -> double {
            const std::string v = next(what);
            double x            = NAN;
            std::string why;
            if (!filmgrain::parse_decimal(v, x, why) || !(x >= lo && x <= hi)) {
                std::cerr << "filmgrain-fit: " << a << " " << v << ": must be a number in [" << lo
                          << ", " << hi << "]\n";
                std::exit(2);
            }
            return x;
        };
        // One of the names (filmgrain/names.h) of the enumeration of `e`:
        // its value; exits 2 on another word.
        const auto choice = [&](auto e) {
            const auto& names = names_of(e);
            std::string list;  // "a, b or c"
            size_t k = 0;
            for (const auto& n : names)
                list += (k++ == 0 ? "" : k == std::size(names) ? " or " : ", ")
                        + std::string(n.name);
            const std::string v = next(list.c_str());
            if (filmgrain::parse_name(v, e))
                return e;
            std::cerr << "filmgrain-fit: " << a << " " << v << ": must be " << list << "\n";
            std::exit(2);
        };
        // LAYER=FRACTION,... (--scatter, --halation): fractions in [0, 1].
        const auto per_layer = [&](std::map<std::string, double>& out) {
            const std::string v = next("LAYER=FRACTION,...");
            for (const std::string& item : split_commas(a, v)) {
                const size_t eq = item.find('=');
                double x        = NAN;
                std::string why;
                if (eq == 0 || eq == std::string::npos
                    || !filmgrain::parse_decimal(std::string_view(item).substr(eq + 1), x, why)
                    || !(x >= 0.0 && x <= 1.0) || out.count(item.substr(0, eq))) {
                    std::cerr << "filmgrain-fit: " << a << " " << v << ": '" << item
                              << "' is not LAYER=FRACTION with a fraction in [0, 1] (each layer once)\n";
                    std::exit(2);
                }
                out[item.substr(0, eq)] = x;
            }
        };
        if (a == "--help" || a == "-h") {
            usage(std::cout);
            return 0;
        } else if (a == "-o") {
            cmd.out_path = next("a file");
        } else if (a == "--report") {
            cmd.report_dir = next("a directory");
        } else if (a == "--measure") {
            cmd.measure_path = next("a stock");
        } else if (a == "--seed") {
            const std::string v = next("a number");
            uint64_t seed       = 0;
            std::string why;
            if (!filmgrain::parse_count(v, UINT64_MAX, seed, why)) {
                std::cerr << "filmgrain-fit: --seed " << v << ": not an unsigned integer\n";
                return 2;
            }
            opt.seed = seed;
        } else if (a == "--populations") {
            opt.populations = static_cast<int>(integer("N", 1, 4));
        } else if (a == "--starts") {
            opt.starts = static_cast<int>(integer("N", 1, 16));
        } else if (a == "--population-evals") {
            opt.population_evals = static_cast<int>(integer("N", 1, 1000000));
        } else if (a == "--rate-evals") {
            opt.rate_evals = static_cast<int>(integer("N", 1, 100000));
        } else if (a == "--rounds") {
            opt.rounds = static_cast<int>(integer("N", 1, 8));
        } else if (a == "--render-check") {
            cmd.check = true;
        } else if (a == "--no-rates") {
            opt.fit_rates = false;
        } else if (a == "--image") {
            opt.image = choice(filmgrain::LayerImage {});
        } else if (a == "--cloud-profile") {
            opt.cloud_profile = choice(filmgrain::CloudProfile {});
        } else if (a == "--coupler-limited") {
            opt.coupler_limited = static_cast<int>(integer("N", 0, 4));
        } else if (a == "--start-cloud-ratio") {
            opt.start_cloud_ratio = number("a number", 0.5, 2.0);
        } else if (a == "--max-log-sigma") {
            opt.max_log_sigma = number("a number", 0.05, 0.8);
        } else if (a == "--scatter") {
            per_layer(scatter);
        } else if (a == "--scatter-sigma-um") {
            scatter_sigma_um = number("micrometres", 0.0, 1000.0);
        } else if (a == "--halation") {
            per_layer(halation);
        } else if (a == "--halation-radius-um") {
            halation_radius_um = number("micrometres", 0.0, 5000.0);
        } else if (a == "--halation-kernel") {
            halation_kernel = choice(filmgrain::HalationKernel {});
        } else if (a == "--base-thickness-um") {
            base_thickness_um = number("micrometres", 0.0, 2000.0);
        } else if (a == "--base-refractive-index") {
            base_refractive_index = number("a number", 1.3, 2.0);
        } else if (a == "--rear-face") {
            rear_face = choice(filmgrain::RearFace {});
        } else if (a == "--no-light-spread") {
            cmd.no_light_spread = true;
        } else if (a == "--inhibition") {
            opt.inhibition = true;
        } else if (a == "--no-inhibition") {
            opt.inhibition = false;
        } else if (a == "--start") {
            cmd.start_path = next("a stock");
        } else if (a == "--layers") {
            opt.layers = split_commas(a, next("layer names"));
        } else if (a == "--name") {
            cmd.name = next("a name");
        } else if (a == "--threads") {
            const int t = static_cast<int>(integer("N", 0, 1024));
            opt.search_curve.nthreads = opt.rate_curve.nthreads = opt.final_curve.nthreads = t;
        } else if (a == "-q") {
            cmd.quiet = true;
        } else if (!a.empty() && a[0] == '-') {
            std::cerr << "filmgrain-fit: unknown option " << a << " (see --help)\n";
            return 2;
        } else if (cmd.sheet_path.empty()) {
            cmd.sheet_path = a;
        } else {
            std::cerr << "filmgrain-fit: more than one datasheet (" << cmd.sheet_path << ", " << a
                      << ")\n";
            return 2;
        }
    }
    // Nothing silently ignored: a width without its fraction is an error.
    if ((scatter_sigma_um && scatter.empty()) || (halation_radius_um && halation.empty())
        || (halation_kernel && halation.empty())) {
        std::cerr << "filmgrain-fit: --scatter-sigma-um needs --scatter, --halation-radius-um "
                     "and --halation-kernel need --halation\n";
        return 2;
    }
    const bool base_kernel = halation_kernel == filmgrain::HalationKernel::base;
    if ((base_thickness_um || base_refractive_index || rear_face) && !base_kernel) {
        std::cerr << "filmgrain-fit: --base-thickness-um, --base-refractive-index and "
                     "--rear-face describe the base that --halation-kernel base reads\n";
        return 2;
    }
    if (base_kernel && halation_radius_um) {
        std::cerr << "filmgrain-fit: --halation-radius-um sizes the disc and ring kernels; "
                     "the base kernel's size follows from --base-thickness-um\n";
        return 2;
    }
    if (base_kernel && base_thickness_um) {
        // Without it, the start's base (none without a start: the fitted
        // stock's check then names base_thickness_um).
        filmgrain::fit::FitOptions::FilmBase base;
        base.thickness_um     = *base_thickness_um;
        base.refractive_index = base_refractive_index.value_or(base.refractive_index);
        base.rear_face        = rear_face.value_or(base.rear_face);
        opt.film_base         = base;
    } else if (base_kernel && (base_refractive_index || rear_face)) {
        std::cerr << "filmgrain-fit: --base-refractive-index and --rear-face need "
                     "--base-thickness-um (without it, the --start stock's base is kept whole)\n";
        return 2;
    }
    for (const auto* list : { &scatter, &halation })
        for (const auto& [layer, fraction] : *list) {
            filmgrain::fit::FitOptions::LayerSpread& ls = opt.light_spread[layer];
            if (list == &scatter) {
                ls.scatter          = fraction;
                ls.scatter_sigma_um = scatter_sigma_um.value_or(0.0);
            } else {
                ls.halation           = fraction;
                ls.halation_radius_um = halation_radius_um.value_or(0.0);
                ls.halation_kernel    = halation_kernel.value_or(filmgrain::HalationKernel::disc);
            }
        }
    if (cmd.no_light_spread && (!opt.light_spread.empty() || base_kernel)) {
        std::cerr << "filmgrain-fit: --no-light-spread with --scatter or --halation\n";
        return 2;
    }
    if (!opt.light_spread.empty() && !cmd.measure_path.empty()) {
        std::cerr << "filmgrain-fit: --scatter and --halation set a fitted stock's spread; "
                     "--measure measures a stock as it is\n";
        return 2;
    }
    if (cmd.sheet_path.empty() || (cmd.out_path.empty() && cmd.measure_path.empty())) {
        usage(std::cerr);
        return 2;
    }
    return std::nullopt;
}

/// The recipe's choice (filmgrain::fit::recipe_for) for every fit option
/// the command line left unset; a --start stock keeps its own images,
/// cloud limits and light spread. Says the recipe in the progress lines.
void apply_recipe(const sm::Datasheet& sheet, FitCommand& cmd)
{
    const filmgrain::fit::FitRecipe r = filmgrain::fit::recipe_for(sheet);
    filmgrain::fit::FitOptions& opt   = cmd.opt;
    std::vector<std::string> overridden;
    const auto unset = [&](const char* option) {
        if (!cmd.given.count(option))
            return true;
        overridden.push_back(option);
        return false;
    };
    if (unset("--populations"))
        opt.populations = r.options.populations;
    if (unset("--starts"))
        opt.starts = r.options.starts;
    if (unset("--population-evals"))
        opt.population_evals = r.options.population_evals;
    if (unset("--rounds"))
        opt.rounds = r.options.rounds;
    if (unset("--max-log-sigma"))
        opt.max_log_sigma = r.options.max_log_sigma;
    const bool start = !cmd.start_path.empty();
    if (!start) {
        if (unset("--cloud-profile"))
            opt.cloud_profile = r.options.cloud_profile;
        // Coupler limits need dye layers of disc clouds: not where the
        // command line asks for silver or gaussian clouds.
        const filmgrain::LayerImage image = opt.image.value_or(
            sheet.kind == "colour-negative" ? filmgrain::LayerImage::dye
                                            : filmgrain::LayerImage::silver);
        const bool disc_dye = opt.cloud_profile == filmgrain::CloudProfile::disc
                              && image == filmgrain::LayerImage::dye;
        if (unset("--coupler-limited")) {
            if (disc_dye)
                opt.coupler_limited = r.options.coupler_limited;
            else if (r.options.coupler_limited > 0)
                overridden.push_back("layers' image (no coupler limits: they need disc dye "
                                     "clouds)");
        }
        if (unset("--start-cloud-ratio"))
            opt.start_cloud_ratio = r.options.start_cloud_ratio;
        const bool spread_given = cmd.no_light_spread || !opt.light_spread.empty()
                                  || opt.film_base.has_value();
        if (spread_given && !r.options.light_spread.empty())
            overridden.push_back("the light spread");
        if (!spread_given) {
            opt.light_spread = r.options.light_spread;
            opt.film_base    = r.options.film_base;
        }
    }
    if (!opt.progress)
        return;
    for (const std::string& why : r.reasons)
        opt.progress("recipe: " + why);
    if (start)
        opt.progress("recipe: --start: the start stock's images, cloud limits and light "
                     "spread are kept");
    if (!overridden.empty()) {
        std::string list;
        for (const std::string& o : overridden)
            list += (list.empty() ? "" : ", ") + o;
        opt.progress("recipe: the command line's own " + list);
    }
}

/// What a fit or a measurement found (a measurement: no evaluations, 0 s).
using Outcome = filmgrain::fit::FitResult;

/// Measures --measure's stock, or fits one and writes it to -o.
Status fit_or_measure(const FitCommand& cmd, const sm::Datasheet& sheet, Outcome& out)
{
    if (!cmd.measure_path.empty()) {
        if (Status s = filmgrain::load_stock(cmd.measure_path, out.stock); !s)
            return s;
        return filmgrain::fit::measure(out.stock, sheet, cmd.opt.final_curve, out.figures,
                                       out.comparisons);
    }
    filmgrain::fit::FitOptions opt = cmd.opt;
    if (!cmd.start_path.empty()) {
        Stock start;
        if (Status s = filmgrain::load_stock(cmd.start_path, start); !s)
            return s;
        opt.start = start;
    }
    if (opt.progress)
        opt.progress("fitting " + sheet.name + " (" + cmd.sheet_path + "), seed "
                     + std::to_string(opt.seed));
    if (Status s = filmgrain::fit::fit_stock(sheet, opt, out); !s)
        return s;
    if (!cmd.name.empty())
        out.stock.name = cmd.name;
    return filmgrain::write_whole_file(cmd.out_path,
                                       filmgrain::stock_to_json(out.stock, 2) + "\n");
}

/// What the model cannot reach for this datasheet: model_limits's bounds,
/// which hold for images that add (silver, MODEL.md 8's clouds); a
/// coupler-limited population's noise falls as its clouds fill the plane,
/// which they do not bound.
std::vector<std::string> limits_of(const FitCommand& cmd, const sm::Datasheet& sheet,
                                   const Stock& stock)
{
    for (const filmgrain::Layer& l : stock.layers)
        if (filmgrain::has_coupler_limit(l))
            return {};
    // The grains each datasheet layer may hold: the search's bound for a fit
    // (every population at its most), the stock's own for a measurement.
    std::vector<double> layer_grains_per_um2;
    for (const auto& t : sheet.layers) {
        double sum = 0.0;
        for (const filmgrain::Layer& l : stock.layers)
            if (l.name == t.name)
                for (const filmgrain::Population& p : l.populations)
                    sum += cmd.measure_path.empty()
                               ? filmgrain::fit::kMaxGrainsPerPopulationPerUm2
                               : p.grains_per_um2;
        layer_grains_per_um2.push_back(sum);
    }
    return filmgrain::fit::model_limits(sheet, stock.inhibits(), layer_grains_per_um2);
}

/// --report DIR: report.md, figures.json, curves.csv, granularity.csv.
void write_report(const FitCommand& cmd, const sm::Datasheet& sheet, const Outcome& o,
                  const std::string& table, int missed, const std::vector<std::string>& limits)
{
    const std::string& dir = cmd.report_dir;
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    std::ofstream md(dir + "/report.md");
    md << "# " << o.stock.name << " against the datasheet " << sheet.name << "\n\n"
       << "Datasheet: `" << cmd.sheet_path << "`. Figures measured analytically from the model's "
          "expected curves and Boolean-model aperture variance "
          "(tools/sensitometry/datasheet.h says how each is defined); the error bound is "
          "the expected curve's stated density error carried into each figure.\n\n";
    if (cmd.measure_path.empty())
        md << "Fitted in " << o.seconds << " s (" << o.evaluations
           << " objective evaluations), seed " << cmd.opt.seed << ", " << cmd.opt.populations
           << " populations per layer.\n\n";
    md << table << "\n"
       << (missed ? "**" + std::to_string(missed) + " figures missed** (above).\n"
                  : "Every figure is within the issue's tolerance.\n");
    if (!limits.empty()) {
        md << "\n## What the model cannot reach\n\n";
        for (const std::string& l : limits)
            md << "- " << l << ".\n";
    }
    nlohmann::json j = figures_json(o.figures, o.comparisons);
    j["stock"]       = nlohmann::json::parse(filmgrain::stock_to_json(o.stock));
    j["fit_seconds"] = o.seconds;
    std::ofstream(dir + "/figures.json") << j.dump(2) << "\n";
    if (Status s = write_curves(o.stock, sheet, cmd.opt.final_curve, dir + "/curves.csv"); !s)
        std::cerr << "filmgrain-fit: " << s.message() << "\n";
    if (Status s = write_granularity(o.stock, sheet, cmd.opt.final_curve,
                                     dir + "/granularity.csv");
        !s)
        std::cerr << "filmgrain-fit: " << s.message() << "\n";
}

/// --render-check: renders the patches of every analytic figure and
/// compares; 0 when every row agrees, else 1.
int render_check(const FitCommand& cmd, const sm::Datasheet& sheet, const Outcome& o)
{
    const Stock& stock = o.stock;
    std::vector<filmgrain::fit::RenderCheckRow> rows;
    if (Status s = filmgrain::fit::render_check(stock, sheet, o.figures, cmd.opt.seed,
                                                cmd.opt.final_curve.nthreads, cmd.opt.progress,
                                                rows);
        !s) {
        std::cerr << "filmgrain-fit: render check: " << s.message() << "\n";
        return 1;
    }
    std::ostringstream md;
    md << "| figure | analytic | bound | rendered (exact engine) | standard error | z | |\n"
          "| --- | --- | --- | --- | --- | --- | --- |\n";
    int disagree = 0;
    for (const auto& r : rows) {
        disagree += r.agrees() ? 0 : 1;
        md << "| " << r.figure << " | " << r.analytic << " | " << r.analytic_error << " | "
           << r.rendered << " | " << r.rendered_se << " | "
           << (r.rendered_se > 0.0 ? (r.rendered - r.analytic) / r.rendered_se : 0.0) << " | "
           << (r.agrees() ? "agrees" : "**disagrees**") << " |\n";
    }
    md << (disagree ? std::to_string(disagree) + " rows disagree (beyond 3 standard errors "
                                                 "plus the analytic bound)\n"
                    : "every row agrees within 3 standard errors plus the analytic bound\n");
    std::cout << "\nrender check:\n" << md.str();
    // Which layers were rendered alone (render_check): say so.
    std::string alone, together;
    for (size_t l = 0; l < stock.layers.size(); ++l)
        (filmgrain::fit::layer_develops_alone(stock, l) ? alone : together)
            += (std::string(1, ' ') + stock.layers[l].name);
    std::string layers;
    if (stock.layers.size() > 1) {
        layers = " Each layer's patches render";
        if (!alone.empty())
            layers += " the layer alone where no other layer inhibits it (every effect "
                      "but MODEL.md 10's inhibition acts within a layer):" + alone;
        if (!together.empty())
            layers += std::string(alone.empty() ? "" : ";") + " the whole stock where "
                      "another layer inhibits it:" + together;
        layers += ".";
    }
    if (!cmd.report_dir.empty())
        std::ofstream(cmd.report_dir + "/render_check.md")
            << "# Render check: " << stock.name << "\n\nThe analytic figures beside "
               "patches rendered with the exact engine and read by tools/sensitometry "
               "(expose_patch, read_granularity), seed " << cmd.opt.seed << "." << layers
            << " Agreement: |rendered - analytic| <= 3 standard errors + the analytic "
               "bound.\n\n"
            << md.str();
    return disagree ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv)
{
    // A fit builds P(develop | N) tables for thousands of trial stocks, each
    // used once: none is kept on disk (kinetics_table.h), unless the caller
    // names a cache directory.
    setenv("FILMGRAIN_CACHE_DIR", "off", /*overwrite=*/0);
    FitCommand cmd;
    if (const std::optional<int> exit_status = parse_command_line(argc, argv, cmd))
        return *exit_status;
    sm::Datasheet sheet;
    if (Status s = sm::load_datasheet(cmd.sheet_path, sheet); !s) {
        std::cerr << "filmgrain-fit: " << s.message() << "\n";
        return 1;
    }
    const auto t0 = std::chrono::steady_clock::now();
    if (!cmd.quiet)
        cmd.opt.progress = [t0](const std::string& line) {
            std::cerr << stamp(std::chrono::duration<double>(std::chrono::steady_clock::now()
                                                             - t0)
                                   .count())
                      << line << std::endl;
        };
    if (cmd.measure_path.empty())
        apply_recipe(sheet, cmd);
    Outcome o;
    if (Status s = fit_or_measure(cmd, sheet, o); !s) {
        std::cerr << "filmgrain-fit: " << s.message() << "\n";
        return 1;
    }
    const std::string table = filmgrain::fit::comparison_table(o.comparisons);
    int missed              = 0;
    for (const auto& c : o.comparisons)
        missed += c.met() ? 0 : 1;
    const std::vector<std::string> limits = limits_of(cmd, sheet, o.stock);
    std::cout << table;
    for (const std::string& l : limits)
        std::cout << "model limit: " << l << "\n";
    std::cout << (missed ? std::to_string(missed) + " of " + std::to_string(o.comparisons.size())
                               + " figures missed their tolerance"
                         : "every figure within tolerance (" + std::to_string(o.comparisons.size())
                               + ")")
              << "\n";
    if (!cmd.report_dir.empty())
        write_report(cmd, sheet, o, table, missed, limits);
    if (cmd.check && render_check(cmd, sheet, o) != 0)
        return 1;
    return missed ? 3 : 0;
}
