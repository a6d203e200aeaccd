"""What PoCL (CPU) vectorises across work-items, on this CPU and as the kernels compile for
an AVX2-only AMD EPYC (Zen 1, LLVM znver1, through tools/avx2/run.sh): micro-kernels
on 2M floats (2048 x 1024 for the 2-D ones), best of 7. A kernel PoCL vectorises runs at
about the memory's speed (1-4 ms here); one it leaves scalar takes several times longer.

    python tools/pocl_vectorisation.py [--doc docs/performance.md]

Findings of session 1 (AVX-512): OpenCL builtins (exp, sqrt, fmax, ...) are non-inlined
calls that stop vectorisation; a __constant parameter read needs `restrict`; a loop over
primitive types and float3 arithmetic stay slow. Session 9 (AVX2): see the table the script
writes (docs/performance.md, "What PoCL vectorises"). Session 17: an index such as 4 (j w + i)
becomes gathers (and its stores scatters), a row pointer indexed by 4 i + c wide loads and
shuffles: the k_rgba_* and k_pair_* rows.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

SRC = r'''
inline float exp_poly(float y){ float z=y*1.44269504f; z=z<-127.0f?-127.0f:(z>128.0f?128.0f:z); int ni=(int)(z+(z>=0.0f?0.5f:-0.5f)); float g=(z-(float)ni)*0.69314718f;
 float p=1.0f+g*(1.0f+g*(0.5f+g*(1.0f/6.0f+g*(1.0f/24.0f+g*(1.0f/120.0f+g*(1.0f/720.0f+g*(1.0f/5040.0f)))))));
 return z<=-127.0f?0.0f:p*as_float((ni+127)<<23);}
typedef struct { int type; float factor; float falloff; float radius; float4 n; float4 o; } density_t;
inline float expo(float pre, float b, float k, float D){ float x=-b*D*k; float series=1.0f+x*(0.5f+x*(1.0f/6.0f+x*(1.0f/24.0f))); float direct=(exp_poly(x)-1.0f)/x; return pre*D*((x<1e-2f && x>-1e-2f)?series:direct);}
__kernel void k_exp(__global const float* restrict a,__global float* restrict b){int i=get_global_id(0); b[i]=exp(a[i]);}
__kernel void k_pexp(__global const float* restrict a,__global float* restrict b){int i=get_global_id(0); b[i]=exp_poly(a[i]);}
__kernel void k_sqrt(__global const float* restrict a,__global float* restrict b){int i=get_global_id(0); b[i]=sqrt(a[i]);}
__kernel void k_bsqrt(__global const float* restrict a,__global float* restrict b){int i=get_global_id(0); b[i]=__builtin_sqrtf(a[i]);}
__kernel void k_bound(__global const float*a,__global float*b,int n){int i=get_global_id(0); if(i>=n) return; b[i]=expo(1.3f,0.2f,0.3f,a[i]*100.0f);}
__kernel void k_const(__global const float* restrict a,__global float* restrict b,__constant const density_t* restrict d){int i=get_global_id(0); b[i]=expo(d[0].n.w,d[0].falloff,d[0].n.y,a[i]*100.0f);}
__kernel void k_loop(__global const float* restrict a,__global float* restrict b,__constant const density_t* restrict d,int nd){int i=get_global_id(0); float P=0; for(int k=0;k<nd;++k){ if(d[k].type==0) P+=d[k].factor*a[i]; else P+=expo(d[k].n.w,d[k].falloff,d[k].n.y,a[i]*100.0f);} b[i]=P;}
__kernel void k_f3(__global const float4* restrict a,__global float4* restrict b){int i=get_global_id(0); float3 v=a[i].xyz; float3 r=(float3)(exp_poly(-v.x),exp_poly(-v.y),exp_poly(-v.z)); b[i]=(float4)(r*v, 1.0f);}
__kernel void k_gather(__global const float* restrict a,__global float* restrict b,__global const float* restrict lut){int i=get_global_id(0); int k=(int)(a[i]*60.0f); b[i]=lut[k]+lut[k+1]*a[i];}
__kernel void k_exp_gather(__global const float* restrict a,__global float* restrict b,__global const float* restrict lut){int i=get_global_id(0); int k=(int)(a[i]*60.0f); b[i]=exp_poly(-a[i])*(lut[k]+lut[k+1]*a[i]);}
__kernel void k_rgba_plain(__global const float* restrict a,__global float* restrict b){int i=get_global_id(0); const __global float*f=a+4*i; __global float*o=b+4*i; float x=f[0],y=f[1],z=f[2],w=f[3]; o[0]=x*2.0f; o[1]=y*3.0f; o[2]=z*y; o[3]=w;}
__kernel void k_rgba_exp(__global const float* restrict a,__global float* restrict b){int i=get_global_id(0); const __global float*f=a+4*i; __global float*o=b+4*i; float x=f[0],y=f[1],z=f[2],w=f[3]; o[0]=exp_poly(-x); o[1]=exp_poly(-y); o[2]=exp_poly(-z); o[3]=w;}
__kernel void k_rgba_in_exp(__global const float* restrict a,__global float* restrict b){int i=get_global_id(0); const __global float*f=a+4*i; b[i]=exp_poly(-f[0])+exp_poly(-f[1])+exp_poly(-f[2]);}
__kernel void k_planes_exp(__global const float* restrict a,__global float* restrict b,int n){int i=get_global_id(0); b[i]=exp_poly(-a[i]); b[n+i]=exp_poly(-a[n+i]); b[2*n+i]=exp_poly(-a[2*n+i]);}
__kernel void k_vec4_exp(__global const float4* restrict a,__global float4* restrict b){int i=get_global_id(0); float4 v=a[i]; b[i]=(float4)(exp_poly(-v.x),exp_poly(-v.y),exp_poly(-v.z),v.w);}
__kernel void k_nb_clamp(__global const float* restrict a,__global float* restrict b,int w,int h){int i=get_global_id(0),j=get_global_id(1); if(i>=w||j>=h) return; int idx=j*w+i; int ip=i+1<w?i+1:w-1; b[idx]=exp_poly(-a[idx])+a[j*w+ip];}
__kernel void k_nb_masked(__global const float* restrict a,__global float* restrict b,int w,int h){int i=get_global_id(0),j=get_global_id(1); if(i>=w||j>=h) return; int idx=j*w+i; float v=i+1<w?a[idx+1]:a[idx]; b[idx]=exp_poly(-a[idx])+v;}
__kernel void k_nb_affine(__global const float* restrict a,__global float* restrict b,int w,int h){int i=get_global_id(0),j=get_global_id(1); if(i>=w||j>=h) return; int idx=j*w+i; float v=a[idx+1]; b[idx]=exp_poly(-a[idx])+(i+1<w?v:0.0f);}
__kernel void k_rgba_idx(__global const float* restrict a,__global float* restrict b,int w,int h){int i=get_global_id(0),j=get_global_id(1); int idx=j*w+i; b[idx]=a[4*idx]*0.2f+a[4*idx+1]*0.7f+a[4*idx+2]*0.1f+a[4*idx+3];}
__kernel void k_rgba_row(__global const float* restrict a,__global float* restrict b,int w,int h){int i=get_global_id(0),j=get_global_id(1); const __global float*r=a+4*j*w; b[j*w+i]=r[4*i]*0.2f+r[4*i+1]*0.7f+r[4*i+2]*0.1f+r[4*i+3];}
__kernel void k_pair_idx(__global const float* restrict a,__global float* restrict b,int w,int h){int i=get_global_id(0),j=get_global_id(1); int idx=j*w+2*i; for(int p=0;p<2;++p){ b[4*(idx+p)]=a[4*(idx+p)]*2.0f; b[4*(idx+p)+1]=a[4*(idx+p)+1]; b[4*(idx+p)+2]=a[4*(idx+p)+2]*a[4*(idx+p)]; b[4*(idx+p)+3]=a[4*(idx+p)+3];}}
__kernel void k_pair_row(__global const float* restrict a,__global float* restrict b,int w,int h){int i=get_global_id(0),j=get_global_id(1); const __global float*r=a+4*j*w; __global float*o=b+4*j*w; for(int p=0;p<2;++p){ o[8*i+4*p]=r[8*i+4*p]*2.0f; o[8*i+4*p+1]=r[8*i+4*p+1]; o[8*i+4*p+2]=r[8*i+4*p+2]*r[8*i+4*p]; o[8*i+4*p+3]=r[8*i+4*p+3];}}
'''

# name: (what it tests, 2-D?)
KERNELS = {
    "k_exp": "builtin exp (a call)",
    "k_pexp": "exp_poly (inline polynomial)",
    "k_sqrt": "builtin sqrt",
    "k_bsqrt": "__builtin_sqrtf",
    "k_bound": "bounds check + expo",
    "k_const": "__constant struct read (restrict)",
    "k_loop": "loop over primitives",
    "k_f3": "float3 arithmetic",
    "k_gather": "table read at a data index (gather)",
    "k_exp_gather": "gather + exp_poly",
    "k_rgba_plain": "RGBA float4 as 4 floats in and out, no exp",
    "k_rgba_exp": "RGBA as 4 floats in and out + 3 exp_poly",
    "k_rgba_in_exp": "RGBA in, one float out + 3 exp_poly",
    "k_planes_exp": "three planes in and out + 3 exp_poly",
    "k_vec4_exp": "float4 typed load/store + 3 exp_poly",
    "k_nb_clamp": "2-D, right neighbour at a clamped index",
    "k_nb_masked": "2-D, right neighbour read under a condition",
    "k_nb_affine": "2-D, right neighbour read unconditionally (padded)",
    "k_rgba_idx": "2-D, RGBA read at 4 (j w + i) + c",
    "k_rgba_row": "2-D, RGBA read at row[4 i + c], row = a + 4 j w",
    "k_pair_idx": "2-D, two RGBA pixels a work-item at 4 (j w + 2 i + p) + c",
    "k_pair_row": "2-D, two RGBA pixels a work-item at row[8 i + 4 p + c]",
}
TWO_D = {"k_nb_clamp", "k_nb_masked", "k_nb_affine", "k_rgba_idx", "k_rgba_row", "k_pair_idx", "k_pair_row"}
HALF_W = {"k_pair_idx", "k_pair_row"}    # a work-item per pair of pixels


def measure() -> dict:
    import pyopencl as cl

    # PoCL by name: with the test extras installed, Oclgrind's platform may be listed first
    # (it was, in session 39: every kernel then failed to build and the table read nan)
    from fogcli.device.runtime import choose, list_devices
    dev = choose(list_devices(), "portable computing language", origin="pocl_vectorisation.py")[1]
    ctx = cl.Context([dev])
    q = cl.CommandQueue(ctx, properties=cl.command_queue_properties.PROFILING_ENABLE)
    prg = cl.Program(ctx, SRC).build()
    n, W, H = 1 << 21, 2048, 1024
    mf = cl.mem_flags
    a = (np.random.default_rng(0).random(4 * n + 4096) * 0.9).astype(np.float32)
    A = cl.Buffer(ctx, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=a)
    B = cl.Buffer(ctx, mf.READ_WRITE, 16 * n)
    L = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.random.default_rng(1).random(128).astype(np.float32))
    dt = np.dtype([("type", np.int32), ("factor", np.float32), ("falloff", np.float32), ("radius", np.float32),
                   ("n", np.float32, 4), ("o", np.float32, 4)], align=True)
    d = np.zeros(2, dt)
    d[0]["type"], d[0]["n"], d[0]["falloff"], d[1]["factor"] = 1, [0, 1, 0, 1.3], 0.2, 1
    D = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=d)
    args = {"k_bound": (A, B, np.int32(n)), "k_const": (A, B, D), "k_loop": (A, B, D, np.int32(2)),
            "k_gather": (A, B, L), "k_exp_gather": (A, B, L), "k_planes_exp": (A, B, np.int32(n // 2))}
    out = {}
    for name in KERNELS:
        k = cl.Kernel(prg, name)
        glob = ((W // 2 if name in HALF_W else W), H) if name in TWO_D else ((n // 2,) if name == "k_planes_exp" else (n,))
        kargs = (A, B, np.int32(W), np.int32(H)) if name in TWO_D else args.get(name, (A, B))
        # the addressing kernels on fogcli's own work-groups (runtime.LOCAL_CPU)
        local = (32, 4) if name in TWO_D and name.startswith(("k_rgba_idx", "k_rgba_row", "k_pair")) else None
        best = 1e9
        for _ in range(7):
            e = k(q, glob, local, *kargs)
            e.wait()
            best = min(best, (e.profile.end - e.profile.start) * 1e-6)
        out[name] = best
    return {"device": dev.version, "ms": out}


def main() -> int:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--doc", help="write the table into this markdown file (between its markers)")
    ap.add_argument("--json", help=argparse.SUPPRESS)          # the child under tools/avx2/run.sh
    args = ap.parse_args()
    if args.json:
        Path(args.json).write_text(json.dumps(measure()))
        return 0
    with tempfile.TemporaryDirectory() as tmp:                 # children first: nothing forks after OpenCL
        runs = []
        for cpu in ("", "znver1"):
            out = Path(tmp) / f"{cpu or 'host'}.json"
            cmd = ([str(ROOT / "tools" / "avx2" / "run.sh"), cpu] if cpu else []) + [sys.executable, __file__, "--json", str(out)]
            r = subprocess.run(cmd, env={**os.environ, "POCL_CACHE_DIR": str(Path(tmp) / f"pocl-{cpu or 'host'}")})
            runs.append(json.loads(out.read_text()) if r.returncode == 0 and out.exists() else None)
    host, amd = runs
    from docblock import cpu_name

    lines = [f"`python tools/pocl_vectorisation.py` on {cpu_name()}: micro-kernels on 2M floats "
             "(2048 x 1024 for the 2-D ones), kernel ms, best of 7; the AVX2 column as PoCL compiles for an AMD "
             "EPYC Zen 1 (`tools/avx2/run.sh znver1`). Vectorised kernels run at about the memory's speed; "
             "a ratio well above 1 in the last column is a kernel PoCL leaves scalar on AVX2 only.", "",
             f"| kernel | what it tests | {host['device'].split('-')[-1] if host else 'host'} ms | "
             f"{amd['device'].split('-')[-1] if amd else 'znver1'} ms | AVX2 / host |", "|---|---|---|---|---|"]
    for name, what in KERNELS.items():
        h = host["ms"][name] if host else float("nan")
        z = amd["ms"][name] if amd else float("nan")
        lines.append(f"| {name} | {what} | {h:.2f} | {z:.2f} | {z / h:.1f} |")
    text = "\n".join(lines)
    print(text)
    if args.doc:
        from docblock import cpu_kind, markers, write_block

        begin, end = markers(f"vectorisation-{cpu_kind()}")
        write_block(Path(args.doc), begin, end, f"{begin}\n## What PoCL vectorises on {cpu_name()}\n\n{text}\n{end}",
                    new_doc="")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    sys.exit(main())
