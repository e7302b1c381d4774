// The installed filmgrain package, used as a studio tool would: the operator
// on an OIIO ImageBuf, a stock preset, an OCIO input converter. Exits 0 when
// everything works, 1 with a message naming the first failure.
#include <filmgrain/imagebufalgo_filmgrain.h>
#include <filmgrain/ocio.h>
#include <filmgrain/stock.h>
#include <filmgrain/version.h>

#include <OpenImageIO/imagebuf.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace {

int fail(const std::string& what)
{
    std::fprintf(stderr, "filmgrain_consumer: FAIL: %s\n", what.c_str());
    return 1;
}

}  // namespace

int main()
{
    std::printf("filmgrain_consumer: linked against filmgrain %s\n",
                filmgrain::version_string());

    // A small scene-linear RGB ramp.
    const int width = 16, height = 12;
    OIIO::ImageBuf src(OIIO::ImageSpec(width, height, 3, OIIO::TypeDesc::FLOAT));
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            const float v[3] = { 0.02f + 0.1f * x / width, 0.18f, 0.05f + 0.5f * y / height };
            src.setpixel(x, y, v, 3);
        }

    // The operator with the default stock on a 0.3 mm wide frame (few
    // grains: fast).
    filmgrain::FilmgrainOptions opts;
    opts.scene.width_mm = 0.3;
    OIIO::ImageBuf neg = filmgrain::IBA::filmgrain(src, opts);
    if (neg.has_error())
        return fail("IBA::filmgrain: " + neg.geterror());
    const int nlayers = static_cast<int>(opts.stock.layers.size());
    const OIIO::ImageSpec& spec = neg.spec();
    if (nlayers < 1 || spec.nchannels != nlayers)
        return fail("IBA::filmgrain: " + std::to_string(spec.nchannels) + " channels for "
                    + std::to_string(nlayers) + " stock layers");
    if (spec.width != width || spec.height != height)
        return fail("IBA::filmgrain: result is " + std::to_string(spec.width) + "x"
                    + std::to_string(spec.height) + ", expected 16x12");
    std::vector<float> pixels(size_t(width) * height * nlayers);
    if (!neg.get_pixels(OIIO::ROI::All(), OIIO::TypeDesc::FLOAT, pixels.data()))
        return fail("get_pixels: " + neg.geterror());
    for (size_t i = 0; i < pixels.size(); ++i)
        if (!std::isfinite(pixels[i]))
            return fail("IBA::filmgrain: non-finite value at float " + std::to_string(i));
    std::printf("filmgrain_consumer: rendered %dx%d, %d layers, stock \"%s\"\n", spec.width,
                spec.height, nlayers, opts.stock.name.c_str());

    // A built-in preset other than the default.
    filmgrain::Stock paper;
    filmgrain::Status st = filmgrain::load_stock("paper", paper);
    if (!st.ok())
        return fail("load_stock(\"paper\"): " + st.message());
    if (paper.layers.empty())
        return fail("load_stock(\"paper\"): no layers");

    // OCIO input conversion through the embedded config (the driver unsets
    // $OCIO): sRGB 0.5 decodes to about 0.214 in scene-linear Rec.709.
    std::unique_ptr<filmgrain::ocio::InputConverter> conv;
    st = filmgrain::ocio::InputConverter::create("", "sRGB", conv);
    if (!st.ok() || !conv)
        return fail("InputConverter::create(\"\", \"sRGB\"): " + st.message());
    float rgb[3] = { 0.5f, 0.5f, 0.5f };
    conv->apply_rgb(rgb, 1);
    if (!(std::fabs(rgb[0] - 0.21404f) < 1e-3f))
        return fail("sRGB 0.5 -> scene_linear gave " + std::to_string(rgb[0])
                    + ", expected 0.214");
    std::printf("filmgrain_consumer: OCIO sRGB -> %s (config: %s) OK\n",
                conv->scene_linear_colorspace().c_str(), conv->config().source.c_str());

    std::printf("filmgrain_consumer: PASS\n");
    return 0;
}
