// filmgrain Python module: the extension `filmgrain._filmgrain`.
//
// A thin adapter, like the CLI: it holds no physics and no option parsing
// of its own. The keyword arguments of filmgrain.render() arrive here as a
// `--filmgrain:key=value` modifier string (built by python/filmgrain/
// __init__.py) and are parsed by the CLI's own parser
// (filmgrain::cli::parse_filmgrain_modifiers), so validation, defaults and
// messages are the CLI's. The render runs through the same operator as the
// CLI (filmgrain::IBA::filmgrain), so the output is bit-identical, and the
// statistics are the CLI's --stats document (filmgrain::cli::stats_json).
//
// The public, documented API is the pure-Python package; the functions here
// are private (their names start with '_' on the Python side).
#include <OpenImageIO/half.h>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>

#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <climits>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "filmgrain/imagebufalgo_filmgrain.h"
#include "filmgrain/render.h"
#include "filmgrain/stock.h"
#include "filmgrain/version.h"
#include "modifiers.h"
#include "output_transform.h"
#include "stats_json.h"

namespace py = pybind11;

namespace filmgrain::python {

namespace {

/// A failure reported by the core, the operator or the modifier parser:
/// becomes filmgrain.Error (a ValueError) carrying the message unchanged.
class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

std::string trim(std::string s)
{
    while (!s.empty() && (s.back() == '\n' || s.back() == ' '))
        s.pop_back();
    return s;
}

/// The operator's messages start with its name, as OIIO's do; the CLI
/// prints them without it, and so do we.
std::string operator_message(const OIIO::ImageBuf& dst)
{
    std::string msg = trim(dst.geterror());
    const std::string prefix = "filmgrain: ";
    if (msg.rfind(prefix, 0) == 0)
        msg.erase(0, prefix.size());
    return msg.empty() ? std::string("render failed") : msg;
}

/// Python objects attached to a render: an optional progress callable and
/// the exception (KeyboardInterrupt from Ctrl-C, or one raised by the
/// callable) that cancelled it. Used only with the GIL held.
struct Interruption {
    py::object progress;  ///< None or callable(fraction) -> bool-ish
    PyObject* type  = nullptr;
    PyObject* value = nullptr;
    PyObject* trace = nullptr;

    /// Called about ten times a second from the rendering thread (which
    /// released the GIL): takes the GIL briefly, runs pending signal
    /// handlers (Ctrl-C raises KeyboardInterrupt there) and the progress
    /// callable. False cancels the render.
    bool poll(double fraction)
    {
        py::gil_scoped_acquire gil;
        if (type)
            return false;
        if (PyErr_CheckSignals() != 0) {
            PyErr_Fetch(&type, &value, &trace);
            return false;
        }
        if (progress.is_none())
            return true;
        try {
            py::object r = progress(fraction);
            return r.is_none() || r.cast<bool>();
        } catch (py::error_already_set& e) {
            e.restore();
            PyErr_Fetch(&type, &value, &trace);
        } catch (const std::exception& e) {
            PyErr_SetString(PyExc_RuntimeError, e.what());
            PyErr_Fetch(&type, &value, &trace);
        }
        return false;
    }

    /// Re-raises the saved exception, if any (GIL held).
    void rethrow()
    {
        if (!type)
            return;
        PyErr_Restore(type, value, trace);
        type = value = trace = nullptr;
        throw py::error_already_set();
    }

    ~Interruption()
    {
        Py_XDECREF(type);
        Py_XDECREF(value);
        Py_XDECREF(trace);
    }
};

/// Where the array's pixels sit on the film frame, as an ImageBuf's windows:
/// (x, y, full_x, full_y, full_width, full_height). None: the array is the
/// whole frame (data window = display window at 0, 0).
using Window = std::optional<std::tuple<int, int, int, int, int, int>>;

/// render(pixels, modifiers, stock_name, stock_json, threads, progress,
/// window, ocolorspace, colorconfig) -> (density, stats_json, attributes,
/// data_window, channels).
/// pixels: C-contiguous float32 (height, width, channels); the Python layer
/// has checked dtype and shape and made it contiguous, this checks again.
py::tuple render(py::array pixels, const std::string& modifiers,
                 const std::optional<std::string>& stock_name,
                 const std::optional<std::string>& stock_json, long long threads,
                 py::object progress, const Window& window,
                 const std::optional<std::string>& ocolorspace,
                 const std::optional<std::string>& colorconfig)
{
    const auto t_start = std::chrono::steady_clock::now();
    if (!py::isinstance<py::array_t<float>>(pixels) || pixels.ndim() != 3
        || !(pixels.flags() & py::array::c_style))
        throw py::type_error("internal: _render takes a C-contiguous float32 array "
                             "(height, width, channels)");
    const py::ssize_t height = pixels.shape(0), width = pixels.shape(1),
                      nchannels = pixels.shape(2);
    if (height < 1 || width < 1 || nchannels < 1)
        throw Error("pixels has shape (" + std::to_string(height) + ", " + std::to_string(width)
                    + ", " + std::to_string(nchannels)
                    + "): an image needs at least one pixel and one channel");
    if (height > INT_MAX || width > INT_MAX || nchannels > INT_MAX)
        throw Error("pixels has shape (" + std::to_string(height) + ", " + std::to_string(width)
                    + ", " + std::to_string(nchannels)
                    + "): an OpenImageIO image side must be at most "
                    + std::to_string(INT_MAX));
    // The CLI's --threads range.
    if (threads < 0 || threads > 4096)
        throw Error("threads = " + std::to_string(threads)
                    + ": expected a whole number of threads in [0, 4096] (0: all)");

    // The options, as the CLI's render() maps its FilmgrainCommand.
    cli::FilmgrainCommand cmd;
    if (Status s = cli::parse_filmgrain_modifiers(modifiers, cmd); !s)
        throw Error(s.message());
    FilmgrainOptions opts;
    if (stock_json) {
        if (Status s = parse_stock_json(*stock_json, "stock dict", opts.stock); !s)
            throw Error(s.message());
    } else if (Status s = load_stock(stock_name ? *stock_name : cmd.stock, opts.stock); !s) {
        throw Error(s.message());
    }
    opts.scene          = cmd.scene;
    opts.engine_options = cmd.engine_options;
    opts.scan_width     = cmd.scan_width;
    opts.scan_height    = cmd.scan_height;
    opts.tile_size_px   = cmd.tile_size_px;
    OIIO::ROI roi;  // undefined: the whole scan
    if (cmd.has_roi)
        roi = OIIO::ROI(static_cast<int>(cmd.roi_x), static_cast<int>(cmd.roi_x + cmd.roi_width),
                        static_cast<int>(cmd.roi_y),
                        static_cast<int>(cmd.roi_y + cmd.roi_height));

    // The array, wrapped (not copied) as the operator's source image.
    OIIO::ImageSpec spec(static_cast<int>(width), static_cast<int>(height),
                         static_cast<int>(nchannels), OIIO::TypeFloat);
    if (window) {
        const auto& [x, y, full_x, full_y, full_width, full_height] = *window;
        spec.x           = x;
        spec.y           = y;
        spec.full_x      = full_x;
        spec.full_y      = full_y;
        spec.full_width  = full_width;
        spec.full_height = full_height;
    }
    // The operator only reads src; ImageBuf's constructor wants a mutable pointer.
    OIIO::ImageBuf src(spec, const_cast<void*>(pixels.data()));

    Interruption interruption;
    interruption.progress = std::move(progress);
    opts.progress = [&interruption](double f) { return interruption.poll(f); };

    cli::RunReport report;
    report.stock_name       = opts.stock.name;
    report.scene            = opts.scene;
    report.input_file       = "<array>";
    report.input_colorspace = "scene_linear";

    OIIO::ImageBuf dst;
    bool ok = false;
    {
        py::gil_scoped_release nogil;
        const auto t = std::chrono::steady_clock::now();
        opts.stats = &report.render;
        ok         = IBA::filmgrain(dst, src, opts, roi, static_cast<int>(threads));
        report.seconds.simulate
            = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    }
    interruption.rethrow();  // Ctrl-C or the progress callable's exception
    if (!ok)
        throw Error(operator_message(dst));

    // output=: the CLI's transform of the density (ADX code values, the
    // regrain positive in the config's scene_linear), as the CLI applies it.
    report.output = cli::output_kind_name(cmd.output);
    {
        OIIO::ImageBuf transformed;  // the density itself stays in place
        OIIO::ImageBuf& result = cmd.output == cli::OutputKind::density ? dst : transformed;
        cli::OutputReport output_report;
        Status s;
        {
            py::gil_scoped_release nogil;
            cli::OutputRequest request;  // one render: no curves to share
            request.kind        = cmd.output;
            request.colorconfig = colorconfig.value_or("");
            request.ocolorspace = ocolorspace.value_or("");
            request.timing      = cmd.timing;
            s = cli::apply_output(request, opts, src, dst, result, output_report);
        }
        if (!s)
            throw Error(s.message());
        for (const std::string& w : output_report.warnings)
            if (PyErr_WarnEx(PyExc_UserWarning, w.c_str(), 1) < 0)
                throw py::error_already_set();  // warnings turned into errors
        if (&result != &dst)
            dst = std::move(result);
    }

    if (Status s = cli::report_scan(spec, opts, report); !s)
        throw Error(s.message());
    const OIIO::ROI data = dst.roi();
    report.roi           = Roi { data.xbegin, data.ybegin, data.xend, data.yend };

    // The metadata the operator wrote (filmgrain:*), with their types.
    py::list attributes;
    for (const OIIO::ParamValue& p : dst.spec().extra_attribs) {
        const std::string name = p.name().string();
        if (name.rfind("filmgrain:", 0) != 0)
            continue;
        if (p.type() == OIIO::TypeString)
            attributes.append(py::make_tuple(name, std::string(p.get_string())));
        else if (p.type() == OIIO::TypeInt)
            attributes.append(py::make_tuple(name, p.get_int()));
        else if (p.type() == OIIO::TypeFloat)
            attributes.append(py::make_tuple(name, p.get_float()));
        else
            attributes.append(py::make_tuple(name, std::string(p.get_string())));
    }
    py::list channels;
    for (const std::string& c : dst.spec().channelnames)
        channels.append(c);

    // The density array owns dst's pixels (no copy).
    const OIIO::ImageSpec& ds = dst.spec();
    const std::vector<py::ssize_t> shape = { ds.height, ds.width, ds.nchannels };
    auto* owner = new OIIO::ImageBuf(std::move(dst));
    py::capsule keep(owner, [](void* p) { delete static_cast<OIIO::ImageBuf*>(p); });
    py::array_t<float> density(shape, static_cast<float*>(owner->localpixels()), keep);

    report.seconds.total = std::chrono::duration<double>(std::chrono::steady_clock::now()
                                                         - t_start)
                               .count();
    return py::make_tuple(density, cli::stats_json(report), attributes,
                          py::make_tuple(data.xbegin, data.ybegin, data.width(), data.height(),
                                         report.scan.width, report.scan.height),
                          channels);
}

/// The stock `name_or_path` (a preset name or a JSON file) as JSON text with
/// every key present.
std::string stock_json(const std::string& name_or_path)
{
    Stock stock;
    if (Status s = load_stock(name_or_path, stock); !s)
        throw Error(s.message());
    return stock_to_json(stock, 2);
}

/// A stock given as JSON text, validated and completed with the defaults.
std::string parse_stock(const std::string& text, const std::string& origin)
{
    Stock stock;
    if (Status s = parse_stock_json(text, origin, stock); !s)
        throw Error(s.message());
    return stock_to_json(stock, 2);
}

/// The CLI's --filmgrain modifiers: (key, form, help, default), --help's order.
std::vector<std::tuple<std::string, std::string, std::string, std::string>> modifier_docs()
{
    std::vector<std::tuple<std::string, std::string, std::string, std::string>> out;
    for (const cli::ModifierDoc& d : cli::filmgrain_modifier_docs())
        out.emplace_back(d.key, d.form, d.help, d.default_text);
    return out;
}

}  // namespace

}  // namespace filmgrain::python

PYBIND11_MODULE(_filmgrain, m)
{
    namespace fp = filmgrain::python;
    m.doc() = "filmgrain's compiled core (private: use the `filmgrain` package).";
    py::register_exception<fp::Error>(m, "Error", PyExc_ValueError);
    m.def("render", &fp::render, py::arg("pixels"), py::arg("modifiers"),
          py::arg("stock_name"), py::arg("stock_json"), py::arg("threads"),
          py::arg("progress"), py::arg("window"), py::arg("ocolorspace"),
          py::arg("colorconfig"),
          "Private: see filmgrain.render.");
    m.def("stock_json", &fp::stock_json, py::arg("name_or_path"),
          "A preset or stock file as complete JSON text.");
    m.def("parse_stock", &fp::parse_stock, py::arg("text"), py::arg("origin"),
          "A stock's JSON text, validated and completed with the defaults.");
    m.def("preset_names", &filmgrain::preset_names, "Built-in preset names, the default first.");
    m.def("default_preset_name", []() { return std::string(filmgrain::default_preset_name()); });
    m.def("version", []() { return std::string(filmgrain::version_string()); });
    m.def("modifier_docs", &fp::modifier_docs,
          "The CLI's --filmgrain modifiers: (key, form, help, default).");
    m.def(
        "renamed_modifiers",
        []() {
            std::vector<std::pair<std::string, std::string>> out;
            for (const filmgrain::cli::RenamedModifier& r : filmgrain::cli::renamed_modifiers())
                out.emplace_back(r.old_key, r.key);
            return out;
        },
        "The CLI's renamed --filmgrain modifiers: (old name, name now).");
}
