// exrraw.cc -- an OpenEXR image's R, G, B as raw floats, for bench/pt.py.
//
//   exrraw IN.exr OUT.raw
//
// Writes "W H\n" and then W x H x 3 little-endian 32-bit floats, row by
// row from the top, R G B per pixel: rayd's and Blender's EXRs (half or
// float, any compression OpenEXR reads) read by one library, so that the
// error statistics in pt.py (plain Python, no numpy) compare like with
// like.  A missing channel reads as 0.  Exit 2 when IN cannot be read or
// OUT written.
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>

#include <cstdio>
#include <exception>
#include <vector>

int main(int argc, char **argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: exrraw IN.exr OUT.raw\n");
        return 2;
    }
    try {
        Imf::InputFile in(argv[1]);
        const Imath::Box2i dw = in.header().dataWindow();
        const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
        std::vector<float> px((size_t)w * h * 3, 0.0f);
        const size_t xs = 3 * sizeof(float), ys = xs * (size_t)w;
        char *base = (char *)px.data() - dw.min.x * xs - dw.min.y * ys;
        Imf::FrameBuffer fb;
        const char *names[3] = {"R", "G", "B"};
        for (int c = 0; c < 3; c++)
            fb.insert(names[c],
                      Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys, 1, 1, 0.0));
        in.setFrameBuffer(fb);
        in.readPixels(dw.min.y, dw.max.y);
        FILE *out = std::fopen(argv[2], "wb");
        if (!out) {
            std::perror(argv[2]);
            return 2;
        }
        std::fprintf(out, "%d %d\n", w, h);
        const bool ok = std::fwrite(px.data(), sizeof(float), px.size(), out) == px.size();
        if (std::fclose(out) != 0 || !ok) {
            std::fprintf(stderr, "exrraw: %s: write failed\n", argv[2]);
            return 2;
        }
    } catch (const std::exception &e) {
        std::fprintf(stderr, "exrraw: %s: %s\n", argv[1], e.what());
        return 2;
    }
    return 0;
}
