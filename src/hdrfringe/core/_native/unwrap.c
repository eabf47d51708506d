/* Reliability-guided spatial phase unwrapping (issue 16), for hdrfringe.core.unwrap.
 *
 * The algorithm of Herraez, Burton, Lalor and Gdeisat, "Fast two-dimensional phase-unwrapping
 * algorithm based on sorting by reliability following a noncontinuous path", Appl. Opt. 41(35),
 * 7437-7444 (2002), written from the paper:
 *
 * 1. Every valid pixel gets a dispersion D, the root sum of squares of its four wrapped second
 *    differences (horizontal, vertical and the two diagonals, Eq. 2-6 of the paper); its
 *    reliability is 1 / D. A second difference needs both of its neighbours valid and inside
 *    the image; a pixel beside an invalid pixel uses the ones it has, scaled to four terms
 *    (D^2 = 4/m * sum of the m squares), and a pixel with none gets D = NO_INFO, larger than
 *    any measured D (each second difference lies in (-2 pi, 2 pi], so D <= 4 pi). Pixels on
 *    the image border get NO_INFO added to theirs: they are joined after every interior
 *    pixel, among themselves by their own estimate (the paper leaves the border out of the
 *    reliabilities; scikit-image gives those pixels random low reliabilities). Measured on
 *    noisy maps with a known truth (benchmarks/bench_unwrap.py --quality): scaled estimates
 *    everywhere were a little worse on NaN-free maps, and joining the pixels beside invalid
 *    ones last as well (a raster sweep through noisy patches) much worse on maps with NaN.
 *    No random numbers: the result depends on the input only.
 * 2. Every edge between 4-neighbouring valid pixels gets the reliability of its two pixels,
 *    here the key D_p + D_q (smaller key = more reliable).
 * 3. Edges are visited by increasing key (ties by edge number: a stable sort, so the order is
 *    the one numpy.argsort(kind="stable") gives). An edge between two groups joins them,
 *    shifting the smaller group by the 2 pi multiple that keeps the step between the edge's
 *    two pixels below pi; an edge inside one group is skipped. Groups are kept in a union-find
 *    with the order of each pixel relative to its parent (union by size, path compression), so
 *    the shift of a group is one number at its root.
 *
 * Conventions shared with hdrfringe.core.unwrap: pixels in raster order, pixel i = row * w + col;
 * edge 2 i joins i to its right neighbour, edge 2 i + 1 joins i to the one below. The step
 * rule is the integration path's: for an edge from p (left or top) to q, k_q - k_p = +1 where
 * c_p - c_q > pi, -1 where c_p - c_q < -pi, else 0. Output: the integer order k of every valid
 * pixel relative to the root of its group (0 at invalid pixels); the caller counts each region
 * from its first pixel, so the group roots do not matter.
 *
 * Plain C on raw buffers (no Python API): opened with ctypes by hdrfringe.core._native.load.
 */

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846
#define TWO_PI 6.28318530717958647692
#define NO_INFO 100.0 /* > 4 pi: no second difference; added on the image border */

/* Wrap a difference of two values in [-pi, pi) into [-pi, pi]. */
static inline double wrap_diff(double d) {
    if (d > PI) return d - TWO_PI;
    if (d < -PI) return d + TWO_PI;
    return d;
}

/* Dispersion D of every pixel (NO_INFO at invalid ones; valid may be NULL: all valid). */
void hf_unwrap_dispersion(const double *c, const unsigned char *valid, int64_t h, int64_t w,
                          double *disp) {
    /* neighbour pairs (a, b) of the four second differences: (dr, dc) of a; b = -a */
    static const int dr[4] = {0, -1, -1, -1};
    static const int dc[4] = {-1, 0, -1, 1};
    for (int64_t r = 0; r < h; ++r) {
        for (int64_t col = 0; col < w; ++col) {
            int64_t i = r * w + col;
            if (valid && !valid[i]) {
                disp[i] = NO_INFO;
                continue;
            }
            double v = c[i], sum = 0.0;
            int m = 0;
            for (int t = 0; t < 4; ++t) {
                int64_t ra = r + dr[t], ca = col + dc[t], rb = r - dr[t], cb = col - dc[t];
                if (ra < 0 || ra >= h || rb < 0 || rb >= h || ca < 0 || ca >= w || cb < 0 ||
                    cb >= w)
                    continue;
                int64_t a = ra * w + ca, b = rb * w + cb;
                if (valid && (!valid[a] || !valid[b])) continue;
                double s = wrap_diff(c[a] - v) - wrap_diff(v - c[b]);
                sum += s * s;
                ++m;
            }
            double d = m == 4 ? sqrt(sum) : (m ? sqrt(sum * (4.0 / m)) : NO_INFO);
            if (r == 0 || r == h - 1 || col == 0 || col == w - 1) d += NO_INFO; /* border: last */
            disp[i] = d;
        }
    }
}

/* Key of every edge 0 .. 2 h w - 1 (HUGE_VAL where the edge does not exist: it leaves the
 * image or touches an invalid pixel). For the numpy-argsort variant and the tests. */
void hf_unwrap_edge_keys(const double *c, const unsigned char *valid, int64_t h, int64_t w,
                         double *keys) {
    int64_t n = h * w;
    for (int64_t e = 0; e < 2 * n; ++e) keys[e] = HUGE_VAL;
    double *d = (double *)malloc((size_t)(n ? n : 1) * sizeof(double));
    if (!d) return;
    hf_unwrap_dispersion(c, valid, h, w, d);
    for (int64_t i = 0; i < n; ++i) {
        if (valid && !valid[i]) continue;
        if (i % w + 1 < w && (!valid || valid[i + 1])) keys[2 * i] = d[i] + d[i + 1];
        if (i + w < n && (!valid || valid[i + w])) keys[2 * i + 1] = d[i] + d[i + w];
    }
    free(d);
}

static inline uint64_t key_bits(double k) {
    uint64_t u;
    memcpy(&u, &k, sizeof u); /* keys are >= 0: their bits sort as unsigned integers */
    return u;
}

#define RADIX_BITS 11
#define RADIX_SIZE (1 << RADIX_BITS)
#define RADIX_PASSES 6 /* 66 >= 64 bits */

/* Stable LSD radix sort of the edges by key: ids (and keys) permuted in place. Passes whose
 * digit is the same for every key are skipped. Returns 0, or -1 if out of memory. */
static int radix_sort(uint64_t *keys, uint32_t *ids, int64_t m) {
    uint64_t *k2 = (uint64_t *)malloc((size_t)(m ? m : 1) * sizeof(uint64_t));
    uint32_t *i2 = (uint32_t *)malloc((size_t)(m ? m : 1) * sizeof(uint32_t));
    int64_t *hist = (int64_t *)calloc((size_t)RADIX_PASSES * RADIX_SIZE, sizeof(int64_t));
    if (!k2 || !i2 || !hist) {
        free(k2);
        free(i2);
        free(hist);
        return -1;
    }
    for (int64_t e = 0; e < m; ++e) {
        uint64_t k = keys[e];
        for (int p = 0; p < RADIX_PASSES; ++p)
            ++hist[p * RADIX_SIZE + ((k >> (p * RADIX_BITS)) & (RADIX_SIZE - 1))];
    }
    uint64_t *src_k = keys, *dst_k = k2;
    uint32_t *src_i = ids, *dst_i = i2;
    for (int p = 0; p < RADIX_PASSES; ++p) {
        int64_t *hp = hist + p * RADIX_SIZE;
        int trivial = 0;
        for (int b = 0; b < RADIX_SIZE; ++b) {
            if (hp[b] == m) trivial = 1;
            if (hp[b]) break;
        }
        if (trivial || m == 0) continue;
        int64_t pos = 0;
        for (int b = 0; b < RADIX_SIZE; ++b) {
            int64_t cnt = hp[b];
            hp[b] = pos;
            pos += cnt;
        }
        int shift = p * RADIX_BITS;
        for (int64_t e = 0; e < m; ++e) {
            uint64_t k = src_k[e];
            int64_t at = hp[(k >> shift) & (RADIX_SIZE - 1)]++;
            dst_k[at] = k;
            dst_i[at] = src_i[e];
        }
        uint64_t *tk = src_k;
        src_k = dst_k;
        dst_k = tk;
        uint32_t *ti = src_i;
        src_i = dst_i;
        dst_i = ti;
    }
    if (src_i != ids) {
        memcpy(ids, src_i, (size_t)m * sizeof(uint32_t));
        memcpy(keys, src_k, (size_t)m * sizeof(uint64_t));
    }
    free(k2);
    free(i2);
    free(hist);
    return 0;
}

/* Root of x; *rel = k_x - k_root. Compresses the path to point at the root. */
static inline int32_t find_root(int32_t *parent, int32_t *off, int32_t x, int32_t *rel) {
    int32_t r = x, acc = 0;
    while (parent[r] != r) {
        acc += off[r];
        r = parent[r];
    }
    int32_t cur = x, rem = acc;
    while (parent[cur] != r && cur != r) {
        int32_t next = parent[cur], o = off[cur];
        parent[cur] = r;
        off[cur] = rem;
        rem -= o;
        cur = next;
    }
    *rel = acc;
    return r;
}

/* Join the groups along the edges in the given order; k[i] = order of pixel i. */
static int merge(const double *c, const unsigned char *valid, int64_t h, int64_t w,
                 const uint32_t *ids32, const int64_t *ids64, int64_t m, int32_t *k) {
    int64_t n = h * w;
    int32_t *parent = (int32_t *)malloc((size_t)n * sizeof(int32_t));
    int32_t *size = (int32_t *)malloc((size_t)n * sizeof(int32_t));
    if (!parent || !size) {
        free(parent);
        free(size);
        return -1;
    }
    int32_t *off = k; /* the output doubles as the offsets to the parent */
    for (int64_t i = 0; i < n; ++i) {
        parent[i] = (int32_t)i;
        size[i] = 1;
        off[i] = 0;
    }
    for (int64_t e = 0; e < m; ++e) {
        int64_t id = ids32 ? (int64_t)ids32[e] : ids64[e];
        if (id < 0 || id >= 2 * n) continue;
        int64_t p = id >> 1, q = (id & 1) ? p + w : p + 1;
        if ((id & 1) ? q >= n : (p % w) + 1 >= w) continue;
        if (valid && (!valid[p] || !valid[q])) continue;
        double d = c[p] - c[q];
        int32_t step = d > PI ? 1 : (d < -PI ? -1 : 0); /* k_q - k_p */
        int32_t op, oq;
        int32_t rp = find_root(parent, off, (int32_t)p, &op);
        int32_t rq = find_root(parent, off, (int32_t)q, &oq);
        if (rp == rq) continue;
        /* k_rq - k_rp = step + op - oq */
        int32_t rel = step + op - oq;
        if (size[rq] <= size[rp]) {
            parent[rq] = rp;
            off[rq] = rel;
            size[rp] += size[rq];
        } else {
            parent[rp] = rq;
            off[rp] = -rel;
            size[rq] += size[rp];
        }
    }
    for (int64_t i = 0; i < n; ++i) {
        int32_t o;
        find_root(parent, off, (int32_t)i, &o);
        /* after compression off[i] is the order relative to the root (0 at the root) */
    }
    for (int64_t i = 0; i < n; ++i)
        if (valid && !valid[i]) k[i] = 0;
    free(parent);
    free(size);
    return 0;
}

/* Fringe orders of a wrapped map c (values in [-pi, pi), any value at invalid pixels).
 *
 * valid: h * w bytes, nonzero = valid, or NULL (all valid).
 * order: NULL to sort the edges here (stable radix sort of the keys), or n_order edge ids to
 *        visit in that order (ids of missing edges are skipped).
 * k:     h * w int32, out.
 * Returns 0, -1 when out of memory, -2 when the image is too large (2 h w >= 2^31).
 */
int hf_unwrap_orders(const double *c, const unsigned char *valid, int64_t h, int64_t w,
                     const int64_t *order, int64_t n_order, int32_t *k) {
    int64_t n = h * w;
    if (h <= 0 || w <= 0) return 0;
    if (2 * n >= ((int64_t)1 << 31)) return -2;
    if (order) return merge(c, valid, h, w, NULL, order, n_order, k);

    double *disp = (double *)malloc((size_t)n * sizeof(double));
    uint64_t *keys = (uint64_t *)malloc((size_t)(2 * n) * sizeof(uint64_t));
    uint32_t *ids = (uint32_t *)malloc((size_t)(2 * n) * sizeof(uint32_t));
    if (!disp || !keys || !ids) {
        free(disp);
        free(keys);
        free(ids);
        return -1;
    }
    hf_unwrap_dispersion(c, valid, h, w, disp);
    int64_t m = 0;
    for (int64_t i = 0; i < n; ++i) {
        if (valid && !valid[i]) continue;
        int64_t col = i % w;
        if (col + 1 < w && (!valid || valid[i + 1])) {
            keys[m] = key_bits(disp[i] + disp[i + 1]);
            ids[m++] = (uint32_t)(2 * i);
        }
        if (i + w < n && (!valid || valid[i + w])) {
            keys[m] = key_bits(disp[i] + disp[i + w]);
            ids[m++] = (uint32_t)(2 * i + 1);
        }
    }
    free(disp);
    int rc = radix_sort(keys, ids, m);
    free(keys);
    if (rc == 0) rc = merge(c, valid, h, w, ids, NULL, m, k);
    free(ids);
    return rc;
}
