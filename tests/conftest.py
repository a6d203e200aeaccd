import numpy as np
import pytest

from fogcli.device.runtime import get_runtime


@pytest.fixture(scope="session")
def rt():
    return get_runtime(None)


@pytest.fixture
def rng():
    return np.random.default_rng(1234)




def pytest_report_header(config):
    """The OpenCL device the run's kernels go to, and the work-group shape they launch with
    (FOGCLI_DEVICE picks another; tests/test_devices.py covers the other implementations)."""
    rt = get_runtime(None)
    return f"fogcli device: {rt.info.label()}, work-group {rt.local2d[0]} x {rt.local2d[1]}"
