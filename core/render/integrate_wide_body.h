/* integrate_wide_body.h -- the body of integrate_wide.c, compiled twice.
 *
 * integrate_wide.c includes this file once for the build's own target and
 * once for AVX-512, with WIDE(name) giving each copy its own names and
 * WIDE_FN its target.  The loops over the 16 lanes are straight-line code
 * on arrays of doubles (flags are doubles too, 0 or 1), the shape the
 * vectoriser turns into vector instructions; each lane does the one-ray
 * code's operations in the one-ray code's order (integrate.c, scene_query.c,
 * light.c, shape_sphere.c), so the colours are the same bits however wide
 * the registers are.
 */

/* fmax of two non-negative numbers, NaN as fmax has it (the other one). */
WIDE_FN double WIDE(fmax_nn)(double a, double b) { return a > b ? a : b != b ? a : b; }

/* The packet's flags for a lane hitting object o of material m. */
WIDE_FN void WIDE(flags)(struct wide *w, const struct object *o, const struct material *m) {
    w->top |= m->shine_whole > 0 ? m->shine_whole : 0;
    w->frac |= m->shine_whole < 0;
    w->gloss |= m->specular > 0;
    w->spheres |= o->kind == SHAPE_SPHERE;
}

/* Lane j's object o and its material. */
WIDE_FN void WIDE(put_object)(struct wide *w, int j, const struct object *o,
                              const struct material *m) {
    bool sphere = o->kind == SHAPE_SPHERE;
    vec3 g = sphere ? o->u.sphere.center : o->u.plane.normal;
    w->gx[j] = g.x, w->gy[j] = g.y, w->gz[j] = g.z;
    w->sphere[j] = sphere;
    w->colx[j] = m->color.x, w->coly[j] = m->color.y, w->colz[j] = m->color.z;
    w->emx[j] = m->emission.x, w->emy[j] = m->emission.y, w->emz[j] = m->emission.z;
    w->emf[j] = m->emit_front_only;
    w->amb[j] = m->ambient, w->dif[j] = m->diffuse, w->spec[j] = m->specular;
    w->cut[j] = m->spec_cut, w->kr[j] = m->reflectivity, w->shin[j] = m->shininess;
    w->shine[j] = m->shine_whole;
}

/* The lanes' rays, hits and materials; lanes outside the packet copy its
 * first lane, so every loop may run over all 16.  Most packets hit one
 * object: that one is read once. */
WIDE_FN void WIDE(gather)(const rayd_scene *s, const struct ray16 *r, const struct hit16 *hs,
                          uint32_t lanes, struct wide *w) {
    int first = __builtin_ctz(lanes);
    const struct object *obj[16];
    bool one = true;
    if (lanes == 0xffff) { /* the common case: straight copies */
        memcpy(w->t, hs->t, sizeof w->t), memcpy(obj, hs->leaf, sizeof obj);
        memcpy(w->ox, r->o[0], sizeof w->ox), memcpy(w->oy, r->o[1], sizeof w->oy);
        memcpy(w->oz, r->o[2], sizeof w->oz), memcpy(w->dx, r->d[0], sizeof w->dx);
        memcpy(w->dy, r->d[1], sizeof w->dy), memcpy(w->dz, r->d[2], sizeof w->dz);
    } else {
        for (int j = 0; j < 16; j++) {
            int i = lanes >> j & 1 ? j : first;
            w->t[j] = hs->t[i], obj[j] = hs->leaf[i];
            w->ox[j] = r->o[0][i], w->oy[j] = r->o[1][i], w->oz[j] = r->o[2][i];
            w->dx[j] = r->d[0][i], w->dy[j] = r->d[1][i], w->dz[j] = r->d[2][i];
        }
    }
    uintptr_t other = 0; /* bits where some lane's object differs: vectorised */
    for (int j = 0; j < 16; j++) other |= (uintptr_t)obj[j] ^ (uintptr_t)obj[0];
    one = other == 0;
    w->top = 0, w->frac = w->gloss = w->spheres = false;
    if (one) { /* copies: no store to w can change them, so they load once */
        const struct object o = *obj[0];
        const struct material m = s->mats[o.material];
        WIDE(flags)(w, &o, &m);
        for (int j = 0; j < 16; j++) WIDE(put_object)(w, j, &o, &m);
        return;
    }
    for (int j = 0; j < 16; j++) {
        const struct material *m = &s->mats[obj[j]->material];
        WIDE(flags)(w, obj[j], m);
        WIDE(put_object)(w, j, obj[j], m);
    }
}

/* hit_frame: the point, the normal facing the ray (for these shapes the
 * shading normal is the geometric one), the point lifted off the surface
 * (integrate_offset); then shade_base: emission, plus ambient when the
 * scene has lights (lit). */
WIDE_FN void WIDE(frame)(struct wide *w, double lit) {
    for (int j = 0; j < 16; j++) {
        w->px[j] = w->ox[j] + w->dx[j] * w->t[j], w->py[j] = w->oy[j] + w->dy[j] * w->t[j];
        w->pz[j] = w->oz[j] + w->dz[j] * w->t[j];
    }
    for (int j = 0; w->spheres && j < 16; j++) { /* sphere_normal_part: v3_norm(p - centre) */
        double ex = w->px[j] - w->gx[j], ey = w->py[j] - w->gy[j], ez = w->pz[j] - w->gz[j];
        double inv = 1.0 / sqrt(ex * ex + ey * ey + ez * ez);
        w->nx[j] = ex * inv, w->ny[j] = ey * inv, w->nz[j] = ez * inv;
    }
    for (int j = 0; j < 16; j++) {
        double px = w->px[j], py = w->py[j], pz = w->pz[j];
        double nx = w->sphere[j] != 0 ? w->nx[j] : w->gx[j];
        double ny = w->sphere[j] != 0 ? w->ny[j] : w->gy[j];
        double nz = w->sphere[j] != 0 ? w->nz[j] : w->gz[j];
        double in = nx * w->dx[j] + ny * w->dy[j] + nz * w->dz[j]; /* > 0: inside */
        nx = in > 0 ? -nx : nx, ny = in > 0 ? -ny : ny, nz = in > 0 ? -nz : nz;
        double off = 1e-9 * (1.0 + WIDE(fmax_nn)(fabs(px), WIDE(fmax_nn)(fabs(py), fabs(pz))));
        w->nx[j] = nx, w->ny[j] = ny, w->nz[j] = nz;
        w->up[0][j] = px + nx * off, w->up[1][j] = py + ny * off, w->up[2][j] = pz + nz * off;
        double e = w->emf[j] != 0 && in > 0 ? 0 : 1; /* a back face of a one-sided emitter */
        w->cx[j] = lit != 0 ? e * w->emx[j] + w->colx[j] * w->amb[j] : e * w->emx[j];
        w->cy[j] = lit != 0 ? e * w->emy[j] + w->coly[j] * w->amb[j] : e * w->emy[j];
        w->cz[j] = lit != 0 ? e * w->emz[j] + w->colz[j] * w->amb[j] : e * w->emz[j];
    }
}

/* light_at for a point (point != 0) or directional light, and
 * integrate_light_aim's test: the unit vector toward it, its distance, and
 * in ok whether it reaches the lane from the front. */
WIDE_FN void WIDE(aim)(const struct light *l, const struct wide *w, struct aimed *a) {
    double lx = l->position.x, ly = l->position.y, lz = l->position.z;
    double dx = -l->direction.x, dy = -l->direction.y, dz = -l->direction.z;
    double point = l->kind == LIGHT_POINT;
    for (int j = 0; j < 16; j++) {
        double vx = lx - w->px[j], vy = ly - w->py[j], vz = lz - w->pz[j];
        double len = sqrt(vx * vx + vy * vy + vz * vz), inv = 1.0 / len;
        double wx = point != 0 ? vx * inv : dx, wy = point != 0 ? vy * inv : dy;
        double wz = point != 0 ? vz * inv : dz;
        a->wi[0][j] = wx, a->wi[1][j] = wy, a->wi[2][j] = wz;
        a->dist[j] = point != 0 ? len : INFINITY;
        double reach = point != 0 ? (len > 0 ? 1.0 : 0.0) : 1.0;
        a->ok[j] = w->nx[j] * wx + w->ny[j] * wy + w->nz[j] * wz <= 0 ? 0.0 : reach;
    }
}

/* phong_pow by squaring for the 16 lanes: pw = x to the power shine, bit
 * by bit of the whole exponents (top: all their bits), each lane's
 * products the one-ray code's.  Eight lanes at a time in vector registers:
 * as a loop over the arrays, pw and x went back to memory at every bit and
 * each bit waited on the stores of the one before (a tenth of the
 * shading's time on the sphere scene). */
WIDE_FN void WIDE(pow_whole)(const double x0[16], const int64_t shine[16], int64_t top,
                             double pw[16]) {
    for (int h = 0; h < 16; h += 8) {
        wide_d8 x, p = {1, 1, 1, 1, 1, 1, 1, 1};
        wide_i8 e;
        memcpy(&x, x0 + h, sizeof x);
        memcpy(&e, shine + h, sizeof e);
        for (int b = 0; top >> b > 0; b++) {
            wide_i8 on = -((e >> b) & 1); /* all ones where bit b is set */
            wide_d8 px = p * x;
            p = (wide_d8)(((wide_i8)px & on) | ((wide_i8)p & ~on));
            x = x * x;
        }
        memcpy(pw + h, &p, sizeof p);
    }
}

/* Lambert + Blinn-Phong for one light (shade_one), wi toward it: adds to
 * c what each lane receives, pass being 1 where it arrives and r what
 * arrives (light_pass). */
WIDE_FN void WIDE(shade)(struct wide *w, const double wi[3][16], const double pass[16],
                         const double rx[16], const double ry[16], const double rz[16]) {
    LANES_ALIGN double ax[16], ay[16], az[16], ndh[16], want[16], x[16], pw[16];
    for (int j = 0; j < 16; j++) {
        double ndl = w->nx[j] * wi[0][j] + w->ny[j] * wi[1][j] + w->nz[j] * wi[2][j];
        double dl = w->dif[j] * ndl;
        ax[j] = rx[j] * (w->colx[j] * dl), ay[j] = ry[j] * (w->coly[j] * dl);
        az[j] = rz[j] * (w->colz[j] * dl);
        want[j] = 0, pw[j] = 1;
    }
    for (int j = 0; w->gloss && j < 16; j++) { /* the highlight, where some lane has one */
        double hx = wi[0][j] - w->dx[j], hy = wi[1][j] - w->dy[j];
        double hz = wi[2][j] - w->dz[j];
        double inv = 1.0 / sqrt(hx * hx + hy * hy + hz * hz);
        double d = w->nx[j] * (hx * inv) + w->ny[j] * (hy * inv) + w->nz[j] * (hz * inv);
        double hl = fabs(rx[j]) > 1 ? 1.0 : fabs(ry[j]) > 1 ? 1.0 : fabs(rz[j]) > 1 ? 1.0 : 0.0;
        hl = d > w->cut[j] ? 1.0 : hl;
        hl = w->spec[j] > 0 ? hl : 0.0;
        want[j] = pass[j] != 0 ? hl : 0.0;
        ndh[j] = d, x[j] = d;
    }
    if (w->gloss) WIDE(pow_whole)(x, w->shine, w->top, pw);
    for (int j = 0; w->gloss && w->frac && j < 16; j++) /* exponents that are not whole */
        if (want[j] != 0 && w->shine[j] < 0) pw[j] = pow(ndh[j], w->shin[j]);
    for (int j = 0; j < 16; j++) {
        double k = w->spec[j] * pw[j];
        double sx = want[j] != 0 ? ax[j] + rx[j] * k : ax[j];
        double sy = want[j] != 0 ? ay[j] + ry[j] * k : ay[j];
        double sz = want[j] != 0 ? az[j] + rz[j] * k : az[j];
        sx = pass[j] != 0 ? 0.0 + sx : 0.0, sy = pass[j] != 0 ? 0.0 + sy : 0.0;
        sz = pass[j] != 0 ? 0.0 + sz : 0.0;
        /* v3_madd(c, sum, 1.0 / n), n = 1 */
        w->cx[j] = w->cx[j] + sx * 1.0, w->cy[j] = w->cy[j] + sy * 1.0;
        w->cz[j] = w->cz[j] + sz * 1.0;
    }
}

/* The shadow rays of the lanes in aim toward light l (aimed at by a) as a
 * packet: what each lets through into a->tr. */
WIDE_FN void WIDE(shadow)(const rayd_scene *s, const struct light *l, struct aimed *a,
                          const struct wide *w, uint32_t lanes, struct meter *mt) {
    uint32_t aim = 0;
    for (int j = 0; j < 16; j++) aim |= (uint32_t)(a->ok[j] != 0) << j;
    aim &= lanes;
    if (!meter_rays(mt, (uint64_t)__builtin_popcount(aim))) aim = 0; /* stopped: none traced */
    scene_transmittance16_soa(s, (int)(l - s->lights), (const double(*)[16])w->up, a->wi, a->dist,
                              aim, a->tr);
}

/* Light l's light on the lanes, through its shadow rays' a->tr. */
WIDE_FN void WIDE(light)(const struct light *l, const struct aimed *a, struct wide *w) {
    LANES_ALIGN double pass[16], rx[16], ry[16], rz[16];
    vec3 lc = v3_scale(l->color, l->intensity);
    for (int j = 0; j < 16; j++) { /* light_pass */
        double tx = a->tr[0][j], ty = a->tr[1][j], tz = a->tr[2][j];
        /* 0 where all three are <= 0: as selects, not nested branches, so
         * the loop is vectorised (the branches were a tenth of the shading) */
        double p = tx <= 0 ? 0.0 : 1.0;
        p = ty <= 0 ? p : 1.0;
        pass[j] = tz <= 0 ? p : 1.0;
        rx[j] = lc.x * tx, ry[j] = lc.y * ty, rz[j] = lc.z * tz;
    }
    WIDE(shade)(w, a->wi, pass, rx, ry, rz);
}

/* The mirror rays (mirror_dir about the normal), every lane's. */
WIDE_FN void WIDE(mirror)(const struct wide *w, struct ray16 *rr) {
    for (int j = 0; j < 16; j++) {
        double a = -2.0 * (w->dx[j] * w->nx[j] + w->dy[j] * w->ny[j] + w->dz[j] * w->nz[j]);
        rr->d[0][j] = w->dx[j] + w->nx[j] * a, rr->d[1][j] = w->dy[j] + w->ny[j] * a;
        rr->d[2][j] = w->dz[j] + w->nz[j] * a;
        rr->o[0][j] = w->up[0][j], rr->o[1][j] = w->up[1][j], rr->o[2][j] = w->up[2][j];
    }
}

WIDE_FN uint32_t WIDE(whitted_wide)(const rayd_scene *s, const struct ray16 *r,
                                    const struct hit16 *hs, uint32_t lanes, int depth, vec3 out[16],
                                    struct ray16 *rr, double kr[16], struct meter *mt) {
    struct wide w;
    WIDE(gather)(s, r, hs, lanes, &w);
    WIDE(frame)(&w, s->nlights > 0);
    struct aimed a[WIDE_AHEAD];
    for (int i0 = 0; i0 < s->nlights; i0 += WIDE_AHEAD) { /* the aims, then the shadows */
        int n = s->nlights - i0 < WIDE_AHEAD ? s->nlights - i0 : WIDE_AHEAD; /* first: nothing */
        const struct light *l = &s->lights[i0];                              /* waits on them */
        for (int k = 0; k < n; k++) WIDE(aim)(&l[k], &w, &a[k]);
        for (int k = 0; k < n; k++) WIDE(shadow)(s, &l[k], &a[k], &w, lanes, mt);
        for (int k = 0; k < n; k++) WIDE(light)(&l[k], &a[k], &w);
    }
    uint32_t mirror = 0;
    for (uint32_t m = lanes; m; m &= m - 1) {
        int j = __builtin_ctz(m);
        out[j] = v3(w.cx[j], w.cy[j], w.cz[j]);
        kr[j] = w.kr[j];
        if (depth < s->rs.max_depth && w.kr[j] > 0) mirror |= 1u << j;
    }
    if (mirror) WIDE(mirror)(&w, rr);
    return mirror;
}
