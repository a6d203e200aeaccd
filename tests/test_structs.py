"""The structs the host fills (numpy dtypes) against the ones the kernels read: size and every
member's offset measured on the device (sizeof / __builtin_offsetof in a probe kernel), so a
member added, moved or padded differently on one side fails here instead of shifting values."""
import numpy as np
import pytest

from fogcli.api import make_config
from fogcli.lights import LIGHT_T, LMEDIUM_T
from fogcli.noise import NOISE_T, TFM_T
from fogcli.pipeline import CAMERA_T, MEDIUM_T, defines
from fogcli.runtime import KERNEL_DIR

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
