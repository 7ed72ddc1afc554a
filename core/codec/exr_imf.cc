// exr_imf.cc -- OpenEXR in through the format's C++ library (Imf).
//
// exr_read.c reads environment maps with OpenEXRCore, the format's C
// library.  In OpenEXR 3.1 (Debian 12's) that library cannot decompress
// DWAA and DWAB, the lossy compressions Blender and Nuke write by default
// for EXR maps, and reads no tiled file through the scanline calls; the C++
// library of the same release can do both.  So this file, the core's only
// C++, is a fallback exr_read.c takes for those files alone, after it has
// checked the header (size limit, channels, storage) with the C library:
// the pixels come from Imf::InputFile, reading from memory through an
// Imf::IStream over the bytes the scene loader already holds.  Every
// exception stays inside: the C side gets -1 and the library's message.
// No thread pool: Imf's global one is off unless a program turns it on, so
// a read runs on the calling thread like every other decode in the core.
#include "codec/exr_imf.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <stdexcept>

namespace {

// The file's bytes as a stream Imf reads; a read past the end throws, as
// Imf's own file streams do.
class exr_imf_stream : public Imf::IStream {
  public:
    exr_imf_stream(const void *buf, size_t len)
        : Imf::IStream("memory"), p_(static_cast<const char *>(buf)), len_(len) {}
    bool read(char c[], int n) override {
        if (n < 0 || static_cast<uint64_t>(n) > len_ - pos_)
            throw std::runtime_error("the file ends inside its data");
        std::memcpy(c, p_ + pos_, static_cast<size_t>(n));
        pos_ += static_cast<uint64_t>(n);
        return pos_ < len_;
    }
    uint64_t tellg() override { return pos_; }
    void seekg(uint64_t pos) override { pos_ = pos < len_ ? pos : len_; }
    void clear() override {}

  private:
    const char *p_;
    uint64_t len_;
    uint64_t pos_ = 0;
};

void exr_imf_read(const void *buf, size_t len, float *rgb, int w, int h) {
    exr_imf_stream in(buf, len);
    Imf::InputFile file(in);
    const Imath::Box2i dw = file.header().dataWindow();
    if (dw.max.x - dw.min.x + 1 != w || dw.max.y - dw.min.y + 1 != h)
        throw std::runtime_error("the data window is not the one the header gave");
    const size_t xs = 3 * sizeof(float), ys = xs * static_cast<size_t>(w);
    // Imf addresses pixel (x, y) of the data window as base + x*xs + y*ys.
    char *base = reinterpret_cast<char *>(rgb) - static_cast<ptrdiff_t>(dw.min.x) * (ptrdiff_t)xs -
                 static_cast<ptrdiff_t>(dw.min.y) * (ptrdiff_t)ys;
    Imf::FrameBuffer fb;
    const char *names[3] = {"R", "G", "B"};
    for (int k = 0; k < 3; k++)
        fb.insert(names[k], Imf::Slice(Imf::FLOAT, base + k * sizeof(float), xs, ys, 1, 1, 0.0));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
}

} // namespace

extern "C" int exr_imf_read_rgb(const void *buf, size_t len, float *rgb, int w, int h,
                                char *message, size_t message_size) {
    try {
        exr_imf_read(buf, len, rgb, w, h);
        return 0;
    } catch (const std::exception &e) {
        std::snprintf(message, message_size, "%s", e.what());
    } catch (...) {
        std::snprintf(message, message_size, "OpenEXR failed with an unknown error");
    }
    return -1;
}
