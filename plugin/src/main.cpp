// filmgrain: the command-line tool. oiiotool-shaped; see `filmgrain --help`.
//
// main() only orders the stages: parse the command line, then per image
// (frame_render.h) read the input (or make the wedge or the chart), convert
// it to scene-linear (scene_linear.h), run the operator, write the outputs
// all-or-nothing. It does no maths of its own; console.h shows progress
// and catches interruptions.
#include <OpenImageIO/imageio.h>

#include <nlohmann/json.hpp>
#include <unistd.h>

#include <exception>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "cli_args.h"
#include "console.h"
#include "filmgrain/chart.h"
#include "filmgrain/version.h"
#include "filmgrain/wedge.h"
#include "frame_render.h"
#include "input_image.h"
#include "sequence.h"
#include "stats_json.h"

namespace filmgrain::cli {

namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------
// Informational commands.

int list_stocks()
{
    for (const std::string& name : preset_names()) {
        Stock stock;
        const Status s = load_stock(name, stock);
        std::cout << name << (name == default_preset_name() ? " (default)" : "") << "\n    "
                  << (s ? stock.description : "cannot load: " + s.message()) << "\n";
    }
    return 0;
}

int print_stock(const std::string& name_or_path, const Console& con)
{
    Stock stock;
    if (Status s = load_stock(name_or_path, stock); !s)
        return con.fail(s);
    std::cout << stock_to_json(stock, 2) << "\n";
    return 0;
}

// ---------------------------------------------------------------------------
// Rendering: every frame of the command line.

int render(const CliArgs& a, const Console& con)
{
    const auto t_start = Clock::now();
    if (Status s = validate_render_args(a); !s)
        return con.fail(s);
    std::vector<FrameJob> jobs;
    if (Status s = plan_frames(a, jobs); !s)
        return con.fail(s);

    RenderContext ctx { a, con, {}, std::make_shared<std::vector<ExpectedCurve>>() };
    const FilmgrainCommand& cmd = a.filmgrain;
    if (Status s = load_stock(cmd.stock, ctx.opts.stock); !s)
        return con.fail(s);
    ctx.opts.scene = cmd.scene;
    if (a.wedge && !cmd.has_width_mm)
        ctx.opts.scene.width_mm = WedgeSpec().strip_width_mm;
    if (a.chart && !cmd.has_width_mm)
        ctx.opts.scene.width_mm = ChartSpec().strip_width_mm;
    ctx.opts.engine_options = cmd.engine_options;
    ctx.opts.scan_width     = cmd.scan_width;
    ctx.opts.scan_height    = cmd.scan_height;
    ctx.opts.tile_size_px   = cmd.tile_size_px;

    if (a.dry_run) {
        for (const FrameJob& job : jobs) {
            FilmgrainOptions opts = ctx.opts;
            if (job.frame)
                opts.scene.frame = *job.frame;
            const std::string hash = settings_hash(ctx, opts, job);
            std::error_code ec;
            const bool exists = a.wedge || a.chart || fs::exists(job.input, ec);
            // What the render would refuse from the input's header (its
            // pixels are not read): null when nothing.
            std::string refusal;
            if (exists && !a.wedge && !a.chart) {
                InputHeader input;
                Status st = read_input_header(job.input, a.input_selection, input);
                if (st)
                    if (Status o = check_output_size(opts, input.spec, cmd); !o)
                        st = Status::errorf("input '", job.input, "': ", o.message());
                if (!st)
                    refusal = st.message();
            }
            const nlohmann::ordered_json line
                = { { "frame", frame_json<nlohmann::ordered_json>(job.frame) },
                    { "input", a.wedge   ? std::string("wedge")
                               : a.chart ? std::string("chart")
                                         : job.input },
                    { "output", job.output },
                    { "stats", job.stats },
                    { "preview", job.preview },
                    { "input_exists", exists },
                    { "error", refusal.empty() ? nlohmann::ordered_json(nullptr)
                                               : nlohmann::ordered_json(refusal) },
                    { "settings_hash", hash },
                    { "up_to_date", up_to_date(job, hash) } };
            std::cout << line.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace)
                      << "\n";
        }
        return 0;
    }

    const bool sequence = jobs.front().frame.has_value();
    size_t rendered = 0, skipped = 0, missing = 0;
    for (size_t i = 0; i < jobs.size(); ++i) {
        const FrameJob& job = jobs[i];
        const std::string where
            = sequence ? "frame " + std::to_string(*job.frame) + ": " : std::string();
        con.set_frame(i, sequence ? jobs.size() : 0, job.frame);
        if (Status s = check_outputs_spare_inputs(a, job); !s)
            return con.fail(where + s.message());
        const auto t_frame   = Clock::now();
        FrameOutcome outcome = FrameOutcome::rendered;
        const Status s       = render_one(ctx, job, outcome);
        if (interrupted())
            return con.fail_interrupted(
                sequence ? where + "not written; " + std::to_string(rendered)
                               + " frames written before it are complete"
                         : std::string("no output written"));
        if (!s)
            return con.fail(where + s.message());
        rendered += outcome == FrameOutcome::rendered;
        skipped += outcome == FrameOutcome::up_to_date;
        missing += outcome == FrameOutcome::missing;
        if (a.report_json)
            std::cout << nlohmann::ordered_json {
                { "frame", frame_json<nlohmann::ordered_json>(job.frame) },
                { "output", job.output },
                { "outcome", name_of(outcome) },
                { "seconds", seconds_since(t_frame) } }
                    .dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace)
                      << std::endl;
    }
    if (sequence)
        con.info("sequence of " + std::to_string(jobs.size()) + " frames: "
                 + std::to_string(rendered) + " rendered, " + std::to_string(skipped)
                 + " up to date (skipped), " + std::to_string(missing)
                 + " missing input (skipped) in " + format_seconds(seconds_since(t_start))
                 + " s");
    return 0;
}

int run(int argc, const char** argv)
{
    if (wants_help(argc, argv)) {
        std::cout << help_text();
        return 0;
    }
    CliArgs args;
    if (Status s = parse_command_line(argc, argv, args); !s)
        return Console(false, false).fail(s);
    const Console con(args.quiet, ::isatty(STDERR_FILENO) != 0, args.progress);
    for (const std::string& notice : args.filmgrain.notices)
        con.warning(notice);

    if (args.version || args.list_stocks || args.list_options || !args.print_stock.empty()) {
        if (!args.input.empty() || args.wedge || args.chart || args.has_filmgrain
            || !args.output.empty())
            return con.fail("--version, --list-stocks, --list-options and --print-stock print "
                            "and exit: do not combine them with INPUT, --wedge, --chart, "
                            "--filmgrain or -o");
        if (args.version)
            std::cout << "filmgrain " << version_string() << " (OpenImageIO "
                      << OIIO_VERSION_STRING << ")\n";
        if (args.list_stocks)
            list_stocks();
        if (args.list_options)
            std::cout << options_json();
        if (!args.print_stock.empty())
            return print_stock(args.print_stock, con);
        return 0;
    }
    if (argc <= 1) {
        std::cerr << help_text();
        return kExitError;
    }

    install_signal_handlers();
    if (args.threads > 0)
        OIIO::attribute("threads", args.threads);
    return render(args, con);
}

}  // namespace

}  // namespace filmgrain::cli

int main(int argc, const char** argv)
{
    int status = filmgrain::cli::kExitError;
    try {
        status = filmgrain::cli::run(argc, argv);
    } catch (const std::exception& e) {
        std::cerr << "filmgrain: error: internal error: " << e.what() << std::endl;
    } catch (...) {
        std::cerr << "filmgrain: error: internal error (unknown exception)" << std::endl;
    }
    // Leave no OIIO error pending (OIIO reports those at exit).
    OIIO::geterror();
    return status;
}
