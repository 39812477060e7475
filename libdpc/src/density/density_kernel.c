/* The density kernel (density_kernel_body.h) on 8-lane GCC vectors for any CPU: the scalar ISA
 * path. The compiler lowers the vectors to what the target has (two SSE registers on a generic
 * x86-64 build); packing and table lookups go lane by lane. */
#include <math.h>
#include <stdint.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#define VW 8
typedef float vf __attribute__((vector_size(32)));
typedef int32_t vi __attribute__((vector_size(32)));

/* Vectors passed between static inline functions: no ABI is involved. */
#pragma GCC diagnostic ignored "-Wpsabi"

static inline vf load_lanes(const float *p) {
    vf v;
    __builtin_memcpy(&v, p, sizeof v);
    return v;
}

#if defined(__SSE2__)
/* GCC splits 8-lane arithmetic into SSE halves but not comparisons (it goes lane by lane), so
 * the comparisons, minima and square roots are written on the halves; the same values. */
typedef float vf4 __attribute__((vector_size(16)));
typedef int32_t vi4 __attribute__((vector_size(16)));
#define LO(v) __builtin_shufflevector(v, v, 0, 1, 2, 3)
#define HI(v) __builtin_shufflevector(v, v, 4, 5, 6, 7)
#define JOIN(a, b) __builtin_shufflevector(a, b, 0, 1, 2, 3, 4, 5, 6, 7)
static inline vf sqrt_lanes(vf x) { return JOIN((vf4)_mm_sqrt_ps((__m128)LO(x)), (vf4)_mm_sqrt_ps((__m128)HI(x))); }
static inline vf min_lanes(vf a, vf b) {
    return JOIN((vf4)_mm_min_ps((__m128)LO(a), (__m128)LO(b)), (vf4)_mm_min_ps((__m128)HI(a), (__m128)HI(b)));
}
static inline vi4 imin4(vi4 a, vi4 b) {
    const vi4 lt = (vi4)_mm_cmplt_epi32((__m128i)a, (__m128i)b);
    return (a & lt) | (b & ~lt);
}
static inline vi imin_lanes(vi a, vi b) { return JOIN(imin4(LO(a), LO(b)), imin4(HI(a), HI(b))); }
static inline vi window_lanes(vf v, vf lo, vf hi) {
    const __m128 a =
        _mm_and_ps(_mm_cmpgt_ps((__m128)LO(v), (__m128)LO(lo)), _mm_cmplt_ps((__m128)LO(v), (__m128)LO(hi)));
    const __m128 b =
        _mm_and_ps(_mm_cmpgt_ps((__m128)HI(v), (__m128)HI(lo)), _mm_cmplt_ps((__m128)HI(v), (__m128)HI(hi)));
    return JOIN((vi4)a, (vi4)b);
}
static inline vi live_lanes(vi iota, int32_t n) {
    const __m128i nn = _mm_set1_epi32(n);
    return JOIN((vi4)_mm_cmplt_epi32((__m128i)LO(iota), nn), (vi4)_mm_cmplt_epi32((__m128i)HI(iota), nn));
}
#define VMIN(a, b) min_lanes(a, b)
#define VIMIN(a, b) imin_lanes(a, b)
#define VLIVE(iota, n) live_lanes(iota, n)
#define WINDOW(v, lo, hi) window_lanes(v, lo, hi)
#else
static inline vf sqrt_lanes(vf x) {
    vf r;
    for (int l = 0; l < VW; l++) r[l] = sqrtf(x[l]);
    return r;
}
#define WINDOW(v, lo, hi) (((v) > (lo)) & ((v) < (hi)))
#endif

#include "cpu/cpu_tables_portable.h"

/* Every lane stored, the pointer moved past the lanes of m only. */
static inline uint32_t pack_lanes(vi m, vf tx, vf ty, vf a, float *px, float *py, float *pa) {
    uint32_t n = 0;
    for (int l = 0; l < VW; l++) {
        px[n] = tx[l];
        py[n] = ty[l];
        pa[n] = a[l];
        n += (uint32_t)m[l] & 1u;
    }
    return n;
}

#define KERNEL dpc_density_kernel_generic
#define VLOAD(p) load_lanes(p)
#define VSQRT(x) sqrt_lanes(x)
#define LOAD_TABLE(T, src, n) ((T)->w = (src), (void)(n))
#define LOOKUP(T, b) lookup_lanes(T, b)
typedef vi mask_t;
#define PACK3(m, tx, ty, a, px, py, pa) pack_lanes(m, tx, ty, a, px, py, pa)
#include "density/density_kernel_body.h"
