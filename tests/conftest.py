import numpy as np
import pytest

from fogcli.api import make_config
from fogcli.device.plan import get_plan
from fogcli.device.runtime import get_runtime


@pytest.fixture(scope="session")
def rt():
    return get_runtime(None)


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


def plan_for(rt, w, h, *sets, medium="fog", aovs=()):
    """Kernel tests drive the Gaussian chain with the closed border unless they name
    render.psf or render.border."""
    if not any(s.startswith("render.psf=") for s in sets):
        sets = ("render.psf=gaussian",) + tuple(sets)
    if not any(s.startswith("render.border=") for s in sets):
        sets = ("render.border=closed",) + tuple(sets)
    cfg = make_config(medium, sets=sets)
    return get_plan(rt, w, h, cfg, aovs), cfg
