/* The medium as the per-pixel stage reads it (preprocess.cl: preprocess, coverage, view
 * cosines): the host fills it from fogcli.structs.MEDIUM_T, whose layout tests/test_structs.py
 * checks against this one on the device. */
#ifndef FOGCLI_MEDIUM_H
#define FOGCLI_MEDIUM_H

#include "common.h"
#include "density.h"

typedef struct {
    float4 sa;          /* absorption per RGB, 1/m; .w = mean over RGB */
    float4 ss;          /* scattering per RGB; .w = mean */
    float4 emission;    /* L_e */
    float4 ambient;     /* L_a */
    camera_t cam;
    float g;            /* phase asymmetry */
    float spread_scale;
    float homogeneous;  /* sum of the homogeneous density factors: their P is this times D */
    int has_medium_light;   /* emission or ambient non-zero */
    int has_p;          /* the density stage left the other primitives' P in spread0 */
} medium_t;

/* Per-channel absorption and scattering of medium M as arrays A[3], S[3]; in a grey medium
 * (-D MEDIUM_GREY) every channel's are channel 0's, so the three channels' expressions are
 * the same and the compiler computes them once */
#ifdef MEDIUM_GREY
#define MEDIUM_RATES(M, A, S) float A[3] = {(M).sa.x, (M).sa.x, (M).sa.x}, S[3] = {(M).ss.x, (M).ss.x, (M).ss.x}
#else
#define MEDIUM_RATES(M, A, S) float A[3] = {(M).sa.x, (M).sa.y, (M).sa.z}, S[3] = {(M).ss.x, (M).ss.y, (M).ss.z}
#endif

#endif
