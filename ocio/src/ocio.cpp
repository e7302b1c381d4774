// filmgrain: per-grain film simulation.
// OpenColorIO conversions (see filmgrain/ocio.h). A thin adapter: it loads a
// config, builds one CPU processor and runs it; it holds no physics.
#include <filmgrain/ocio.h>

#include <OpenColorIO/OpenColorIO.h>

#include <algorithm>
#include <cstddef>
#include <cstdlib>
#include <exception>
#include <limits>
#include <sstream>
#include <utility>

namespace OCIO = OCIO_NAMESPACE;

namespace filmgrain::ocio {

namespace detail {
// Defined in the generated filmgrain_minimal_ocio.cpp (see ../CMakeLists.txt).
extern const char* const k_filmgrain_minimal_ocio;
}  // namespace detail

namespace {

/// Pixels handed to OCIO per apply() call. OCIO converts a packed RGB row
/// through a scratch buffer of width * 4 floats allocated per call; chunking
/// bounds it (256 KiB here) whatever the tile size.
constexpr size_t k_chunk_pixels = 16384;

struct LoadedConfig {
    OCIO::ConstConfigRcPtr config;
    ConfigInfo info;
};

/// How a config is named in messages: "'<path>'", "'<path>' (from $OCIO)" or
/// "'embedded'".
std::string describe(const ConfigInfo& info)
{
    if (info.source == "embedded")
        return "'embedded'";
    std::string s = "'" + info.path + "'";
    if (info.source == "$OCIO")
        s += " (from $OCIO)";
    return s;
}

/// Resolution rules of filmgrain/ocio.h: explicit path, else $OCIO, else the
/// embedded config.
Status load_config(const std::string& config_path, LoadedConfig& out)
{
    out = LoadedConfig();
    const char* env = std::getenv("OCIO");
    if (!config_path.empty()) {
        out.info.source = "file";
        out.info.path   = config_path;
    } else if (env && *env) {
        out.info.source = "$OCIO";
        out.info.path   = env;
    } else {
        out.info.source = "embedded";
    }

    try {
        if (out.info.source == "embedded") {
            std::istringstream in(embedded_config_text());
            out.config = OCIO::Config::CreateFromStream(in);
        } else {
            out.config = OCIO::Config::CreateFromFile(out.info.path.c_str());
        }
    } catch (const std::exception& e) {  // OCIO::Exception is one
        out.config.reset();
        if (out.info.source == "embedded")
            return Status::errorf("cannot load the embedded OCIO config: ",
                                  e.what());
        return Status::errorf("cannot load OCIO config ", describe(out.info),
                              ": ", e.what());
    }
    if (!out.config) {
        return Status::errorf("cannot load OCIO config ", describe(out.info),
                              ": OCIO returned no config");
    }
    return Status();
}

/// Colour spaces (all, config order) then roles; no duplicates.
std::vector<std::string> known_names(const OCIO::Config& config)
{
    std::vector<std::string> names;
    auto add = [&names](const char* name) {
        if (name && *name
            && std::find(names.begin(), names.end(), name) == names.end())
            names.emplace_back(name);
    };
    const int ncs = config.getNumColorSpaces(OCIO::SEARCH_REFERENCE_SPACE_ALL,
                                             OCIO::COLORSPACE_ALL);
    for (int i = 0; i < ncs; ++i)
        add(config.getColorSpaceNameByIndex(OCIO::SEARCH_REFERENCE_SPACE_ALL,
                                            OCIO::COLORSPACE_ALL, i));
    for (int i = 0; i < config.getNumRoles(); ++i)
        add(config.getRoleName(i));
    return names;
}

/// Runs `cpu` over `count` pixels whose RGB floats start at `first` and are
/// `stride` floats apart, in chunks. OCIO cannot fail here for the
/// descriptors we build; should it throw anyway, the chunk's RGB is set to
/// NaN so the failure cannot pass unnoticed (no exception leaves the library
/// and apply_* returns void).
void run_cpu(const OCIO::ConstCPUProcessorRcPtr& cpu, float* first, size_t count, int stride)
{
    const ptrdiff_t x_stride_bytes = ptrdiff_t(stride) * ptrdiff_t(sizeof(float));
    for (size_t done = 0; done < count; done += k_chunk_pixels) {
        const size_t n = std::min(k_chunk_pixels, count - done);
        float* p       = first + done * size_t(stride);
        try {
            OCIO::PackedImageDesc desc(p, long(n), 1, OCIO::CHANNEL_ORDERING_RGB,
                                       OCIO::BIT_DEPTH_F32, ptrdiff_t(sizeof(float)),
                                       x_stride_bytes, x_stride_bytes * ptrdiff_t(n));
            cpu->apply(desc);
        } catch (...) {
            const float nan = std::numeric_limits<float>::quiet_NaN();
            for (size_t i = 0; i < n; ++i)
                std::fill_n(p + i * size_t(stride), 3, nan);
        }
    }
}

std::string join(const std::vector<std::string>& names)
{
    std::string s;
    for (const std::string& n : names) {
        if (!s.empty())
            s += ", ";
        s += n;
    }
    return s;
}

}  // namespace

struct InputConverter::Impl {
    ConfigInfo info;
    std::string source_colorspace;
    std::string scene_linear_colorspace;
    OCIO::ConstCPUProcessorRcPtr cpu;
    bool noop = true;

    void run(float* first, size_t count, int stride) const { run_cpu(cpu, first, count, stride); }
};

InputConverter::InputConverter(std::unique_ptr<Impl> impl)
    : m_impl(std::move(impl))
{
}

InputConverter::~InputConverter() = default;

Status InputConverter::create(const std::string& config_path,
                              const std::string& src_colorspace,
                              std::unique_ptr<InputConverter>& out)
{
    out.reset();
    LoadedConfig loaded;
    if (Status s = load_config(config_path, loaded); !s.ok())
        return s;
    const OCIO::Config& config = *loaded.config;

    try {
        OCIO::ConstColorSpaceRcPtr linear = config.getColorSpace(
            OCIO::ROLE_SCENE_LINEAR);
        if (!linear) {
            return Status::errorf("OCIO config ", describe(loaded.info),
                                  " has no '", OCIO::ROLE_SCENE_LINEAR,
                                  "' role: filmgrain converts its input to "
                                  "scene_linear");
        }
        // getColorSpace resolves names, aliases and roles (case-insensitive).
        OCIO::ConstColorSpaceRcPtr src = src_colorspace.empty()
                                             ? nullptr
                                             : config.getColorSpace(
                                                 src_colorspace.c_str());
        if (!src) {
            return Status::errorf("unknown colour space '", src_colorspace,
                                  "' in config ", describe(loaded.info),
                                  "; known: ", join(known_names(config)));
        }

        auto impl                     = std::make_unique<Impl>();
        impl->info                    = loaded.info;
        impl->source_colorspace       = src_colorspace;
        impl->scene_linear_colorspace = linear->getName();
        try {
            OCIO::ConstProcessorRcPtr proc
                = config.getProcessor(src->getName(), linear->getName());
            // The default optimisation, as OIIO and the OCIO tools use, so our
            // numbers match `oiiotool --colorconvert` on the same config.
            impl->cpu = proc->getDefaultCPUProcessor();
        } catch (const std::exception& e) {
            return Status::errorf("cannot build the OCIO conversion from '",
                                  src_colorspace, "' to scene_linear ('",
                                  linear->getName(), "') in config ",
                                  describe(loaded.info), ": ", e.what());
        }
        impl->noop = impl->cpu->isNoOp();
        out.reset(new InputConverter(std::move(impl)));
        return Status();
    } catch (const std::exception& e) {
        return Status::errorf("OCIO error with colour space '", src_colorspace,
                              "' in config ", describe(loaded.info), ": ",
                              e.what());
    } catch (...) {
        return Status::errorf("unknown OCIO error with colour space '",
                              src_colorspace, "' in config ",
                              describe(loaded.info));
    }
}

void InputConverter::apply_rgb(float* rgb, size_t npixels) const
{
    if (!rgb || npixels == 0 || m_impl->noop)
        return;
    m_impl->run(rgb, npixels, 3);
}

void InputConverter::apply_rgb_strided(float* pixels, size_t npixels,
                                       int nchannels) const
{
    if (!pixels || npixels == 0 || nchannels < 3 || m_impl->noop)
        return;
    m_impl->run(pixels, npixels, nchannels);
}

bool InputConverter::is_noop() const { return m_impl->noop; }

const ConfigInfo& InputConverter::config() const { return m_impl->info; }

const std::string& InputConverter::source_colorspace() const
{
    return m_impl->source_colorspace;
}

const std::string& InputConverter::scene_linear_colorspace() const
{
    return m_impl->scene_linear_colorspace;
}

// --- Converter ---------------------------------------------------------------

struct Converter::Impl {
    ConfigInfo info;
    std::string source, destination;
    OCIO::ConstCPUProcessorRcPtr cpu;
    bool noop = true;
};

Converter::Converter(std::unique_ptr<Impl> impl)
    : m_impl(std::move(impl))
{
}

Converter::~Converter() = default;

namespace {

/// The displays of a config, or the views of one display, for messages.
std::vector<std::string> display_names(const OCIO::Config& config)
{
    std::vector<std::string> names;
    for (int i = 0; i < config.getNumDisplays(); ++i)
        names.emplace_back(config.getDisplay(i));
    return names;
}

std::vector<std::string> view_names(const OCIO::Config& config, const char* display)
{
    std::vector<std::string> names;
    for (int i = 0; i < config.getNumViews(display); ++i)
        names.emplace_back(config.getView(display, i));
    return names;
}

}  // namespace

Status Converter::create(const std::string& config_path, const std::string& src_colorspace,
                         const std::string& dst_colorspace, std::unique_ptr<Converter>& out)
{
    out.reset();
    LoadedConfig loaded;
    if (Status s = load_config(config_path, loaded); !s.ok())
        return s;
    const OCIO::Config& config = *loaded.config;
    try {
        OCIO::ConstColorSpaceRcPtr cs[2];
        const std::string* names[2] = { &src_colorspace, &dst_colorspace };
        for (int i = 0; i < 2; ++i) {
            cs[i] = names[i]->empty() ? nullptr : config.getColorSpace(names[i]->c_str());
            if (!cs[i])
                return Status::errorf("unknown colour space '", *names[i], "' in config ",
                                      describe(loaded.info), "; known: ",
                                      join(known_names(config)));
        }
        auto impl         = std::make_unique<Impl>();
        impl->info        = loaded.info;
        impl->source      = cs[0]->getName();
        impl->destination = cs[1]->getName();
        try {
            impl->cpu = config.getProcessor(cs[0]->getName(), cs[1]->getName())
                            ->getDefaultCPUProcessor();
        } catch (const std::exception& e) {
            return Status::errorf("cannot build the OCIO conversion from '", src_colorspace,
                                  "' to '", dst_colorspace, "' in config ",
                                  describe(loaded.info), ": ", e.what());
        }
        impl->noop = impl->cpu->isNoOp();
        out.reset(new Converter(std::move(impl)));
        return Status();
    } catch (const std::exception& e) {
        return Status::errorf("OCIO error converting '", src_colorspace, "' to '",
                              dst_colorspace, "' in config ", describe(loaded.info), ": ",
                              e.what());
    }
}

Status Converter::create_display_view(const std::string& config_path,
                                      const std::string& src_colorspace,
                                      const std::string& display, const std::string& view,
                                      std::unique_ptr<Converter>& out)
{
    out.reset();
    LoadedConfig loaded;
    if (Status s = load_config(config_path, loaded); !s.ok())
        return s;
    const OCIO::Config& config = *loaded.config;
    try {
        OCIO::ConstColorSpaceRcPtr src
            = src_colorspace.empty() ? nullptr : config.getColorSpace(src_colorspace.c_str());
        if (!src)
            return Status::errorf("unknown colour space '", src_colorspace, "' in config ",
                                  describe(loaded.info), "; known: ", join(known_names(config)));
        const std::vector<std::string> displays = display_names(config);
        const std::string d = display.empty() ? std::string(config.getDefaultDisplay()) : display;
        if (std::find(displays.begin(), displays.end(), d) == displays.end())
            return Status::errorf("unknown display '", d, "' in config ", describe(loaded.info),
                                  "; known: ", join(displays));
        const std::vector<std::string> views = view_names(config, d.c_str());
        const std::string v = view.empty() ? std::string(config.getDefaultView(d.c_str())) : view;
        if (std::find(views.begin(), views.end(), v) == views.end())
            return Status::errorf("unknown view '", v, "' of display '", d, "' in config ",
                                  describe(loaded.info), "; known: ", join(views));
        auto impl         = std::make_unique<Impl>();
        impl->info        = loaded.info;
        impl->source      = src->getName();
        impl->destination = d + " / " + v;
        try {
            impl->cpu = config.getProcessor(src->getName(), d.c_str(), v.c_str(),
                                            OCIO::TRANSFORM_DIR_FORWARD)
                            ->getDefaultCPUProcessor();
        } catch (const std::exception& e) {
            return Status::errorf("cannot build the OCIO display transform from '",
                                  src_colorspace, "' to display '", d, "', view '", v,
                                  "' in config ", describe(loaded.info), ": ", e.what());
        }
        impl->noop = impl->cpu->isNoOp();
        out.reset(new Converter(std::move(impl)));
        return Status();
    } catch (const std::exception& e) {
        return Status::errorf("OCIO error with the display transform of '", src_colorspace,
                              "' in config ", describe(loaded.info), ": ", e.what());
    }
}

void Converter::apply_rgb(float* rgb, size_t npixels) const
{
    if (!rgb || npixels == 0 || m_impl->noop)
        return;
    run_cpu(m_impl->cpu, rgb, npixels, 3);
}

void Converter::apply_rgb_strided(float* pixels, size_t npixels, int nchannels) const
{
    if (!pixels || npixels == 0 || nchannels < 3 || m_impl->noop)
        return;
    run_cpu(m_impl->cpu, pixels, npixels, nchannels);
}

bool Converter::is_noop() const { return m_impl->noop; }

const ConfigInfo& Converter::config() const { return m_impl->info; }

const std::string& Converter::source_name() const { return m_impl->source; }

const std::string& Converter::destination_name() const { return m_impl->destination; }

Status find_colorspace(const std::string& config_path, const std::string& name,
                       std::string& resolved, ConfigInfo* info)
{
    resolved.clear();
    LoadedConfig loaded;
    if (Status s = load_config(config_path, loaded); !s.ok())
        return s;
    if (info)
        *info = loaded.info;
    try {
        if (OCIO::ConstColorSpaceRcPtr cs
            = name.empty() ? nullptr : loaded.config->getColorSpace(name.c_str()))
            resolved = cs->getName();
    } catch (const std::exception& e) {
        return Status::errorf("OCIO error looking up colour space '", name, "' in config ",
                              describe(loaded.info), ": ", e.what());
    }
    return Status();
}

const std::string& embedded_config_text()
{
    static const std::string text(detail::k_filmgrain_minimal_ocio);
    return text;
}

Status list_colorspaces(const std::string& config_path,
                        std::vector<std::string>& names)
{
    names.clear();
    LoadedConfig loaded;
    if (Status s = load_config(config_path, loaded); !s.ok())
        return s;
    try {
        names = known_names(*loaded.config);
    } catch (const std::exception& e) {
        names.clear();
        return Status::errorf("cannot list the colour spaces of OCIO config ",
                              describe(loaded.info), ": ", e.what());
    }
    return Status();
}

}  // namespace filmgrain::ocio
