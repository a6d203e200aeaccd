import numpy as np
import pytest

from fogcli.device.runtime import get_runtime


@pytest.fixture(scope="session")
def rt():
    return get_runtime(None)


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


