// filmgrain: per-grain film simulation.
// OpenColorIO conversions (see filmgrain/ocio.h). A thin adapter: it loads a
// config, builds one CPU processor and runs it; it holds no physics.
#include <filmgrain/ocio.h>

#include <OpenColorIO/OpenColorIO.h>

#include <Imath/ImathMatrix.h>
#include <Imath/ImathVec.h>

#include <algorithm>
#include <cmath>
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

/// Loads the config (load_config) and runs body(config, info) on it. What
/// OCIO throws becomes an error: "OCIO error <doing> in config <name>:
/// <what>". Every entry point below that reads a config goes through it.
template <class Body>
Status with_config(const std::string& config_path, const std::string& doing, Body&& body)
{
    LoadedConfig loaded;
    if (Status s = load_config(config_path, loaded); !s.ok())
        return s;
    try {
        return body(*loaded.config, loaded.info);
    } catch (const std::exception& e) {  // OCIO::Exception is one
        return Status::errorf("OCIO error ", doing, " in config ", describe(loaded.info), ": ",
                              e.what());
    } catch (...) {
        return Status::errorf("unknown OCIO error ", doing, " in config ",
                              describe(loaded.info));
    }
}

/// The config's scene_linear role, or an error: filmgrain's input is
/// converted to it.
Status scene_linear_of(const OCIO::Config& config, const ConfigInfo& info,
                       OCIO::ConstColorSpaceRcPtr& out)
{
    out = config.getColorSpace(OCIO::ROLE_SCENE_LINEAR);
    if (!out)
        return Status::errorf("OCIO config ", describe(info), " has no '",
                              OCIO::ROLE_SCENE_LINEAR,
                              "' role: filmgrain converts its input to scene_linear");
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

/// The colour space `name` names in `config` (a name, an alias or a role,
/// case-insensitive: OCIO's getColorSpace), or an error naming the config
/// and the spaces it knows. Called inside the callers' try blocks.
Status lookup_colorspace(const OCIO::Config& config, const ConfigInfo& info,
                         const std::string& name, OCIO::ConstColorSpaceRcPtr& out)
{
    out = name.empty() ? nullptr : config.getColorSpace(name.c_str());
    if (!out)
        return Status::errorf("unknown colour space '", name, "' in config ", describe(info),
                              "; known: ", join(known_names(config)));
    return Status();
}

// --- Chromaticities ----------------------------------------------------------
// Matrices act on column vectors (out = M in, M[row][column]), as the
// standards write them; Imath's own `v * M` takes v as a row, so mul() is
// used instead. Imath's product M1 * M2 is the ordinary one.

using M33 = Imath::M33d;
using V3  = Imath::V3d;

/// ACES AP0 primaries and the ACES white (SMPTE ST 2065-1).
constexpr Chromaticities k_ap0_xy = { 0.7347, 0.2653, 0.0,     1.0,
                                      0.0001, -0.0770, 0.32168, 0.33767 };

/// Bradford's cone response matrix, XYZ -> RGB "cones" (Lam 1985, in its
/// linear form as ICC.1:2010 Annex E and CIECAM97s use it; the matrix OCIO
/// uses for its "_BFD" transforms).
const M33 k_bradford(0.8951, 0.2664, -0.1614,
                     -0.7502, 1.7135, 0.0367,
                     0.0389, -0.0685, 1.0296);

/// Below this, |det| relative to the product of the column lengths, a 3x3
/// matrix is taken as singular (its columns lie on one plane).
constexpr double k_singular = 1e-9;

/// |OCIO's output for RGB black| above which a colour space is taken not to
/// keep black at 0.
constexpr double k_black_tolerance = 1e-6;

const char* const k_xy_names[8] = { "red x",  "red y",  "green x", "green y",
                                    "blue x", "blue y", "white x", "white y" };

V3 mul(const M33& m, const V3& v)
{
    return V3(m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
              m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
              m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z);
}

V3 column(const M33& m, int c) { return V3(m[0][c], m[1][c], m[2][c]); }

M33 from_columns(const V3& c0, const V3& c1, const V3& c2)
{
    return M33(c0.x, c1.x, c2.x, c0.y, c1.y, c2.y, c0.z, c1.z, c2.z);
}

/// |det m| over the product of its columns' lengths (Hadamard's bound): 0
/// when singular, 1 when the columns are orthogonal; 0 when not finite.
double relative_determinant(const M33& m)
{
    const double scale = column(m, 0).length() * column(m, 1).length() * column(m, 2).length();
    const double r     = scale > 0.0 ? std::fabs(m.determinant()) / scale : 0.0;
    return std::isfinite(r) ? r : 0.0;
}

/// x, y of CIE XYZ; NaN when X + Y + Z is 0.
void xyz_to_xy(const V3& xyz, double& x, double& y)
{
    const double sum = xyz.x + xyz.y + xyz.z;
    x = sum != 0.0 ? xyz.x / sum : std::nan("");
    y = sum != 0.0 ? xyz.y / sum : std::nan("");
}

/// A number in messages: 7 significant digits, so a value read from a float
/// (an EXR attribute) prints as written (0.64, not 0.63999998569).
std::string number(double v)
{
    std::ostringstream s;
    s.precision(7);
    s << v;
    return s.str();
}

/// "red 0.64 0.33, green ..., white 0.3127 0.329": chromaticities in messages.
std::string describe_xy(const Chromaticities& xy)
{
    std::ostringstream s;
    s.precision(7);
    const char* const names[4] = { "red", "green", "blue", "white" };
    for (int i = 0; i < 4; ++i)
        s << (i ? ", " : "") << names[i] << ' ' << xy[size_t(2 * i)] << ' '
          << xy[size_t(2 * i + 1)];
    return s.str();
}

/// RGB -> CIE XYZ of primaries and white `xy` (SMPTE RP 177-1993, 3.3):
/// P's columns are the primaries' (x, y, 1 - x - y), scaled by S = P^-1 W so
/// that RGB (1, 1, 1) is the white W = (x_w / y_w, 1, (1 - x_w - y_w) / y_w),
/// luminance 1. Written without dividing by a primary's y, so XYZ's own
/// primaries ((1, 0), (0, 1), (0, 0)) give the identity.
Status rgb_to_xyz(const Chromaticities& xy, M33& out)
{
    for (size_t i = 0; i < xy.size(); ++i)
        if (!std::isfinite(xy[i]))
            return Status::errorf("chromaticities: ", k_xy_names[i], " = ", number(xy[i]),
                                  ": must be finite");
    if (!(xy[7] > 0.0))
        return Status::errorf("chromaticities: white y = ", number(xy[7]),
                              ": must be > 0 (the white has a luminance)");
    const auto primary = [&xy](int i) {
        const double x = xy[size_t(2 * i)], y = xy[size_t(2 * i + 1)];
        return V3(x, y, 1.0 - x - y);
    };
    const M33 p = from_columns(primary(0), primary(1), primary(2));
    if (relative_determinant(p) < k_singular)
        return Status::errorf("chromaticities (", describe_xy(xy),
                              "): the red, green and blue primaries lie on one line, so "
                              "they span no colour space");
    const V3 white(xy[6] / xy[7], 1.0, (1.0 - xy[6] - xy[7]) / xy[7]);
    const V3 scale = mul(p.inverse(), white);
    out            = from_columns(column(p, 0) * scale.x, column(p, 1) * scale.y,
                                  column(p, 2) * scale.z);
    if (relative_determinant(out) < k_singular)
        return Status::errorf("chromaticities (", describe_xy(xy),
                              "): the white lies on the line through two primaries, so "
                              "one primary carries none of it");
    return Status();
}

/// AP0 RGB -> XYZ (the published NPM of SMPTE ST 2065-1, to its 10 digits).
M33 ap0_to_xyz()
{
    M33 m;
    rgb_to_xyz(k_ap0_xy, m);  // valid constants: cannot fail
    return m;
}

/// Bradford chromatic adaptation (von Kries in k_bradford's cone space)
/// taking the white `from` (XYZ) to the white `to` (XYZ), luminance
/// included. Two adaptations compose into the direct one.
M33 bradford(const V3& from, const V3& to)
{
    const V3 cone_from = mul(k_bradford, from), cone_to = mul(k_bradford, to);
    M33 gain;  // Imath's default is the identity
    gain[0][0] = cone_to.x / cone_from.x;
    gain[1][1] = cone_to.y / cone_from.y;
    gain[2][2] = cone_to.z / cone_from.z;
    return k_bradford.inverse() * gain * k_bradford;
}

/// The config's ACES2065-1: its aces_interchange role, else a colour space
/// named or aliased "ACES2065-1"; null when it has neither.
OCIO::ConstColorSpaceRcPtr find_aces(const OCIO::Config& config)
{
    if (config.hasRole(OCIO::ROLE_INTERCHANGE_SCENE))
        if (OCIO::ConstColorSpaceRcPtr cs = config.getColorSpace(OCIO::ROLE_INTERCHANGE_SCENE))
            return cs;
    return config.getColorSpace("ACES2065-1");
}

Status no_aces_error(const ConfigInfo& info)
{
    return Status::errorf("OCIO config ", describe(info), " has neither an '",
                          OCIO::ROLE_INTERCHANGE_SCENE,
                          "' role nor a colour space named 'ACES2065-1': RGB given by "
                          "chromaticities is placed in a config through ACES2065-1 "
                          "(SMPTE ST 2065-1)");
}

/// `cs` RGB -> AP0 in the config's ACES space `aces`, as OCIO converts:
/// probed at black and the unit primaries (a curve through 0 and 1, such as
/// sRGB's, gives its primaries too).
Status probe_to_ap0(const OCIO::Config& config, const ConfigInfo& info,
                    const OCIO::ConstColorSpaceRcPtr& cs,
                    const OCIO::ConstColorSpaceRcPtr& aces, M33& out)
{
    if (cs->isData())
        return Status::errorf("colour space '", cs->getName(), "' of OCIO config ",
                              describe(info), " is data: it has no primaries");
    float px[12] = { 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1 };
    OCIO::PackedImageDesc desc(px, 4, 1, 3);
    config.getProcessor(cs->getName(), aces->getName())->getDefaultCPUProcessor()->apply(desc);
    for (int c = 0; c < 3; ++c)
        if (!(std::fabs(px[c]) <= k_black_tolerance))
            return Status::errorf("colour space '", cs->getName(), "' of OCIO config ",
                                  describe(info), " takes RGB black to ", number(px[0]), ", ",
                                  number(px[1]), ", ", number(px[2]), " in '", aces->getName(),
                                  "', not to black: it has no primaries to compare");
    out = from_columns(V3(px[3], px[4], px[5]), V3(px[6], px[7], px[8]),
                       V3(px[9], px[10], px[11]));
    if (relative_determinant(out) < k_singular)
        return Status::errorf("colour space '", cs->getName(), "' of OCIO config ",
                              describe(info), " takes its primaries to one plane of '",
                              aces->getName(), "': it has no primaries to compare");
    return Status();
}

/// RGB with chromaticities `xy` placed against the config's colour space
/// `cs` (see compare_chromaticities in ocio.h).
struct ChromaticitiesRoute {
    OCIO::ConstColorSpaceRcPtr aces;  ///< the config's ACES2065-1
    M33 xy_to_ap0;                    ///< xy's RGB -> AP0, white adapted to cs's
    M33 cs_to_ap0;                    ///< cs's RGB -> AP0, by OCIO
    /// Largest |difference| in x or y between the two sets of primaries
    /// (columns of the matrices above, in XYZ); NaN when one is undefined.
    double distance_xy = 0.0;
};

Status plan_route(const OCIO::Config& config, const ConfigInfo& info,
                  const OCIO::ConstColorSpaceRcPtr& cs, const Chromaticities& xy,
                  ChromaticitiesRoute& route)
{
    M33 xy_to_xyz;
    if (Status s = rgb_to_xyz(xy, xy_to_xyz); !s.ok())
        return s;
    route.aces = find_aces(config);
    if (!route.aces)
        return no_aces_error(info);
    if (Status s = probe_to_ap0(config, info, cs, route.aces, route.cs_to_ap0); !s.ok())
        return s;
    const M33 to_xyz = ap0_to_xyz();
    // cs's white as OCIO places it (ACES white when the config adapts to it,
    // as the embedded one does): xy's white is adapted there, so RGB
    // (1, 1, 1) stays (1, 1, 1).
    const V3 cs_white = mul(to_xyz, mul(route.cs_to_ap0, V3(1.0, 1.0, 1.0)));
    const V3 xy_white = mul(xy_to_xyz, V3(1.0, 1.0, 1.0));
    route.xy_to_ap0   = to_xyz.inverse() * bradford(xy_white, cs_white) * xy_to_xyz;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            if (!std::isfinite(route.xy_to_ap0[r][c]))  // a white with a zero cone response
                return Status::errorf("chromaticities (", describe_xy(xy),
                                      "): Bradford cannot adapt this white to colour space '",
                                      cs->getName(), "''s");
    route.distance_xy = 0.0;
    for (int c = 0; c < 3; ++c) {
        double xa, ya, xb, yb;
        xyz_to_xy(mul(to_xyz, column(route.xy_to_ap0, c)), xa, ya);
        xyz_to_xy(mul(to_xyz, column(route.cs_to_ap0, c)), xb, yb);
        const double d = std::max(std::fabs(xa - xb), std::fabs(ya - yb));
        route.distance_xy = std::isnan(d) ? d : std::max(route.distance_xy, d);
        if (std::isnan(d))
            break;
    }
    return Status();
}

bool within(double distance_xy, double tolerance_xy)
{
    return distance_xy <= tolerance_xy;  // false for NaN
}

Status check_tolerance(double tolerance_xy)
{
    if (!(tolerance_xy >= 0.0) || !std::isfinite(tolerance_xy))
        return Status::errorf("tolerance_xy = ", number(tolerance_xy),
                              ": must be finite and >= 0");
    return Status();
}

}  // namespace

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

// --- InputConverter ----------------------------------------------------------

struct InputConverter::Names {
    std::string source_colorspace;
    std::string scene_linear_colorspace;
    std::string via_colorspace;
};

InputConverter::InputConverter(std::unique_ptr<Impl> impl, std::unique_ptr<Names> names)
    : Converter(std::move(impl))
    , m_names(std::move(names))
{
}

InputConverter::~InputConverter() = default;

Status InputConverter::create(const std::string& config_path,
                              const std::string& src_colorspace,
                              std::unique_ptr<InputConverter>& out)
{
    out.reset();
    return with_config(config_path, "with colour space '" + src_colorspace + "'",
                       [&](const OCIO::Config& config, const ConfigInfo& info) {
        OCIO::ConstColorSpaceRcPtr linear, src;
        if (Status s = scene_linear_of(config, info, linear); !s.ok())
            return s;
        if (Status s = lookup_colorspace(config, info, src_colorspace, src); !s.ok())
            return s;
        auto impl         = std::make_unique<Impl>();
        impl->info        = info;
        impl->source      = src->getName();
        impl->destination = linear->getName();
        auto names        = std::make_unique<Names>();
        names->source_colorspace       = src_colorspace;
        names->scene_linear_colorspace = linear->getName();
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
                                  describe(info), ": ", e.what());
        }
        impl->noop = impl->cpu->isNoOp();
        out.reset(new InputConverter(std::move(impl), std::move(names)));
        return Status();
    });
}

const std::string& InputConverter::source_colorspace() const
{
    return m_names->source_colorspace;
}

const std::string& InputConverter::scene_linear_colorspace() const
{
    return m_names->scene_linear_colorspace;
}

const std::string& InputConverter::via_colorspace() const { return m_names->via_colorspace; }

Status InputConverter::create_from_chromaticities(const std::string& config_path,
                                                  const Chromaticities& xy,
                                                  std::unique_ptr<InputConverter>& out,
                                                  double tolerance_xy)
{
    out.reset();
    if (Status s = check_tolerance(tolerance_xy); !s.ok())
        return s;
    return with_config(config_path,
                       "converting chromaticities (" + describe_xy(xy) + ") to scene_linear",
                       [&](const OCIO::Config& config, const ConfigInfo& info) {
        OCIO::ConstColorSpaceRcPtr linear;
        if (Status s = scene_linear_of(config, info, linear); !s.ok())
            return s;
        ChromaticitiesRoute route;
        if (Status s = plan_route(config, info, linear, xy, route); !s.ok())
            return s;

        auto impl         = std::make_unique<Impl>();
        impl->info        = info;
        impl->destination = linear->getName();
        impl->noop        = within(route.distance_xy, tolerance_xy);
        auto names        = std::make_unique<Names>();
        names->scene_linear_colorspace = linear->getName();
        names->via_colorspace          = route.aces->getName();
        if (!impl->noop) {
            // xy -> AP0 (our matrix), then the config's ACES2065-1 ->
            // scene_linear. OCIO's MatrixTransform takes a row-major 4x4
            // acting on column vectors.
            const M33& m  = route.xy_to_ap0;
            const double m44[16] = { m[0][0], m[0][1], m[0][2], 0.0, m[1][0], m[1][1],
                                     m[1][2], 0.0,     m[2][0], m[2][1], m[2][2], 0.0,
                                     0.0,     0.0,     0.0,     1.0 };
            OCIO::MatrixTransformRcPtr matrix = OCIO::MatrixTransform::Create();
            matrix->setMatrix(m44);
            OCIO::ColorSpaceTransformRcPtr to_linear = OCIO::ColorSpaceTransform::Create();
            to_linear->setSrc(route.aces->getName());
            to_linear->setDst(linear->getName());
            OCIO::GroupTransformRcPtr group = OCIO::GroupTransform::Create();
            group->appendTransform(matrix);
            group->appendTransform(to_linear);
            impl->cpu  = config.getProcessor(group)->getDefaultCPUProcessor();
            impl->noop = impl->cpu->isNoOp();
        }
        out.reset(new InputConverter(std::move(impl), std::move(names)));
        return Status();
    });
}

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
    return with_config(config_path,
                       "converting '" + src_colorspace + "' to '" + dst_colorspace + "'",
                       [&](const OCIO::Config& config, const ConfigInfo& info) {
        OCIO::ConstColorSpaceRcPtr cs[2];
        const std::string* names[2] = { &src_colorspace, &dst_colorspace };
        for (int i = 0; i < 2; ++i)
            if (Status s = lookup_colorspace(config, info, *names[i], cs[i]); !s.ok())
                return s;
        auto impl         = std::make_unique<Impl>();
        impl->info        = info;
        impl->source      = cs[0]->getName();
        impl->destination = cs[1]->getName();
        try {
            impl->cpu = config.getProcessor(cs[0]->getName(), cs[1]->getName())
                            ->getDefaultCPUProcessor();
        } catch (const std::exception& e) {
            return Status::errorf("cannot build the OCIO conversion from '", src_colorspace,
                                  "' to '", dst_colorspace, "' in config ",
                                  describe(info), ": ", e.what());
        }
        impl->noop = impl->cpu->isNoOp();
        out.reset(new Converter(std::move(impl)));
        return Status();
    });
}

Status Converter::create_display_view(const std::string& config_path,
                                      const std::string& src_colorspace,
                                      const std::string& display, const std::string& view,
                                      std::unique_ptr<Converter>& out)
{
    out.reset();
    return with_config(config_path, "with the display transform of '" + src_colorspace + "'",
                       [&](const OCIO::Config& config, const ConfigInfo& info) {
        OCIO::ConstColorSpaceRcPtr src;
        if (Status s = lookup_colorspace(config, info, src_colorspace, src); !s.ok())
            return s;
        const std::vector<std::string> displays = display_names(config);
        const std::string d = display.empty() ? std::string(config.getDefaultDisplay()) : display;
        if (std::find(displays.begin(), displays.end(), d) == displays.end())
            return Status::errorf("unknown display '", d, "' in config ", describe(info),
                                  "; known: ", join(displays));
        const std::vector<std::string> views = view_names(config, d.c_str());
        const std::string v = view.empty() ? std::string(config.getDefaultView(d.c_str())) : view;
        if (std::find(views.begin(), views.end(), v) == views.end())
            return Status::errorf("unknown view '", v, "' of display '", d, "' in config ",
                                  describe(info), "; known: ", join(views));
        auto impl         = std::make_unique<Impl>();
        impl->info        = info;
        impl->source      = src->getName();
        impl->destination = d + " / " + v;
        try {
            impl->cpu = config.getProcessor(src->getName(), d.c_str(), v.c_str(),
                                            OCIO::TRANSFORM_DIR_FORWARD)
                            ->getDefaultCPUProcessor();
        } catch (const std::exception& e) {
            return Status::errorf("cannot build the OCIO display transform from '",
                                  src_colorspace, "' to display '", d, "', view '", v,
                                  "' in config ", describe(info), ": ", e.what());
        }
        impl->noop = impl->cpu->isNoOp();
        out.reset(new Converter(std::move(impl)));
        return Status();
    });
}

Status find_colorspace(const std::string& config_path, const std::string& name,
                       std::string& resolved, ConfigInfo* info)
{
    resolved.clear();
    return with_config(config_path, "looking up colour space '" + name + "'",
                       [&](const OCIO::Config& config, const ConfigInfo& loaded) {
        if (info)
            *info = loaded;
        if (OCIO::ConstColorSpaceRcPtr cs
            = name.empty() ? nullptr : config.getColorSpace(name.c_str()))
            resolved = cs->getName();
        return Status();
    });
}

Status compare_chromaticities(const std::string& config_path, const std::string& colorspace,
                              const Chromaticities& xy, bool& same, double tolerance_xy)
{
    same = false;
    if (Status s = check_tolerance(tolerance_xy); !s.ok())
        return s;
    return with_config(config_path,
                       "comparing chromaticities (" + describe_xy(xy) + ") with colour space '"
                           + colorspace + "'",
                       [&](const OCIO::Config& config, const ConfigInfo& info) {
        OCIO::ConstColorSpaceRcPtr cs;
        if (Status s = lookup_colorspace(config, info, colorspace, cs); !s.ok())
            return s;
        ChromaticitiesRoute route;
        if (Status s = plan_route(config, info, cs, xy, route); !s.ok())
            return s;
        same = within(route.distance_xy, tolerance_xy);
        return Status();
    });
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
    return with_config(config_path, "listing the colour spaces",
                       [&](const OCIO::Config& config, const ConfigInfo&) {
        names = known_names(config);
        return Status();
    });
}

}  // namespace filmgrain::ocio
