// hdrcheck.cc -- reads an HDR output with third-party readers and checks
// it against the 8-bit image of the same render.
//
//   hdrcheck IMAGE8.png OTHER.exr|OTHER.png
//
// An EXR is read by OpenEXR's C++ library (Imf::InputFile), not by rayd's
// writer's C API, as R, G, B floats; each value, sRGB-encoded by the
// formula, must round to within one step of the 8-bit byte (the float
// rounding of the average may cross a step).  A 16-bit PNG is read by
// libpng's simplified API; v16 / 257 must be within one step too.  The
// 8-bit PNG is read by libpng.  Prints the largest difference; exit 0 when
// within one step, 1 if not, 2 when a file cannot be read.
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <png.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

static bool read_png(const char *path, bool wide, std::vector<unsigned> &out, int &w, int &h) {
    png_image img;
    std::memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&img, path)) return false;
    // 16 bits: libpng's linear format would undo the sRGB curve, so read
    // the file's own samples: the simplified API is for 8 bits only here.
    img.format = PNG_FORMAT_RGB;
    w = (int)img.width;
    h = (int)img.height;
    if (wide) {
        png_image_free(&img);
        FILE *f = std::fopen(path, "rb");
        if (!f) return false;
        png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
        png_infop info = png_create_info_struct(png);
        if (setjmp(png_jmpbuf(png))) return false;
        png_init_io(png, f);
        png_read_info(png, info);
        if (png_get_bit_depth(png, info) != 16) return false;
        std::vector<unsigned char> row((size_t)w * 6);
        for (int y = 0; y < h; y++) {
            png_read_row(png, row.data(), nullptr);
            for (int k = 0; k < w * 3; k++) out.push_back(row[2 * k] << 8 | row[2 * k + 1]);
        }
        png_destroy_read_struct(&png, &info, nullptr);
        std::fclose(f);
        return true;
    }
    std::vector<unsigned char> px(PNG_IMAGE_SIZE(img));
    if (!png_image_finish_read(&img, nullptr, px.data(), 0, nullptr)) return false;
    out.assign(px.begin(), px.end());
    return true;
}

static int srgb8(double c) {
    if (!(c > 0)) return 0;
    if (c >= 1) return 255;
    double e = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1 / 2.4) - 0.055;
    return (int)std::floor(e * 255 + 0.5);
}

static bool read_exr(const char *path, std::vector<unsigned> &out, int &w, int &h) {
    try {
        Imf::InputFile file(path);
        Imath::Box2i dw = file.header().dataWindow();
        w = dw.max.x - dw.min.x + 1;
        h = dw.max.y - dw.min.y + 1;
        std::vector<float> rgb((size_t)w * h * 3);
        Imf::FrameBuffer fb;
        const char *names[3] = {"R", "G", "B"};
        for (int c = 0; c < 3; c++)
            fb.insert(names[c],
                      Imf::Slice(Imf::FLOAT, (char *)(rgb.data() + c), 12, (size_t)w * 12));
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        for (float v : rgb) out.push_back((unsigned)srgb8(v));
        return true;
    } catch (const std::exception &e) {
        std::fprintf(stderr, "hdrcheck: %s: %s\n", path, e.what());
        return false;
    }
}

int main(int argc, char **argv) {
    if (argc != 3)
        return std::fprintf(stderr, "usage: hdrcheck IMAGE8.png OTHER.exr|OTHER.png\n"), 2;
    std::vector<unsigned> a, b;
    int aw, ah, bw, bh;
    std::string other = argv[2];
    bool exr = other.size() > 4 && other.substr(other.size() - 4) == ".exr";
    if (!read_png(argv[1], false, a, aw, ah))
        return std::fprintf(stderr, "hdrcheck: cannot read %s\n", argv[1]), 2;
    if (!(exr ? read_exr(argv[2], b, bw, bh) : read_png(argv[2], true, b, bw, bh)))
        return std::fprintf(stderr, "hdrcheck: cannot read %s\n", argv[2]), 2;
    if (aw != bw || ah != bh || a.size() != b.size())
        return std::fprintf(stderr, "hdrcheck: sizes differ: %dx%d and %dx%d\n", aw, ah, bw, bh), 1;
    int worst = 0;
    size_t off = 0;
    for (size_t i = 0; i < a.size(); i++) {
        int v = exr ? (int)b[i] : (int)((b[i] + 128) / 257);
        int d = std::abs(v - (int)a[i]);
        if (d > worst) worst = d, off = i;
    }
    std::printf("%dx%d, %zu values, largest difference %d (value %zu)\n", aw, ah, a.size(), worst,
                off);
    return worst <= 1 ? 0 : 1;
}
