// filmgrain CLI: reading INPUT (input_image.h).
#include "input_image.h"
#include "error_text.h"

#include <OpenImageIO/strutil.h>

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <sstream>
#include <system_error>

namespace filmgrain::cli {

namespace {

namespace fs = std::filesystem;

// Input size limits, checked against the file's header before any pixel
// is allocated (docs/reference.md, "Limits and guarantees"). The input is read as
// float: at the limits that is 8 GiB.
constexpr int64_t kMaxInputSide   = int64_t(1) << 20;  ///< pixels a side (1048576)
constexpr int64_t kMaxInputPixels = int64_t(1) << 28;  ///< pixels (268435456: 16384^2)
constexpr int64_t kMaxInputValues = int64_t(1) << 31;  ///< pixels x channels read
constexpr int kMaxInputChannels   = 1024;
/// Parts of a multi-part file looked at for channels.
constexpr int kMaxSubimages = 4096;

/// Checks what a part's header declares: a 2D, non-deep image with at
/// least one pixel, within the limits above (its display window too: the
/// scan covers it). A corrupt header that claims 1e6 x 1e6 pixels is
/// refused here, before anything is allocated for it. `nread`: the
/// channels that will be read (the range the chosen ones span).
Status check_input_spec(const std::string& path, const OIIO::ImageSpec& spec, int64_t nread)
{
    const int64_t w = spec.width, h = spec.height, d = spec.depth, nc = spec.nchannels;
    if (w <= 0 || h <= 0 || nc <= 0)
        return Status::errorf("input '", path, "' declares ", w, "x", h, " pixels of ", nc,
                              " channels: an image needs at least one pixel and one channel");
    if (d > 1)
        return Status::errorf("input '", path, "' is a volume (depth ", d,
                              "): expected a 2D image");
    if (spec.deep)
        return Status::errorf("input '", path, "' is a deep image: not supported");
    if (w > kMaxInputSide || h > kMaxInputSide || w * h > kMaxInputPixels
        || nc > kMaxInputChannels || w * h * nread > kMaxInputValues)
        return Status::errorf("input '", path, "' declares ", w, "x", h, " pixels of ", nc,
                              " channels: larger than filmgrain reads (at most ", kMaxInputSide,
                              " pixels a side, ", kMaxInputPixels, " pixels, ",
                              kMaxInputChannels, " channels and ", kMaxInputValues,
                              " channel values read); refused before reading it (a corrupt "
                              "header?)");
    const int64_t fw = spec.full_width, fh = spec.full_height;
    if (fw > kMaxInputSide || fh > kMaxInputSide || fw * fh > kMaxInputPixels)
        return Status::errorf("input '", path, "' declares a ", fw, "x", fh,
                              " display window: larger than filmgrain reads (at most ",
                              kMaxInputSide, " pixels a side and ", kMaxInputPixels,
                              " pixels); refused before reading it (a corrupt header?)");
    return {};
}

/// The part's name (OpenEXR's "name" attribute, as OIIO reports it).
std::string part_name(const OIIO::ImageSpec& spec)
{
    std::string n = spec.get_string_attribute("oiio:subimagename");
    return n.empty() ? std::string(spec.get_string_attribute("name")) : n;
}

/// The views a multi-view part lists (OpenEXR's multiView), in order.
std::vector<std::string> part_views(const OIIO::ImageSpec& spec)
{
    std::vector<std::string> views;
    const OIIO::ParamValue* p = spec.find_attribute("multiView");
    if (p && p->type().basetype == OIIO::TypeDesc::STRING)
        for (int i = 0; i < p->nvalues() * static_cast<int>(p->type().numelements()); ++i)
            views.emplace_back(static_cast<const OIIO::ustring*>(p->data())[i].string());
    return views;
}

/// "R,G,B,A,Z" (at most 16, then "... (N in all)").
std::string channel_list(const OIIO::ImageSpec& spec)
{
    std::string s;
    const int n = static_cast<int>(spec.channelnames.size());
    for (int i = 0; i < std::min(n, 16); ++i)
        s += (i ? "," : "") + spec.channelnames[static_cast<size_t>(i)];
    if (n > 16)
        s += ",... (" + std::to_string(n) + " in all)";
    return s.empty() ? "none" : s;
}

int find_channel(const OIIO::ImageSpec& spec, const std::string& name)
{
    for (size_t i = 0; i < spec.channelnames.size(); ++i)
        if (spec.channelnames[i] == name)
            return static_cast<int>(i);
    return -1;
}

/// The channels of `names` with `prefix`, all found (indices), or none.
bool find_channels(const OIIO::ImageSpec& spec, const std::string& prefix,
                   const std::vector<std::string>& names, std::vector<int>& out)
{
    out.clear();
    for (const std::string& n : names) {
        const int i = find_channel(spec, prefix + n);
        if (i < 0)
            return false;
        out.push_back(i);
    }
    return true;
}

/// With roi=, the rectangle of the input's data window (file coordinates)
/// that the render reads: required_input_window's window (the ROI's film
/// region grown by the largest grain radius), clipped to the data window.
/// False when the whole image is to be read: no roi, or a roi the operator
/// will refuse (it then reports the error, as for any input).
bool roi_read_window(const FilmgrainOptions& opts, const FilmgrainCommand& cmd,
                     const OIIO::ImageSpec& spec, OIIO::ROI& window)
{
    if (!cmd.has_roi)
        return false;
    // The frame is the display window, else the data window (as the
    // operator's). A plate with overscan (data beyond the display window)
    // is read whole.
    if (has_overscan(spec))
        return false;
    const OIIO::ROI frame = film_frame_window(spec);
    const int64_t fx = frame.xbegin, fy = frame.ybegin, fw = frame.width(), fh = frame.height();
    RenderSettings settings;
    settings.scan_width  = opts.scan_width;
    settings.scan_height = opts.scan_height;
    settings.roi         = Roi { cmd.roi_x, cmd.roi_y, cmd.roi_x + cmd.roi_width,
                                 cmd.roi_y + cmd.roi_height };
    ScanGeometry scan;
    if (!frame_scan(spec, opts, scan))
        return false;
    const Roi& r = settings.roi;
    if (r.x_begin < 0 || r.y_begin < 0 || r.x_end > scan.width || r.y_end > scan.height
        || r.x_end <= r.x_begin || r.y_end <= r.y_begin)
        return false;
    Roi w;
    if (!required_input_window(opts.stock, opts.scene, fw, fh, settings, w) || w.empty())
        return false;
    const int64_t x0 = std::max<int64_t>(w.x_begin + fx, spec.x);
    const int64_t y0 = std::max<int64_t>(w.y_begin + fy, spec.y);
    const int64_t x1 = std::min<int64_t>(w.x_end + fx, int64_t(spec.x) + spec.width);
    const int64_t y1 = std::min<int64_t>(w.y_end + fy, int64_t(spec.y) + spec.height);
    if (x0 >= x1 || y0 >= y1)
        return false;
    window = OIIO::ROI(static_cast<int>(x0), static_cast<int>(x1), static_cast<int>(y0),
                       static_cast<int>(y1), 0, 1, 0, spec.nchannels);
    return true;
}

/// Reads `window` (file coordinates, inside the data window) of channels
/// [chbegin, chend) of `subimage` as float into `dst`, rows of
/// window.width() pixels: scanline files in strips of whole scanlines,
/// tiled files as the tiles that cover the window; only the window is kept.
bool read_window(OIIO::ImageInput& in, int subimage, const OIIO::ROI& window, int chbegin,
                 int chend, float* dst)
{
    const OIIO::ImageSpec spec = in.spec(subimage, 0);
    const int nc               = chend - chbegin;
    const size_t row_values    = static_cast<size_t>(window.width()) * nc;
    std::vector<float> buf;
    if (spec.tile_width > 0) {
        const int tw = spec.tile_width, th = spec.tile_height > 0 ? spec.tile_height : 1;
        const int xb = spec.x + (window.xbegin - spec.x) / tw * tw;
        const int yb = spec.y + (window.ybegin - spec.y) / th * th;
        const int xe = std::min(spec.x + spec.width,
                                spec.x + (window.xend - spec.x + tw - 1) / tw * tw);
        const int ye = std::min(spec.y + spec.height,
                                spec.y + (window.yend - spec.y + th - 1) / th * th);
        const size_t w = static_cast<size_t>(xe - xb);
        buf.resize(w * static_cast<size_t>(ye - yb) * nc);
        if (!in.read_tiles(subimage, 0, xb, xe, yb, ye, 0, 1, chbegin, chend, OIIO::TypeFloat,
                           buf.data()))
            return false;
        for (int y = window.ybegin; y < window.yend; ++y)
            std::copy_n(buf.data() + (static_cast<size_t>(y - yb) * w + (window.xbegin - xb)) * nc,
                        row_values, dst + static_cast<size_t>(y - window.ybegin) * row_values);
        return true;
    }
    // Strips of at most ~64 MiB of whole scanlines.
    const size_t line_values = static_cast<size_t>(spec.width) * nc;
    const int strip = static_cast<int>(std::clamp<size_t>(
        (size_t(64) << 20) / (line_values * sizeof(float)), 1, 1024));
    buf.resize(line_values * static_cast<size_t>(std::min(strip, window.height())));
    for (int y0 = window.ybegin; y0 < window.yend; y0 += strip) {
        const int y1 = std::min(window.yend, y0 + strip);
        if (!in.read_scanlines(subimage, 0, y0, y1, 0, chbegin, chend, OIIO::TypeFloat,
                               buf.data()))
            return false;
        for (int y = y0; y < y1; ++y)
            std::copy_n(buf.data() + static_cast<size_t>(y - y0) * line_values
                            + static_cast<size_t>(window.xbegin - spec.x) * nc,
                        row_values, dst + static_cast<size_t>(y - window.ybegin) * row_values);
    }
    return true;
}

std::unique_ptr<OIIO::ImageInput> open_input(const std::string& path, Status& error)
{
    std::error_code ec;
    if (!fs::exists(path, ec)) {
        error = Status::errorf("input '", path, "' does not exist");
        return nullptr;
    }
    if (fs::is_directory(path, ec)) {
        error = Status::errorf("input '", path, "' is a directory, not an image");
        return nullptr;
    }
    // Keep unassociated alpha as stored: colour channels are read unchanged
    // (alpha itself is ignored by the simulation).
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = OIIO::ImageInput::open(path, &config);
    if (!in) {
        const std::string why = trim(OIIO::geterror());
        error = Status::errorf("cannot read input '", path, "': ",
                               why.empty() ? std::string("not an image OpenImageIO can read")
                                           : why);
    }
    return in;
}

}  // namespace

Status parse_channel_list(const std::string& value, std::vector<std::string>& out)
{
    std::vector<std::string> names;
    std::string name;
    std::istringstream in(value);
    while (std::getline(in, name, ','))
        names.push_back(name);
    if (!value.empty() && value.back() == ',')
        names.emplace_back();
    const bool empty = std::any_of(names.begin(), names.end(),
                                   [](const std::string& n) { return n.empty(); });
    if (empty || (names.size() != 1 && names.size() != 3))
        return Status::errorf("--ch ", value,
                              ": expected three channel names (R,G,B) or one (grey), comma "
                              "separated");
    out = std::move(names);
    return {};
}

Status read_input_header(const std::string& path, const InputSelection& sel, InputHeader& out)
{
    Status error;
    auto in = open_input(path, error);
    if (!in)
        return error;
    // Every part's header (cheap: no pixels).
    std::vector<OIIO::ImageSpec> parts;
    for (int s = 0; s < kMaxSubimages && in->seek_subimage(s, 0); ++s)
        parts.push_back(in->spec());
    OIIO::geterror();  // seeking past the last part is not an error
    in->close();
    if (parts.empty())
        return Status::errorf("cannot read input '", path, "': no image in it");

    // The parts to look in: the one asked for, else all in order.
    std::vector<int> candidates;
    if (!sel.subimage.empty()) {
        int index = -1;
        const char* b = sel.subimage.data();
        const auto r  = std::from_chars(b, b + sel.subimage.size(), index);
        const bool numeric = r.ec == std::errc() && r.ptr == b + sel.subimage.size();
        for (int s = 0; s < static_cast<int>(parts.size()); ++s)
            if ((numeric && s == index) || (!numeric && part_name(parts[s]) == sel.subimage))
                candidates.push_back(s);
        if (candidates.empty()) {
            std::string known;
            for (size_t s = 0; s < parts.size(); ++s)
                known += (s ? ", " : "") + std::to_string(s)
                         + (part_name(parts[s]).empty() ? "" : " '" + part_name(parts[s]) + "'");
            return Status::errorf("--subimage ", sel.subimage, ": input '", path, "' has no such ",
                                  "part (it has ", parts.size(), ": ", known, ")");
        }
    } else {
        for (int s = 0; s < static_cast<int>(parts.size()); ++s)
            candidates.push_back(s);
    }

    // The views: a part may be one view of a multi-part file ("view"), or
    // hold several (multiView: the first is the default, its channels bare,
    // the others' prefixed "view.").
    const std::vector<std::string> default_names = { "R", "G", "B" };
    const std::vector<std::string> grey_names    = { "Y" };
    std::string missing;  // what each part looked at has, for the error
    bool view_seen = sel.view.empty();
    for (int s : candidates) {
        const OIIO::ImageSpec& spec = parts[static_cast<size_t>(s)];
        const std::string part_view = spec.get_string_attribute("view");
        const std::vector<std::string> views = part_views(spec);
        std::string prefix, view = part_view;
        if (!sel.view.empty()) {
            if (!part_view.empty()) {
                if (part_view != sel.view)
                    continue;
            } else if (std::find(views.begin(), views.end(), sel.view) != views.end()) {
                view   = sel.view;
                prefix = sel.view == views.front() ? "" : sel.view + ".";
            } else {
                continue;
            }
            view_seen = true;
        } else if (view.empty() && !views.empty()) {
            view = views.front();
        }
        std::vector<int> channels;
        bool found = false;
        if (!sel.channels.empty()) {
            found = find_channels(spec, prefix, sel.channels, channels);
        } else {
            // Luminance/chroma files (Y, RY, BY): their chroma is
            // subsampled, which OpenImageIO 2.4 does not reconstruct.
            if (find_channel(spec, prefix + "RY") >= 0 && find_channel(spec, prefix + "BY") >= 0
                && !find_channels(spec, prefix, default_names, channels))
                return Status::errorf("input '", path, "' is a luminance/chroma image (",
                                      prefix, "Y, ", prefix, "RY, ", prefix, "BY), which "
                                      "filmgrain cannot read as RGB: convert it to RGB first, "
                                      "or read its luminance alone with --ch ", prefix, "Y");
            found = find_channels(spec, prefix, default_names, channels)
                    || find_channels(spec, prefix, grey_names, channels);
        }
        if (!found) {
            missing += std::string(missing.empty() ? "" : "; ") + "part " + std::to_string(s)
                       + (part_name(spec).empty() ? "" : " '" + part_name(spec) + "'")
                       + (view.empty() ? "" : " (view '" + view + "')") + " has "
                       + channel_list(spec);
            continue;
        }
        const auto [lo, hi] = std::minmax_element(channels.begin(), channels.end());
        if (Status st = check_input_spec(path, spec, *hi - *lo + 1); !st)
            return st;
        out.subimage = s;
        out.spec     = spec;
        out.channels = std::move(channels);
        std::ostringstream d;
        if (parts.size() > 1)
            d << "part " << s << (part_name(spec).empty() ? "" : " '" + part_name(spec) + "'")
              << " of " << parts.size() << ", ";
        if (!view.empty())
            d << "view '" << view << "', ";
        d << "channels ";
        for (size_t i = 0; i < out.channels.size(); ++i)
            d << (i ? "," : "") << spec.channelnames[static_cast<size_t>(out.channels[i])];
        out.description = d.str();
        return {};
    }
    if (!view_seen) {
        std::string views;
        for (const OIIO::ImageSpec& spec : parts) {
            for (const std::string& v : part_views(spec))
                views += (views.empty() ? "" : ", ") + v;
            const std::string v = spec.get_string_attribute("view");
            if (!v.empty())
                views += (views.empty() ? "" : ", ") + v;
        }
        return Status::errorf("--view ", sel.view, ": input '", path, "' has no such view (",
                              views.empty() ? std::string("it has no views")
                                            : "it has " + views,
                              ")");
    }
    std::string wanted = "R, G, B or Y";
    if (!sel.channels.empty()) {
        wanted.clear();
        for (size_t i = 0; i < sel.channels.size(); ++i)
            wanted += (i ? ", " : "") + sel.channels[i];
    }
    return Status::errorf("input '", path, "' has no channels ", wanted,
                          sel.view.empty() ? std::string() : " in view '" + sel.view + "'", " (",
                          missing, "): choose them with --ch, --subimage or --view");
}

Status read_input_pixels(const std::string& path, const InputHeader& header,
                         const FilmgrainOptions& opts, const FilmgrainCommand& cmd,
                         OIIO::ImageBuf& out)
{
    Status error;
    auto in = open_input(path, error);
    if (!in)
        return error;
    const auto [lo, hi] = std::minmax_element(header.channels.begin(), header.channels.end());
    const int chbegin = *lo, chend = *hi + 1, nread = chend - chbegin;
    const int nc      = static_cast<int>(header.channels.size());
    // The part's windows and attributes, with the channels taken (as float).
    OIIO::ImageSpec spec = header.spec;
    spec.set_format(OIIO::TypeFloat);  // also clears per-channel formats
    spec.nchannels = nc;
    spec.channelnames = nc == 3 ? std::vector<std::string> { "R", "G", "B" }
                                : std::vector<std::string> { "Y" };
    spec.alpha_channel = -1;
    spec.z_channel     = -1;
    OIIO::ROI window;
    const bool part = roi_read_window(opts, cmd, header.spec, window)
                      && window != OIIO::ROI(spec.x, spec.x + spec.width, spec.y,
                                             spec.y + spec.height, 0, 1, 0, spec.nchannels);
    if (part) {
        // The frame stays the whole image's (the operator reads the full
        // window as the frame, else the data window).
        if (spec.full_width <= 0) {
            spec.full_x     = spec.x;
            spec.full_width = spec.width;
        }
        if (spec.full_height <= 0) {
            spec.full_y      = spec.y;
            spec.full_height = spec.height;
        }
        spec.x      = window.xbegin;
        spec.y      = window.ybegin;
        spec.width  = window.width();
        spec.height = window.height();
    } else {
        window = OIIO::ROI(spec.x, spec.x + spec.width, spec.y, spec.y + spec.height);
    }
    OIIO::ImageBuf buf(spec);
    float* pixels = static_cast<float*>(buf.localpixels());
    if (!pixels)
        return Status::errorf("cannot read input '", path, "': cannot allocate ", spec.width,
                              "x", spec.height, "x", nc, " floats");
    // The chosen channels in file order side by side (R, G, B of an RGBA
    // file) are read in place; others as the block of channels they span,
    // then picked.
    bool in_order = nread == nc;
    for (int c = 0; c < nc; ++c)
        in_order = in_order && header.channels[static_cast<size_t>(c)] == chbegin + c;
    const size_t npixels = static_cast<size_t>(window.width()) * window.height();
    std::vector<float> block;
    if (!in_order) {
        try {
            block.resize(npixels * static_cast<size_t>(nread));
        } catch (const std::bad_alloc&) {
            return Status::errorf("cannot read input '", path, "': cannot allocate ",
                                  window.width(), "x", window.height(), "x", nread, " floats");
        }
    }
    const bool ok = read_window(*in, header.subimage, window, chbegin, chend,
                                in_order ? pixels : block.data());
    const std::string why = trim(in->geterror());
    in->close();
    if (!ok || !why.empty())
        return Status::errorf("cannot read input '", path, "': ",
                              why.empty() ? std::string("read failed (truncated or corrupt?)")
                                          : why);
    if (!in_order)
        for (size_t p = 0; p < npixels; ++p)
            for (int c = 0; c < nc; ++c)
                pixels[p * nc + c]
                    = block[p * nread + (header.channels[static_cast<size_t>(c)] - chbegin)];
    out = std::move(buf);
    return {};
}

}  // namespace filmgrain::cli
