// objparse -- the OBJ parse of an Embree application, for `make bench-peers`.
//
//   objparse FILE.obj [--runs N]
//
// Embree takes triangles from its caller and has no file reader; an
// application that renders an OBJ with it parses the file first.  This is
// that parse with tinyobjloader (Debian's libtinyobjloader-dev, the loader
// most Embree-based renderers use): the file read and parsed, triangulated,
// and its corners gathered into the flat position and uint32 index arrays
// rtcSetSharedGeometryBuffer takes.  Issue 16 compares rayd's whole process
// on an OBJ with "Embree's OBJ parse + medium build + 16-wide primary and
// shadow rays"; peers.sh adds this parse to embree_bench's build and rays.
// Prints the median over RUNS runs (default 3) as "key value" lines:
// obj_parse_s, vertices, triangles.
#include <tiny_obj_loader.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace {

struct Mesh {
    std::vector<float> pos;
    std::vector<uint32_t> index;
};

// One parse: false (with a message) when tinyobjloader refuses the file.
bool parse(const char *path, Mesh *m) {
    tinyobj::ObjReaderConfig cfg;
    cfg.triangulate = true;
    cfg.vertex_color = false;
    tinyobj::ObjReader r;
    if (!r.ParseFromFile(path, cfg)) {
        std::fprintf(stderr, "objparse: %s: %s\n", path, r.Error().c_str());
        return false;
    }
    const tinyobj::attrib_t &a = r.GetAttrib();
    m->pos.assign(a.vertices.begin(), a.vertices.end());
    m->index.clear();
    for (const tinyobj::shape_t &s : r.GetShapes())
        for (const tinyobj::index_t &i : s.mesh.indices)
            m->index.push_back(static_cast<uint32_t>(i.vertex_index));
    return true;
}

} // namespace

int main(int argc, char **argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: objparse FILE.obj [--runs N]\n");
        return 2;
    }
    int runs = 3;
    for (int i = 2; i + 1 < argc; i += 2)
        if (!std::strcmp(argv[i], "--runs")) runs = std::max(1, std::atoi(argv[i + 1]));
    std::vector<double> t;
    Mesh m;
    for (int k = 0; k < runs; k++) {
        auto t0 = std::chrono::steady_clock::now();
        if (!parse(argv[1], &m)) return 1;
        t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::sort(t.begin(), t.end());
    std::printf("peer tinyobjloader %s\n", "2.0.0rc10");
    std::printf("obj_parse_s %.4f\n", t[t.size() / 2]);
    std::printf("vertices %zu\n", m.pos.size() / 3);
    std::printf("triangles %zu\n", m.index.size() / 3);
    return 0;
}
