// filmgrain: per-grain film simulation.
// OpenColorIO conversions: pixels in any colour space a config knows -> the
// config's scene_linear role, which is what the simulator consumes
// (InputConverter); between any two colour spaces, or from a colour space to
// a display and view, for the outputs and the preview (Converter).
//
// No OpenColorIO type appears here (pimpl): including this header needs only
// the C++ standard library and filmgrain/status.h. No exception leaves these
// functions; every failure is returned as a Status whose message names what
// failed (the colour space, the config file and where it came from).
//
// Config resolution, shared by InputConverter::create and list_colorspaces:
//   1. config_path not empty: that file (like oiiotool --colorconfig);
//   2. else $OCIO, when set and not empty;
//   3. else the embedded minimal config (embedded_config_text()): reference
//      lin_rec709 (scene-linear Rec.709, D65), ACEScg, ACES2065-1, ADX10,
//      ADX16, sRGB, raw; display sRGB with views "ACES 1.0 - SDR Video" (the
//      default) and Raw.
//
// Chromaticities (InputConverter::create_from_chromaticities,
// compare_chromaticities): RGB said only by its primaries and white, as an
// OpenEXR header's `chromaticities` says it, is placed in a config through
// ACES2065-1: the config's `aces_interchange` role, else a colour space
// named (or aliased) "ACES2065-1". Its AP0 primaries and white are published
// (SMPTE ST 2065-1), so RGB -> CIE XYZ -> AP0 is computed here; the config
// says how ACES2065-1 reaches its other spaces.
#pragma once

#include <filmgrain/status.h>

#include <array>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace filmgrain::ocio {

/// Which config was used and from where.
/// Thread safety: a value type; distinct objects are independent.
struct ConfigInfo {
    /// "file" (explicit config_path), "$OCIO" (from the environment) or
    /// "embedded" (the built-in minimal config).
    std::string source;
    /// The config file path as given (explicitly or in $OCIO); empty for the
    /// embedded config.
    std::string path;
};

/// CIE 1931 xy chromaticities of an RGB colour space, dimensionless, in the
/// order of OpenEXR's `chromaticities` header attribute (OpenImageIO:
/// "chromaticities", FLOAT[8]): red x, y, green x, y, blue x, y, white x, y.
/// E.g. Rec.709 / sRGB: {0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.3290}.
using Chromaticities = std::array<double, 8>;

/// Largest difference, in x or in y, between two sets of chromaticities that
/// still counts as the same colour space (no conversion). 1e-3 is far above
/// the rounding of chromaticities written as floats or with 4-5 decimals
/// (e.g. D65 as 0.3127, 0.3290 or 0.31271, 0.32902) and far below the
/// smallest difference between the RGB spaces in use (Rec.709 and P3 differ
/// by 0.04 in green x).
constexpr double k_chromaticities_tolerance_xy = 1e-3;

/// Converts pixels from one colour space to another colour space, or to a
/// display and view, of one config. The OCIO processor is built once
/// (create*); apply_*() then run it as a plain loop.
/// Thread safety: all const member functions may be called concurrently from
/// any number of threads on distinct (non-overlapping) buffers; the intended
/// use is one converter per image, apply per tile. Not copyable.
/// Determinism: the result for a pixel depends only on that pixel's value, not
/// on how the image is split into calls or threads.
class Converter {
public:
    /// src -> dst, both any colour space name, alias or role the config
    /// knows (e.g. "ADX16" -> "scene_linear", "scene_linear" -> "ACEScg").
    /// Errors name the unknown colour space and the config, and list the
    /// known names. out: set on success, reset on failure.
    static Status create(const std::string& config_path, const std::string& src_colorspace,
                         const std::string& dst_colorspace, std::unique_ptr<Converter>& out);

    /// src -> (display, view): the view's transform then the display's
    /// encoding, as an image viewer shows src. Empty display: the config's
    /// default display; empty view: that display's default view. Errors
    /// name the display or view and list the known ones.
    static Status create_display_view(const std::string& config_path,
                                      const std::string& src_colorspace,
                                      const std::string& display, const std::string& view,
                                      std::unique_ptr<Converter>& out);

    virtual ~Converter();
    Converter(const Converter&)            = delete;
    Converter& operator=(const Converter&) = delete;

    /// Converts packed float RGB in place: npixels * 3 floats, no alpha.
    /// Does nothing when rgb is null, npixels is 0 or is_noop().
    /// NaN and Inf are passed to OCIO as they are (no crash; what comes out
    /// depends on the transform: a curve such as sRGB keeps NaN/+Inf/-Inf in
    /// their channel, a matrix such as ACEScg -> Rec.709 spreads a non-finite
    /// value to all three channels of that pixel). Pixels are independent:
    /// a non-finite pixel never affects its neighbours.
    /// Thread safety: const; safe concurrently on non-overlapping buffers.
    void apply_rgb(float* rgb, size_t npixels) const;

    /// Converts the first three channels of packed float pixels with
    /// nchannels (>= 3) channels each; alpha and any further channels are
    /// never read or written. Does nothing when pixels is null, npixels is 0,
    /// nchannels < 3 or is_noop(). Same NaN/Inf behaviour as apply_rgb.
    /// Thread safety: const; safe concurrently on non-overlapping buffers.
    void apply_rgb_strided(float* pixels, size_t npixels, int nchannels) const;

    /// True when the conversion is an identity, e.g. scene_linear ->
    /// scene_linear, an alias of the scene_linear space, or a data space such
    /// as "raw" (OCIO never converts data). Callers may skip the pass.
    bool is_noop() const;

    /// The config this converter was built from.
    const ConfigInfo& config() const;

    /// The resolved names: the source colour space, and the destination
    /// colour space or "display / view".
    const std::string& source_name() const;
    const std::string& destination_name() const;

protected:
    struct Impl;
    explicit Converter(std::unique_ptr<Impl> impl);

private:
    std::unique_ptr<Impl> m_impl;
};

/// Converts pixels from a named colour space, or from chromaticities, to the
/// config's scene_linear role: a Converter (applied, threaded and
/// deterministic as one) that also says how it got there. Its
/// source_name() is the resolved source colour space ("" from
/// chromaticities), its destination_name() the scene_linear colour space.
class InputConverter : public Converter {
public:
    /// Loads the config (see the resolution rules at the top of this header),
    /// resolves src_colorspace and builds the CPU processor
    /// src_colorspace -> scene_linear.
    /// config_path: explicit config file; empty means $OCIO when set and not
    ///   empty, else the embedded minimal config.
    /// src_colorspace: any colour space name, alias or role the config knows
    ///   (e.g. "sRGB", "ACEScg", "scene_linear"); OCIO matches names
    ///   case-insensitively.
    /// out: set to the new converter on success, reset on failure.
    /// Returns an error naming the config (and "$OCIO" when it came from
    /// there) if it cannot be loaded, has no scene_linear role, or does not
    /// know src_colorspace (the message then lists the known names).
    /// Thread safety: may be called concurrently; reads $OCIO with getenv,
    /// so must not race with setenv/unsetenv.
    static Status create(const std::string& config_path,
                         const std::string& src_colorspace,
                         std::unique_ptr<InputConverter>& out);

    /// Loads the config and builds the conversion of RGB that is defined
    /// only by its primaries and white `xy` (see Chromaticities) to the
    /// config's scene_linear: RGB -> CIE XYZ from the primaries and white
    /// (SMPTE RP 177), Bradford chromatic adaptation from `xy`'s white to
    /// scene_linear's, XYZ -> ACES2065-1 (AP0 primaries and white of SMPTE
    /// ST 2065-1), then the config's own ACES2065-1 -> scene_linear.
    /// scene_linear's white is where OCIO takes its RGB (1, 1, 1), so white
    /// stays (1, 1, 1) in any config; the adaptation composes exactly with
    /// the config's own when that is Bradford too (the embedded config's is).
    /// When `xy` describes scene_linear itself (compare_chromaticities within
    /// tolerance_xy) the converter is a no-op: is_noop() is true and pixels
    /// are left bit-identical.
    /// xy: finite; the white's y > 0; the three primaries not on one line
    ///   (a primary's y may be 0 or negative: XYZ's are (1, 0), (0, 1),
    ///   (0, 0), ACES AP0's blue has y = -0.077).
    /// tolerance_xy: >= 0 (0: convert unless exactly equal).
    /// out: set to the new converter on success, reset on failure.
    /// Errors (naming the config) as create(), and when the config has
    /// neither an aces_interchange role nor an ACES2065-1 colour space, when
    /// scene_linear is data or not linear from black, or when xy is invalid
    /// (naming the value and the rule).
    /// source_colorspace() is then "" and via_colorspace() names the ACES
    /// space used. Thread safety: as create().
    static Status create_from_chromaticities(const std::string& config_path,
                                             const Chromaticities& xy,
                                             std::unique_ptr<InputConverter>& out,
                                             double tolerance_xy
                                             = k_chromaticities_tolerance_xy);

    ~InputConverter() override;

    /// The source colour space exactly as the caller gave it; "" when built
    /// by create_from_chromaticities.
    const std::string& source_colorspace() const;

    /// create_from_chromaticities: the config's colour space for ACES2065-1
    /// that the conversion went through (e.g. "ACES2065-1"); "" otherwise.
    const std::string& via_colorspace() const;

    /// The name of the colour space the config's scene_linear role resolves to
    /// (e.g. "lin_rec709" in the embedded config).
    const std::string& scene_linear_colorspace() const;

private:
    struct Names;
    InputConverter(std::unique_ptr<Impl> impl, std::unique_ptr<Names> names);
    std::unique_ptr<Names> m_names;
};

/// Resolves `name` (a colour space, alias or role, case-insensitive) in the
/// config that config_path selects: `resolved` receives the colour space's
/// own name, or is cleared when the config does not know it (still a
/// success). Errors only when the config cannot be loaded.
Status find_colorspace(const std::string& config_path, const std::string& name,
                       std::string& resolved, ConfigInfo* info = nullptr);

/// Whether RGB with chromaticities `xy` is the same RGB as `colorspace` of
/// the config that config_path selects. Both are taken to ACES2065-1 (see
/// the top of this header; `colorspace` by OCIO, probing its RGB (0, 0, 0),
/// (1, 0, 0), (0, 1, 0), (0, 0, 1)), xy's white adapted (Bradford) to where
/// `colorspace`'s white lands; `same` is true when every primary's x and y
/// then agree within tolerance_xy. A curve such as sRGB's keeps 0 and 1,
/// so it is compared by its primaries.
/// same: set on success, false on failure.
/// Errors: the config cannot be loaded, has no ACES2065-1 (as
/// create_from_chromaticities), does not know `colorspace`, or `colorspace`
/// has no primaries to compare (data, or black not black: a log encoding);
/// xy invalid. Thread safety: as InputConverter::create.
Status compare_chromaticities(const std::string& config_path, const std::string& colorspace,
                              const Chromaticities& xy, bool& same,
                              double tolerance_xy = k_chromaticities_tolerance_xy);

/// The embedded minimal config (OCIO v2 YAML), exactly as in
/// ocio/src/filmgrain_minimal.ocio at build time; for --help, debugging and
/// tests. Thread safety: returns a reference to an immutable static string.
const std::string& embedded_config_text();

/// Names of all colour spaces (active and inactive, in config order) followed
/// by all role names of the config that InputConverter::create would load for
/// config_path (same resolution rules); aliases are accepted by create but
/// not listed. For error messages and --help.
/// names: replaced on success, cleared on failure.
/// Thread safety: as InputConverter::create.
Status list_colorspaces(const std::string& config_path,
                        std::vector<std::string>& names);

}  // namespace filmgrain::ocio
