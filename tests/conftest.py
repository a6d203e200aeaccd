import numpy as np
import pytest

from fogcli.api import make_config
from fogcli.pipeline import get_plan
from fogcli.runtime import get_runtime


@pytest.fixture(scope="session")
def rt():
    return get_runtime(None)


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


def plan_for(rt, w, h, *sets, medium="fog", aovs=()):
    cfg = make_config(medium, sets=sets)
    return get_plan(rt, w, h, cfg, aovs), cfg
