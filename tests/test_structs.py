"""What fogcli.device.structs declares for the host against what the kernels read: every struct's
size and member offsets measured on the device (sizeof / __builtin_offsetof in a probe
kernel), and every code and constant read from the kernels' headers as the device compiles
them, so a member added, moved or padded differently, or a code renumbered, on one side
fails here instead of shifting or misreading values."""
import numpy as np
import pytest

from fogcli.api import make_config
from fogcli.device.plan import defines
from fogcli.device.structs import AL_TABLE_T, C_NAMES, CAMERA_T, LIGHT_T, LMEDIUM_T, MEDIUM_T, NOISE_T, TFM_T
from fogcli.device.runtime import KERNEL_DIR

# (C type, the file that declares it, numpy dtype, (numpy field, C member) pairs)
STRUCTS = [
    ("camera_t", "density.h", CAMERA_T, [("pos", "pos"), ("rot", "rot0"), ("focal_px", "focal_px"),
                                         ("focal_y", "focal_y"), ("cx", "cx"), ("cy", "cy"),
                                         ("max_depth", "max_depth"), ("depth_is_z", "depth_is_z")]),
    ("medium_t", "medium.h", MEDIUM_T, [(n, n) for n in ("sa", "ss", "emission", "ambient", "cam", "g",
                                                              "spread_scale", "homogeneous", "has_medium_light",
                                                              "has_p")]),
    ("lmedium_t", "lights.h", LMEDIUM_T, [(n, n) for n in LMEDIUM_T.names]),
    ("light_t", "lights.h", LIGHT_T, [(n, n) for n in LIGHT_T.names]),
    ("al_table_t", "lights.h", AL_TABLE_T, [(n, n) for n in AL_TABLE_T.names]),
    ("noise_t", "noise.h", NOISE_T, [(n, n) for n in NOISE_T.names]),
    ("tfm_t", "noise.h", TFM_T, [(n, n) for n in TFM_T.names]),
]


@pytest.mark.parametrize("ctype,source,dtype,members", STRUCTS, ids=[s[0] for s in STRUCTS])
def test_struct_layout_matches_device(rt, ctype, source, dtype, members):
    lines = [f'#include "{source}"', "__kernel void probe(__global int *out) {", f"    out[0] = (int)sizeof({ctype});"]
    for k, (_, member) in enumerate(members):
        lines.append(f"    out[{k + 1}] = (int)__builtin_offsetof({ctype}, {member});")
    lines.append("}")
    src = "\n".join(lines)
    opts = ["-I", str(KERNEL_DIR)] + (["-D", "FOGCLI_POCL=1"] if rt.pocl else [])
    for k, v in sorted(defines(make_config("fog")).items()):
        opts += ["-D", f"{k}={v}"]
    cl = rt.cl
    prog = cl.Program(rt.ctx, src).build(options=opts)
    out = np.full(len(members) + 1, -1, np.int32)
    buf = cl.Buffer(rt.ctx, cl.mem_flags.WRITE_ONLY, out.nbytes)
    prog.probe(rt.queue, (1,), (1,), buf)
    cl.enqueue_copy(rt.queue, out, buf)
    rt.queue.finish()
    want = [dtype.itemsize] + [dtype.fields[name][1] for name, _ in members]
    assert out.tolist() == want, dict(zip(["sizeof"] + [m for _, m in members], zip(out.tolist(), want)))


# the header that declares each constant of fogcli.device.structs.C_NAMES (the default a kernel
# compiles with where the host passes none)
HEADERS = ("lights.h", "noise.h")


def test_codes_and_constants_match_the_kernels(rt):
    names = sorted(C_NAMES)
    lines = [f'#include "{h}"' for h in HEADERS] + ["__kernel void probe_constants(__global int *out) {"]
    lines += [f"    out[{k}] = (int)({name});" for k, name in enumerate(names)] + ["}"]
    opts = ["-I", str(KERNEL_DIR)] + (["-D", "FOGCLI_POCL=1"] if rt.pocl else [])
    for k, v in sorted(defines(make_config("fog")).items()):
        opts += ["-D", f"{k}={v}"]
    cl = rt.cl
    prog = cl.Program(rt.ctx, "\n".join(lines)).build(options=opts)
    out = np.full(len(names), -12345, np.int32)
    buf = cl.Buffer(rt.ctx, cl.mem_flags.WRITE_ONLY, out.nbytes)
    prog.probe_constants(rt.queue, (1,), None, buf)
    cl.enqueue_copy(rt.queue, out, buf)
    rt.queue.finish()
    assert dict(zip(names, out.tolist())) == {n: C_NAMES[n] for n in names}
