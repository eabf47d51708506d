/* Fused N-step sinusoidal decode of one block of pixels (hdrfringe.core._blockdecode, issue 16).
 *
 * Two plain C functions on raw buffers, called through ctypes once per block each, with numpy's
 * SIMD np.arctan2 in between (libm's scalar atan2 is about 12x slower; benchmarks/README.md,
 * "Native kernel"):
 *
 *   hf_decode_sums    one pass over the N shifts: S, C, the sum and the saturation count per
 *                     pixel, then -S and C for the atan2, I' = sqrt(S*S + C*C) * (2/N) and
 *                     I'' = sum / N (sum * (1/N) for N a power of two: the same number);
 *   hf_decode_finish  after phase = atan2(-S, C): the wrap to [0, 2*pi), validity, NaN filling,
 *                     psi = I'/I'' and the stores into the maps (float64, or float32 rounded to
 *                     nearest).
 *
 * The arithmetic is that of the numpy block kernel, operation for operation and in the same
 * order (S = 0 + I_0 sin(d_0) + I_1 sin(d_1) + ..., a multiply then an add: the build uses
 * -ffp-contract=off, so no fused multiply-add), so every map is bit-identical to it.
 */

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>

/* Keep in step with _Params in hdrfringe/core/_blockdecode.py (ctypes.Structure). */
typedef struct {
    const char *stack;       /* element (k, p) at stack + k * row_stride + p * itemsize */
    int64_t row_stride;      /* bytes from one shift to the next (may be negative) */
    const double *sin_d;     /* sin(delta_k), N values */
    const double *cos_d;     /* cos(delta_k) */
    double full;             /* saturation: value >= full (with validity) */
    double min_modulation;   /* validity: I' >= min_modulation */
    const uint8_t *mask;     /* validity: pixels to decode, NULL for all */
    void *phase;             /* map bases (float64 or float32 per out_f32); NULL if not asked */
    void *modulation;
    void *mean;
    void *psi;
    uint8_t *sat;            /* saturation count map (with validity) */
    uint8_t *valid;          /* validity map (with validity) */
    int32_t dtype;           /* 0 uint8, 1 uint16, 2 float32, 3 float64 */
    int32_t n;               /* shifts */
    int32_t quality;         /* modulation and mean maps */
    int32_t validity;        /* saturation count, psi, validity, NaN filling */
    int32_t check_finite;    /* validity also needs a finite phase (float input) */
    int32_t reject_saturated;
    int32_t out_f32;         /* float maps stored in float32 */
    int32_t isa;             /* -1: the best the CPU has; 0 baseline, 1 AVX2, 2 AVX-512F */
} hf_decode_params;

enum { HF_U8 = 0, HF_U16 = 1, HF_F32 = 2, HF_F64 = 3 };

#define CHUNK 256

/* x86-64 with GCC or clang: each kernel is compiled three times, for AVX-512F, AVX2 and the
 * SSE2 baseline, and the entry point runs the best one the CPU has (or the one asked for with
 * params.isa, so that tests can compare every variant). The results are the same bits on every
 * path: only IEEE operations (+, *, /, sqrt, comparisons, conversions), each correctly
 * rounded, no fused multiply-add (-ffp-contract=off). Elsewhere (or built with
 * -DHF_NO_DISPATCH, to try that path here): the baseline build only. */
#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__) && !defined(HF_NO_DISPATCH)
#define HF_X86 1
#define HF_BODY static inline __attribute__((always_inline))
#else
#define HF_X86 0
#define HF_BODY static inline
#endif
#define TWO_PI 6.283185307179586476925286766559

/* S, C and the sum of pixels [q0, q0 + m) (m <= CHUNK) into s, c, t: the numpy kernel's
 * s += f * sin_d[k]; c += f * cos_d[k]; total += f, one shift after the other. Up to four
 * shifts per pass over the chunk (the sums stay in registers between them); C evaluates
 * s + a + b left to right, so the order of the additions is the numpy kernel's. */
#define ROW(T, k) ((const T *)(p->stack + (ptrdiff_t)(k) * p->row_stride) + q0)
#define SUMS_LOOP(T)                                                                        \
    {                                                                                       \
        int32_t k = 0;                                                                      \
        for (; k + 4 <= p->n; k += 4) {                                                     \
            const T *x0 = ROW(T, k), *x1 = ROW(T, k + 1), *x2 = ROW(T, k + 2),              \
                    *x3 = ROW(T, k + 3);                                                    \
            const double s0 = p->sin_d[k], s1 = p->sin_d[k + 1], s2 = p->sin_d[k + 2],      \
                         s3 = p->sin_d[k + 3];                                              \
            const double c0 = p->cos_d[k], c1 = p->cos_d[k + 1], c2 = p->cos_d[k + 2],      \
                         c3 = p->cos_d[k + 3];                                              \
            for (int64_t i = 0; i < m; i++) {                                               \
                const double f0 = (double)x0[i], f1 = (double)x1[i], f2 = (double)x2[i],    \
                             f3 = (double)x3[i];                                            \
                s[i] = s[i] + f0 * s0 + f1 * s1 + f2 * s2 + f3 * s3;                        \
                c[i] = c[i] + f0 * c0 + f1 * c1 + f2 * c2 + f3 * c3;                        \
                t[i] = t[i] + f0 + f1 + f2 + f3;                                            \
            }                                                                               \
        }                                                                                   \
        for (; k < p->n; k++) {                                                             \
            const T *x0 = ROW(T, k);                                                        \
            const double s0 = p->sin_d[k], c0 = p->cos_d[k];                                \
            for (int64_t i = 0; i < m; i++) {                                               \
                const double f0 = (double)x0[i];                                            \
                s[i] = s[i] + f0 * s0;                                                      \
                c[i] = c[i] + f0 * c0;                                                      \
                t[i] = t[i] + f0;                                                           \
            }                                                                               \
        }                                                                                   \
    }

/* Saturation count: shifts with value >= full (NaN never is). */
#define SAT_LOOP(T, LIMIT)                                                                  \
    for (int32_t k = 0; k < p->n; k++) {                                                    \
        const T *x = ROW(T, k);                                                             \
        for (int64_t i = 0; i < m; i++) st[i] = (uint8_t)(st[i] + (x[i] >= (LIMIT)));       \
    }

/* hf_decode_sums (below), for one instruction set. */
HF_BODY int sums_body(const hf_decode_params *p, int64_t p0, int64_t p1, double *ys, double *cb,
                      double *mb, double *tb) {
    double s[CHUNK], c[CHUNK], t[CHUNK];
    uint8_t st[CHUNK];
    const double two_n = 2.0 / (double)p->n, nd = (double)p->n;
    /* sum / N: for N a power of two, sum * (1/N) is the same correctly rounded number (1/N
     * is exact), and a multiply is cheaper than a divide. */
    const int pow2 = (p->n & (p->n - 1)) == 0;
    const double inv_n = 1.0 / nd;
    if (p->dtype < HF_U8 || p->dtype > HF_F64) return -1;
    for (int64_t q0 = p0; q0 < p1; q0 += CHUNK) {
        const int64_t m = (p1 - q0 < CHUNK) ? p1 - q0 : CHUNK;
        for (int64_t i = 0; i < m; i++) s[i] = c[i] = t[i] = 0.0;
        switch (p->dtype) {
            case HF_U8: SUMS_LOOP(uint8_t) break;
            case HF_U16: SUMS_LOOP(uint16_t) break;
            case HF_F32: SUMS_LOOP(float) break;
            default: SUMS_LOOP(double) break;
        }
        if (p->validity) {
            for (int64_t i = 0; i < m; i++) st[i] = 0;
            /* integer images: an integer limit (full is 2^B - 1, exact), so the loop stays
             * in the images' type; float images compare in double (float32 -> double and
             * the integer full are exact, as in numpy's float32 comparison). */
            const double full = p->full;
            switch (p->dtype) {
                case HF_U8: {
                    const int lim = full > 255.0 ? 256 : (int)ceil(full);
                    SAT_LOOP(uint8_t, lim) break;
                }
                case HF_U16: {
                    const int32_t lim = full > 65535.0 ? 65536 : (int32_t)ceil(full);
                    SAT_LOOP(uint16_t, lim) break;
                }
                case HF_F32: SAT_LOOP(float, full) break;
                default: SAT_LOOP(double, full) break;
            }
            uint8_t *sat = p->sat + q0;
            for (int64_t i = 0; i < m; i++) sat[i] = st[i];
        }
        const int64_t o = q0 - p0;
        for (int64_t i = 0; i < m; i++) {
            ys[o + i] = -s[i];
            cb[o + i] = c[i];
        }
        if (p->quality) {
            for (int64_t i = 0; i < m; i++) {
                mb[o + i] = sqrt(s[i] * s[i] + c[i] * c[i]) * two_n;
                tb[o + i] = pow2 ? t[i] * inv_n : t[i] / nd;
            }
        }
    }
    return 0;
}

/* The numpy kernel's wrap of atan2's [-pi, pi] to [0, 2*pi): add 2*pi where <= 0 and +0.0
 * elsewhere (a no-op there: no -0.0 is left), then a sum that rounds to 2*pi becomes +0.0. */
static inline double wrap(double a) {
    a = a + (a <= 0.0 ? TWO_PI : 0.0);
    return a >= TWO_PI ? 0.0 : a;
}

/* Validity, NaN filling, psi and the stores of pixels [q0, q0 + m) (m <= CHUNK), maps of type
 * T; valid[q0..] holds the mask and saturation test (0/1) on entry. Short passes over the
 * chunk, each a loop the compiler vectorizes (a select writes back the array it reads);
 * |a| <= DBL_MAX is isfinite(a). */
#define FINISH_VALID(T)                                                                     \
    {                                                                                       \
        T *out_ph = (T *)p->phase + q0, *out_md = (T *)p->modulation + q0;                  \
        T *out_tt = (T *)p->mean + q0, *out_ps = (T *)p->psi + q0;                          \
        for (int64_t i = 0; i < m; i++) out_ph[i] = (T)a[i];                                \
        for (int64_t i = 0; i < m; i++) out_md[i] = (T)md[i];                               \
        for (int64_t i = 0; i < m; i++) out_tt[i] = (T)tt[i];                               \
        for (int64_t i = 0; i < m; i++) out_ps[i] = (T)ps[i];                               \
    }
/* Without validity: the wrapped phase, and I', I'' as they are (quality). */
#define FINISH_PLAIN(T)                                                                     \
    {                                                                                       \
        T *out_ph = (T *)p->phase + p0;                                                     \
        for (int64_t i = 0; i < m; i++) out_ph[i] = (T)wrap(ph[i]);                         \
        if (p->quality) {                                                                   \
            T *out_md = (T *)p->modulation + p0, *out_tt = (T *)p->mean + p0;               \
            for (int64_t i = 0; i < m; i++) {                                               \
                out_md[i] = (T)mb[i];                                                       \
                out_tt[i] = (T)tb[i];                                                       \
            }                                                                               \
        }                                                                                   \
    }

/* hf_decode_finish (below), for one instruction set. */
HF_BODY int finish_body(const hf_decode_params *p, int64_t p0, int64_t p1, const double *ph,
                        const double *mb, const double *tb) {
    if (!p->validity) {
        const int64_t m = p1 - p0;
        if (p->out_f32)
            FINISH_PLAIN(float)
        else
            FINISH_PLAIN(double)
        return 0;
    }
    double a[CHUNK], md[CHUNK], tt[CHUNK], ps[CHUNK], ok[CHUNK];
    const double minmod = p->min_modulation, nan = (double)NAN;
    for (int64_t q0 = p0; q0 < p1; q0 += CHUNK) {
        const int64_t m = (p1 - q0 < CHUNK) ? p1 - q0 : CHUNK, o = q0 - p0;
        uint8_t *valid = p->valid + q0;
        const uint8_t *sat = p->sat + q0;
        if (p->mask != NULL) {
            const uint8_t *mask = p->mask + q0;
            for (int64_t i = 0; i < m; i++) valid[i] = mask[i] != 0;
        } else {
            for (int64_t i = 0; i < m; i++) valid[i] = 1;
        }
        if (p->reject_saturated)
            for (int64_t i = 0; i < m; i++) valid[i] = (uint8_t)(valid[i] & (sat[i] == 0));
        for (int64_t i = 0; i < m; i++) ok[i] = (double)valid[i];
        for (int64_t i = 0; i < m; i++) {
            a[i] = wrap(ph[o + i]);
            md[i] = mb[o + i];
            tt[i] = tb[o + i];
        }
        for (int64_t i = 0; i < m; i++) ok[i] = md[i] >= minmod ? ok[i] : 0.0;
        if (p->check_finite)
            for (int64_t i = 0; i < m; i++) ok[i] = fabs(a[i]) <= DBL_MAX ? ok[i] : 0.0;
        for (int64_t i = 0; i < m; i++) a[i] = ok[i] != 0.0 ? a[i] : nan;
        for (int64_t i = 0; i < m; i++) md[i] = ok[i] != 0.0 ? md[i] : nan;
        for (int64_t i = 0; i < m; i++) tt[i] = ok[i] != 0.0 ? tt[i] : nan;
        for (int64_t i = 0; i < m; i++) ps[i] = md[i] / tt[i];
        for (int64_t i = 0; i < m; i++) ps[i] = tt[i] <= 0.0 ? nan : ps[i];
        for (int64_t i = 0; i < m; i++) valid[i] = ok[i] != 0.0;
        if (p->out_f32)
            FINISH_VALID(float)
        else
            FINISH_VALID(double)
    }
    return 0;
}

/* The same as finish_body with validity, one pixel at a time: with two doubles per vector
 * (the SSE2 baseline) the passes of finish_body, with their uint8 <-> double conversions, cost
 * more than this loop (bench_phase.py --blocks, the SSE2 row); AVX2 and AVX-512F vectorise
 * them profitably. */
#define FINISH_SCALAR(T)                                                                    \
    {                                                                                       \
        T *out_ph = (T *)p->phase, *out_md = (T *)p->modulation;                            \
        T *out_tt = (T *)p->mean, *out_ps = (T *)p->psi;                                    \
        for (int64_t i = 0; i < p1 - p0; i++) {                                             \
            const int64_t q = p0 + i;                                                       \
            double a = wrap(ph[i]), md = mb[i], tt = tb[i];                                 \
            int v = md >= minmod;                                                           \
            if (p->check_finite) v = v && fabs(a) <= DBL_MAX;                               \
            if (p->reject_saturated) v = v && p->sat[q] == 0;                               \
            if (p->mask != NULL) v = v && p->mask[q] != 0;                                  \
            p->valid[q] = (uint8_t)v;                                                       \
            if (!v) a = md = tt = nan;                                                      \
            double ps = md / tt;                                                            \
            if (tt <= 0.0) ps = nan;                                                        \
            out_ps[q] = (T)ps;                                                              \
            out_ph[q] = (T)a;                                                               \
            out_md[q] = (T)md;                                                              \
            out_tt[q] = (T)tt;                                                              \
        }                                                                                   \
    }

HF_BODY int finish_scalar_body(const hf_decode_params *p, int64_t p0, int64_t p1,
                               const double *ph, const double *mb, const double *tb) {
    if (!p->validity) return finish_body(p, p0, p1, ph, mb, tb);
    const double minmod = p->min_modulation, nan = (double)NAN;
    if (p->out_f32)
        FINISH_SCALAR(float)
    else
        FINISH_SCALAR(double)
    return 0;
}

/* --- entry points ------------------------------------------------------------------------ */

#if HF_X86
#define HF_VARIANTS(NAME, BODY, BASE, PARAMS, ARGS)                                           \
    __attribute__((target("avx512f"))) static int NAME##_avx512f PARAMS { return BODY ARGS; } \
    __attribute__((target("avx2"))) static int NAME##_avx2 PARAMS { return BODY ARGS; }       \
    static int NAME##_base PARAMS { return BASE ARGS; }
#define SUMS_PARAMS                                                                           \
    (const hf_decode_params *p, int64_t p0, int64_t p1, double *ys, double *cb, double *mb,   \
     double *tb)
#define FINISH_PARAMS                                                                         \
    (const hf_decode_params *p, int64_t p0, int64_t p1, const double *ph, const double *mb,   \
     const double *tb)
HF_VARIANTS(sums, sums_body, sums_body, SUMS_PARAMS, (p, p0, p1, ys, cb, mb, tb))
HF_VARIANTS(finish, finish_body, finish_scalar_body, FINISH_PARAMS, (p, p0, p1, ph, mb, tb))

/* The best instruction set of this CPU: 2 AVX-512F, 1 AVX2, 0 baseline. */
int hf_decode_isa(void) {
    if (__builtin_cpu_supports("avx512f")) return 2;
    if (__builtin_cpu_supports("avx2")) return 1;
    return 0;
}

static int isa_of(const hf_decode_params *p) {
    const int best = hf_decode_isa();
    return (p->isa < 0 || p->isa > best) ? best : p->isa;
}
#else
int hf_decode_isa(void) { return 0; }
#endif

/* Pixels [p0, p1): -S into ys, C into cb, I' into mb and I'' into tb (with quality), and the
 * saturation count into the map (with validity). ys, cb, mb, tb hold p1 - p0 values each.
 * Returns 0, or -1 for an unknown dtype. */
int hf_decode_sums(const hf_decode_params *p, int64_t p0, int64_t p1, double *ys, double *cb,
                   double *mb, double *tb) {
#if HF_X86
    switch (isa_of(p)) {
        case 2: return sums_avx512f(p, p0, p1, ys, cb, mb, tb);
        case 1: return sums_avx2(p, p0, p1, ys, cb, mb, tb);
        default: return sums_base(p, p0, p1, ys, cb, mb, tb);
    }
#else
    return sums_body(p, p0, p1, ys, cb, mb, tb);
#endif
}

/* Pixels [p0, p1) after ph = atan2(-S, C): the wrap to [0, 2*pi), then with validity
 * valid = I' >= min_modulation [and finite phase] [and no saturated shift] [and in mask],
 * phase, I', I'' NaN where invalid, psi = I'/I'' (NaN where I'' <= 0); stores every map
 * (float32 maps: rounded to nearest, as numpy's astype). ph, mb, tb hold p1 - p0 values (mb,
 * tb unused without quality; a float64 map's own slice may be passed). Returns 0. */
int hf_decode_finish(const hf_decode_params *p, int64_t p0, int64_t p1, const double *ph,
                     const double *mb, const double *tb) {
#if HF_X86
    switch (isa_of(p)) {
        case 2: return finish_avx512f(p, p0, p1, ph, mb, tb);
        case 1: return finish_avx2(p, p0, p1, ph, mb, tb);
        default: return finish_base(p, p0, p1, ph, mb, tb);
    }
#else
    return finish_scalar_body(p, p0, p1, ph, mb, tb);
#endif
}
