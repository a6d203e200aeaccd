"""One declaration of the device buffers (plan.BUFFERS): what a plan allocates, what the
memory check counts and what keys the plan cache all come from it."""
from types import SimpleNamespace

import pytest

from helpers import plan_for
from fogcli.errors import ProcessingError
from fogcli.device.border_size import ext_level
from fogcli.device.plan import ALIASES, BUFFERS, buffer_bytes, check_memory, plan_features, planned_bytes


@pytest.mark.parametrize("sets,aovs", [((), ()), (("render.psf=apsf", "render.border=extend"), ("scattered", "transmittance")),
                                       (("render.separation.enabled=true", "render.fetch=receiver"), ("optical_depth",))])
def test_plan_allocates_what_is_declared(rt, sets, aovs):
    w, h = 37, 23
    plan, cfg = plan_for(rt, w, h, *sets, aovs=aovs)
    total = sum(a * b for a, b in plan.sizes)
    want = buffer_bytes(w * h, total, plan_features(cfg, aovs), h)
    got = {b.name: getattr(plan, b.name).size for b in BUFFERS}
    assert got == {k: want[ALIASES[k]] if k in ALIASES and not v else max(v, 16) for k, v in want.items()}
    for k, other in ALIASES.items():        # one buffer, not a copy
        assert (getattr(plan, k) is getattr(plan, other)) == (not want[k])
    assert want["chain"] == 16 * total and (want["scat_aov"] > 0) == bool(aovs)


def _rt(mem, alloc):
    return SimpleNamespace(device=SimpleNamespace(global_mem_size=mem, max_mem_alloc_size=alloc),
                           info=SimpleNamespace(name="test device"))


def test_memory_check_names_the_limit():
    from fogcli.api import make_config

    f = plan_features(make_config("fog"))
    n = 16000 * 12000
    sizes = buffer_bytes(n, n * 4 // 3, f, 12000)
    with pytest.raises(ProcessingError, match=r"16000x12000: its chain buffer needs 3906 MiB in one piece, device "
                                              r"test device allocates at most 2048 MiB: choose a device with more memory \(--device"):
        check_memory(_rt(2**40, 2**31), 16000, 12000, sizes, sum(sizes.values()))
    with pytest.raises(ProcessingError, match="needs .* MiB, device test device has 1024 MiB: choose a device .* or a smaller image$"):
        check_memory(_rt(2**30, 2**31), 16000, 12000, sizes, sum(sizes.values()))
    check_memory(_rt(2**40, 2**33), 16000, 12000, sizes, sum(sizes.values()))   # fits: no error


def test_planned_bytes_counts_what_a_frame_may_add():
    from fogcli.api import make_config

    n, t = 1000, 1333
    base = make_config("fog", sets=["render.border=open"])
    ref = make_config("fog", sets=["render.border=open", "render.method=reference"])
    ext = make_config("fog", sets=["render.border=extend"])
    declared = sum(buffer_bytes(n, t, plan_features(base), 25).values())
    assert planned_bytes(n, t, plan_features(base), base, 25) == declared
    assert planned_bytes(n, t, plan_features(ref), ref, 25) == sum(buffer_bytes(n, t, plan_features(ref), 25).values()) + 48 * n
    f = ext.render.border_margin
    # the extension's plan: the padded frame at its level's resolution (plan.ext_level: 1/2 for
    # a 40 x 25 frame's 3 px margin, 1/8 at 2 MPx), and the edge's bands: two float4 for
    # each row's two ends, each column's two ends and each corner
    for (w, h), level in (((40, 25), 1), ((1920, 1080), 3)):
        d_ext = sum(buffer_bytes(w * h, t, plan_features(ext), h).values())
        assert ext_level(ext, w, h) == level
        assert f > 0 and planned_bytes(w * h, t, plan_features(ext), ext, h) == \
            d_ext + int(d_ext * (1 + 2 * f) ** 2 / 4 ** level) + 32 * (2 * (w + h) + 4)
