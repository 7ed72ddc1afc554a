// exrtool.cc -- OpenEXR files for the environment-map tests, written and
// compared by OpenEXR's C++ library, as artists' tools write them.
//
//   exrtool ramp OUT.exr                    a 64 x 32 float RGB gradient
//   exrtool rewrite IN.exr OUT.exr COMP [tiled]
//                                           IN's R, G, B as half, compressed
//                                           with COMP (none rle zips zip piz
//                                           pxr24 b44 b44a dwaa dwab), as
//                                           scanlines or 16 x 16 tiles
//   exrtool deep OUT.exr                    a deep scanline file
//   exrtool diff A.exr B.exr TOL            exit 0 when every R, G, B value
//                                           of B is within TOL x max(1, |A|)
//                                           of A's, the largest difference
//                                           printed; 1 if not
// Exit 2 when a file cannot be read or written.
#include <ImfChannelList.h>
#include <ImfDeepFrameBuffer.h>
#include <ImfDeepScanLineOutputFile.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfPartType.h>
#include <ImfTiledOutputFile.h>
#include <half.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

struct rgb_image {
    int w = 0, h = 0;
    std::vector<float> px; // w x h x 3
};

static Imf::FrameBuffer frame(float *base, int w, const Imath::Box2i &dw) {
    const size_t xs = 3 * sizeof(float), ys = xs * (size_t)w;
    char *origin = (char *)base - dw.min.x * (ptrdiff_t)xs - dw.min.y * (ptrdiff_t)ys;
    Imf::FrameBuffer fb;
    const char *names[3] = {"R", "G", "B"};
    for (int k = 0; k < 3; k++)
        fb.insert(names[k], Imf::Slice(Imf::FLOAT, origin + k * sizeof(float), xs, ys));
    return fb;
}

static rgb_image read_rgb(const char *path) {
    Imf::InputFile in(path);
    Imath::Box2i dw = in.header().dataWindow();
    rgb_image img;
    img.w = dw.max.x - dw.min.x + 1;
    img.h = dw.max.y - dw.min.y + 1;
    img.px.assign((size_t)img.w * img.h * 3, 0.0f);
    in.setFrameBuffer(frame(img.px.data(), img.w, dw));
    in.readPixels(dw.min.y, dw.max.y);
    return img;
}

static void write_rgb(const char *path, const rgb_image &img, Imf::PixelType type,
                      Imf::Compression comp, bool tiled) {
    Imf::Header hdr(img.w, img.h);
    hdr.compression() = comp;
    for (const char *c : {"R", "G", "B"}) hdr.channels().insert(c, Imf::Channel(type));
    // Imf writes a slice of the channels' own type: halves made here.
    std::vector<float> px = img.px;
    std::vector<half> hx(px.begin(), px.end());
    Imf::FrameBuffer fb = frame(px.data(), img.w, hdr.dataWindow());
    if (type == Imf::HALF) {
        const size_t xs = 3 * sizeof(half), ys = xs * (size_t)img.w;
        fb = Imf::FrameBuffer();
        const char *names[3] = {"R", "G", "B"};
        for (int k = 0; k < 3; k++)
            fb.insert(names[k],
                      Imf::Slice(Imf::HALF, (char *)hx.data() + k * sizeof(half), xs, ys));
    }
    if (tiled) {
        hdr.setTileDescription(Imf::TileDescription(16, 16, Imf::ONE_LEVEL));
        Imf::TiledOutputFile out(path, hdr);
        out.setFrameBuffer(fb);
        out.writeTiles(0, out.numXTiles() - 1, 0, out.numYTiles() - 1);
    } else {
        Imf::OutputFile out(path, hdr);
        out.setFrameBuffer(fb);
        out.writePixels(img.h);
    }
}

static void write_deep(const char *path) {
    const int w = 4, h = 4;
    Imf::Header hdr(w, h);
    hdr.setType(Imf::DEEPSCANLINE);
    hdr.compression() = Imf::ZIPS_COMPRESSION;
    for (const char *c : {"R", "G", "B", "Z"}) hdr.channels().insert(c, Imf::Channel(Imf::FLOAT));
    std::vector<unsigned> counts(w * h, 1);
    std::vector<float> values(w * h, 0.5f);
    std::vector<float *> ptrs(w * h);
    for (int i = 0; i < w * h; i++) ptrs[i] = &values[i];
    Imf::DeepFrameBuffer fb;
    fb.insertSampleCountSlice(
        Imf::Slice(Imf::UINT, (char *)counts.data(), sizeof(unsigned), sizeof(unsigned) * w));
    for (const char *c : {"R", "G", "B", "Z"})
        fb.insert(c, Imf::DeepSlice(Imf::FLOAT, (char *)ptrs.data(), sizeof(float *),
                                    sizeof(float *) * w, sizeof(float)));
    Imf::DeepScanLineOutputFile out(path, hdr);
    out.setFrameBuffer(fb);
    out.writePixels(h);
}

static int compression(const char *name, Imf::Compression *c) {
    const char *names[] = {"none",  "rle", "zips", "zip",  "piz",
                           "pxr24", "b44", "b44a", "dwaa", "dwab"};
    for (int i = 0; i < 10; i++)
        if (!std::strcmp(name, names[i])) {
            *c = (Imf::Compression)i;
            return 0;
        }
    return -1;
}

static int diff(const char *a_path, const char *b_path, double tol) {
    rgb_image a = read_rgb(a_path), b = read_rgb(b_path);
    if (a.w != b.w || a.h != b.h) {
        std::fprintf(stderr, "exrtool: %dx%d against %dx%d\n", a.w, a.h, b.w, b.h);
        return 1;
    }
    double worst = 0;
    for (size_t i = 0; i < a.px.size(); i++) {
        double d = std::fabs((double)a.px[i] - b.px[i]) / std::fmax(1.0, std::fabs(a.px[i]));
        if (!(d <= worst)) worst = d; // a NaN counts as the worst
    }
    std::printf("largest difference %.6g (tolerance %.6g)\n", worst, tol);
    return worst <= tol ? 0 : 1;
}

int main(int argc, char **argv) {
    try {
        std::string op = argc > 1 ? argv[1] : "";
        if (op == "ramp" && argc == 3) {
            rgb_image img;
            img.w = 64;
            img.h = 32;
            for (int y = 0; y < img.h; y++)
                for (int x = 0; x < img.w; x++) {
                    img.px.push_back(0.05f + x / 16.0f);
                    img.px.push_back(0.05f + y / 8.0f);
                    img.px.push_back(1.0f + 0.5f * std::sin(x * 0.3f));
                }
            write_rgb(argv[2], img, Imf::FLOAT, Imf::ZIP_COMPRESSION, false);
            return 0;
        }
        Imf::Compression c;
        if (op == "rewrite" && (argc == 5 || argc == 6) && compression(argv[4], &c) == 0) {
            bool tiled = argc == 6 && !std::strcmp(argv[5], "tiled");
            write_rgb(argv[3], read_rgb(argv[2]), Imf::HALF, c, tiled);
            return 0;
        }
        if (op == "deep" && argc == 3) {
            write_deep(argv[2]);
            return 0;
        }
        if (op == "diff" && argc == 5) return diff(argv[2], argv[3], std::atof(argv[4]));
    } catch (const std::exception &e) {
        std::fprintf(stderr, "exrtool: %s\n", e.what());
        return 2;
    }
    std::fprintf(stderr, "usage: exrtool ramp OUT | rewrite IN OUT COMP [tiled] | deep OUT | "
                         "diff A B TOL\n");
    return 2;
}
