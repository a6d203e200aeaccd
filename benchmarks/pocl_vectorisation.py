"""What PoCL (CPU) vectorises across work-items: micro-kernels on 2M floats, best of 5.
Findings of session 1 (see the issue note): OpenCL builtins (exp, sqrt, fmax, ...) are
non-inlined calls that stop vectorisation; a __constant parameter read needs `restrict`;
a loop over primitive types and float3 arithmetic stay slow.

    python benchmarks/pocl_vectorisation.py
"""
import numpy as np
import pyopencl as cl

ctx=cl.Context([cl.get_platforms()[0].get_devices()[0]]); q=cl.CommandQueue(ctx,properties=cl.command_queue_properties.PROFILING_ENABLE)
common='''
inline float exp_poly(float y){ float z=y*1.44269504f; z=z<-127.0f?-127.0f:(z>128.0f?128.0f:z); int ni=(int)(z+(z>=0.0f?0.5f:-0.5f)); float g=(z-(float)ni)*0.69314718f;
 float p=1.0f+g*(1.0f+g*(0.5f+g*(1.0f/6.0f+g*(1.0f/24.0f+g*(1.0f/120.0f+g*(1.0f/720.0f+g*(1.0f/5040.0f)))))));
 return z<=-127.0f?0.0f:p*as_float((ni+127)<<23);}
typedef struct { int type; float factor; float falloff; float radius; float4 n; float4 o; } density_t;
inline float expo(float pre, float b, float k, float D){ float x=-b*D*k; float series=1.0f+x*(0.5f+x*(1.0f/6.0f+x*(1.0f/24.0f))); float direct=(exp_poly(x)-1.0f)/x; return pre*D*((x<1e-2f && x>-1e-2f)?series:direct);}
'''
src=common+'''
__kernel void k_exp(__global const float* restrict a,__global float* restrict b){int i=get_global_id(0); b[i]=exp(a[i]);}
__kernel void k_pexp(__global const float* restrict a,__global float* restrict b){int i=get_global_id(0); b[i]=exp_poly(a[i]);}
__kernel void k_sqrt(__global const float* restrict a,__global float* restrict b){int i=get_global_id(0); b[i]=sqrt(a[i]);}
__kernel void k_bsqrt(__global const float* restrict a,__global float* restrict b){int i=get_global_id(0); b[i]=__builtin_sqrtf(a[i]);}
__kernel void k_plain(__global const float*a,__global float*b){int i=get_global_id(0); b[i]=expo(1.3f,0.2f,0.3f,a[i]*100.0f);}
__kernel void k_bound(__global const float*a,__global float*b,int n){int i=get_global_id(0); if(i>=n) return; b[i]=expo(1.3f,0.2f,0.3f,a[i]*100.0f);}
__kernel void k_const(__global const float* restrict a,__global float* restrict b,__constant const density_t* restrict d){int i=get_global_id(0); b[i]=expo(d[0].n.w,d[0].falloff,d[0].n.y,a[i]*100.0f);}
__kernel void k_loop(__global const float* restrict a,__global float* restrict b,__constant const density_t* restrict d,int nd){int i=get_global_id(0); float P=0; for(int k=0;k<nd;++k){ if(d[k].type==0) P+=d[k].factor*a[i]; else P+=expo(d[k].n.w,d[k].falloff,d[k].n.y,a[i]*100.0f);} b[i]=P;}
__kernel void k_cond(__global const float*a,__global float*b,__global float*c,int flag){int i=get_global_id(0); float v=expo(1.3f,0.2f,0.3f,a[i]*100.0f); b[i]=v; if(flag) c[i]=v*2.0f;}
__kernel void k_f3(__global const float4* restrict a,__global float4* restrict b){int i=get_global_id(0); float3 v=a[i].xyz; float3 r=(float3)(exp_poly(-v.x),exp_poly(-v.y),exp_poly(-v.z)); b[i]=(float4)(r*v, 1.0f);}
'''
prg=cl.Program(ctx,src).build()
n=1<<21; a=np.random.rand(4*n).astype(np.float32); A=cl.Buffer(ctx,cl.mem_flags.READ_WRITE|cl.mem_flags.COPY_HOST_PTR,hostbuf=a); B=cl.Buffer(ctx,cl.mem_flags.READ_WRITE,16*n); C=cl.Buffer(ctx,cl.mem_flags.READ_WRITE,16*n)
dt=np.dtype([("type",np.int32),("factor",np.float32),("falloff",np.float32),("radius",np.float32),("n",np.float32,4),("o",np.float32,4)],align=True)
d=np.zeros(2,dt); d[0]['type']=1; d[0]['n']=[0,1,0,1.3]; d[0]['falloff']=0.2; d[1]['type']=0; d[1]['factor']=1
Dd=cl.Buffer(ctx,cl.mem_flags.READ_ONLY|cl.mem_flags.COPY_HOST_PTR,hostbuf=d)
runs={'k_exp':(A,B),'k_pexp':(A,B),'k_sqrt':(A,B),'k_bsqrt':(A,B),'k_plain':(A,B),'k_bound':(A,B,np.int32(n)),'k_const':(A,B,Dd),'k_loop':(A,B,Dd,np.int32(2)),'k_cond':(A,B,C,np.int32(1)),'k_f3':(A,B)}
for name,args in runs.items():
    k=cl.Kernel(prg,name); best=1e9
    for r in range(5):
        e=k(q,(n,),(128,),*args); e.wait(); best=min(best,(e.profile.end-e.profile.start)*1e-6)
    print(name, round(best,2),'ms')
