/* The lane layer of the kernels that CPUs with AVX2 and no AVX-512 would run scalar
 * (lights.cl's airlight tables, shadows.cl's epipolar unwarp): LANES 8 writes the same code
 * on float8, eight pixels of a row per work-item. LLVM gives up on the loop over
 * work-items there (the table and sample reads are gathers, which it does not emit for
 * AVX2 CPUs, and the bounds check masks every store), so such a kernel ran scalar, 3-5.5x
 * slower than on AVX-512 (airlight 5.5x, epi_unwarp ~97 against 33 ms at 2 MPx); written
 * on float8 it is vector code whatever the vectoriser decides, a read one load per lane.
 * LANES 1 (the default, every other device) is the scalar code. Per-pixel values are lanef
 * / lanei, uniform ones float; a comparison is 1 in a scalar and -1 in a vector lane, so
 * truth is tested as != 0. The host sets LANES (runtime.Runtime.lanes). */
#ifndef FOGCLI_LANES_H
#define FOGCLI_LANES_H

#include "common.h"

#ifndef LANES
#define LANES 1
#endif
#if LANES == 8
typedef float8 lanef;
typedef int8 lanei;
#define lane_exp exp_poly8
#define LANE_ABS(v) as_float8(as_int8(v) & 0x7fffffff)
/* lane by lane: the library's sqrt and vload8 on vectors are calls in PoCL; sqrt8 (common.h)
 * and these compile to one instruction */
#define LANE_SQRT(v) sqrt8(v)
#define LANE_INT(v) __builtin_convertvector((v), int8)
#define LANE_FLOAT(v) __builtin_convertvector((v), float8)
#define LANE_LOAD(p, k) GATHER8(p, k)
/* lane l's float o of float4 element k[l] of f (k: element indices) */
#define LANE_READ4(f, k, o) GATHER8(f, 4 * (k) + (o))
#define LANE0 ((int8)(0, 1, 2, 3, 4, 5, 6, 7))
#define LANE_TRUE ((int8)(-1))
ALWAYS_INLINE float8 lane_load8(__global const float *p)
{
    return (float8)(p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]);
}

/* log_pos of common.h, lane by lane */
ALWAYS_INLINE float8 lane_log(float8 x)
{
    int8 bits = as_int8(x);
    int8 m = (bits & 0x007fffff) | 0x3f800000;
    int8 big = (m > 0x3fb504f3) & 1;
    int8 e = ((bits >> 23) & 0xff) - 127 + big;
    float8 mant = as_float8(m - (big << 23));
    float8 t = (mant - 1.0f) / (mant + 1.0f), t2 = t * t;
    float8 series = t * (2.0f + t2 * (0.66666667f + t2 * (0.4f + t2 * 0.28571429f)));
    return series + LANE_FLOAT(e) * 0.69314718f;
}
#else
typedef float lanef;
typedef int lanei;
#define LANE_ABS(v) ABS_(v)
#define LANE_SQRT(v) SQRT_(v)
#define LANE_INT(v) ((int)(v))
#define LANE_FLOAT(v) ((float)(v))
#define LANE_LOAD(p, k) ((p)[k])
#define LANE_READ4(f, k, o) ((f)[4 * (k) + (o)])
#define LANE0 0
#define LANE_TRUE 1
#define lane_exp exp_poly
#define lane_log log_pos
#endif

#endif
