import numpy as np
import pytest

from torquefree_ros.core import PROPAGATORS


@pytest.fixture(autouse=True)
def raise_on_float_errors():
    """Numeric tests run with every floating-point exception raised (overflow, invalid, ...)."""
    with np.errstate(all="raise"):
        yield


# Settings at which each propagator is accurate enough for the shared convention checks below
# (1e-8 rad over ~10 s of motion at |w| ~ 1 rad/s).
ACCURATE_SETTINGS = {
    "analytic": {},
    "rk4": {"step": 1e-3},
    "lie_rk4": {"step": 1e-3},
    "dop853": {"rtol": 1e-12, "atol": 1e-14},
}


@pytest.fixture(params=sorted(PROPAGATORS))
def propagator_name(request):
    return request.param


def pytest_collection_modifyitems(items):
    missing = set(PROPAGATORS) - set(ACCURATE_SETTINGS)
    assert not missing, f"give ACCURATE_SETTINGS for new propagators: {missing}"
