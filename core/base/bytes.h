/* bytes.h -- little-endian words read from and written to byte buffers,
 * whatever the host's order: the file formats rayd reads and writes by
 * hand (a .glb's chunk heads, an EXR header's attribute sizes, the sums
 * format of a split render) keep their numbers little-endian. */
#ifndef RAYD_BYTES_H
#define RAYD_BYTES_H

#include <stdint.h>

static inline uint32_t bytes_le32(const unsigned char *p) {
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static inline void bytes_put_le32(unsigned char *p, uint32_t v) {
    for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (8 * i));
}

#endif
