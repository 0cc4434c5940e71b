# Copyright 2026 torquefree_ros maintainers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

import os
import signal

import numpy as np
import pytest
from torquefree_ros.core import PROPAGATORS


@pytest.fixture(autouse=True)
def raise_on_float_errors():
    """Numeric tests run with every floating-point exception raised (overflow, invalid, ...)."""
    with np.errstate(all='raise'):
        yield


def missing_requirement(what: str) -> None:
    """
    Skip a test (or its module) whose requirement ``what`` describes is missing here.

    On CI (the CI environment variable set) fail instead: CI installs every requirement, so a skip
    there would pass without testing anything.
    """
    if os.environ.get('CI'):
        pytest.fail(f'{what} (CI installs it)', pytrace=False)
    pytest.skip(what, allow_module_level=True)


def require_numba(what: str = 'numba is not installed') -> None:
    """Skip a test that needs numba where it is missing; fail on CI."""
    missing_requirement(what)


@pytest.fixture(params=['compiled', 'numpy'])
def attitude_path(request, monkeypatch):
    """
    Run a test on both evaluations of the exact attitude: numba's kernels and numpy's arrays.

    Numba's kernels are the ``fast`` extra, which propagators use when it is installed; numpy's
    arrays are the reference, always there. Without numba the compiled run is skipped, except on
    CI, where requirements-test.txt installs it.
    """
    from torquefree_ros.core.numerics import kernels as switch

    if request.param == 'compiled' and not switch.AVAILABLE:
        require_numba('numba (the fast extra) is not installed')
    monkeypatch.setattr(switch, 'ENABLED', request.param == 'compiled')
    return request.param


@pytest.fixture(params=['compiled', 'reference'])
def integrator_path(request, monkeypatch):
    """
    Run a test on both paths of the numerical propagators: numba's kernels and the reference.

    Numba's kernels (core/compiled) are the default; the reference is scipy's DOP853 and numpy's
    stages. Without numba the compiled run is skipped, except on CI, where the requirements install
    it.
    """
    from torquefree_ros.core.numerics import kernels as switch

    if request.param == 'compiled' and not switch.AVAILABLE:
        require_numba()
    monkeypatch.setattr(switch, 'ENABLED', request.param == 'compiled')
    return request.param


# The longest a test waits for a process it started to start, answer or exit (only bounds a hang).
# Quiet, a node exits within 2 s of its signal; with both cores overloaded (four test sessions
# beside a benchmark) exits took over 30 s, start-up as long again.
PROCESS_TIMEOUT = 180.0  # s


# Settings at which each propagator is accurate enough for the shared convention checks below
# (1e-8 rad over ~10 s of motion at |w| ~ 1 rad/s).
ACCURATE_SETTINGS = {
    'analytic': {},
    'gyrostat': {},
    'rk4': {'step': 1e-3},
    'lie_rk4': {'step': 1e-3},
    'dop853': {'rtol': 1e-12, 'atol': 1e-14},
}


@pytest.fixture(params=sorted(PROPAGATORS))
def propagator_name(request):
    return request.param


def pytest_collection_modifyitems(items):
    missing = set(PROPAGATORS) - set(ACCURATE_SETTINGS)
    assert not missing, f'give ACCURATE_SETTINGS for new propagators: {missing}'


# -- one DDS participant a process: Fast DDS can deadlock destroying a participant while another
# participant of the same process discovers it (seen: a test's node teardown spinning forever in
# DomainParticipant::set_listener while the other participant's event thread waited on its
# discovery mutex). Each rclpy context is one participant, with one 'dds.ev.N' thread. A test that
# leaves a second one alive (a module's shared node beside a test's own) fails here, by name.
def _dds_participants() -> int:
    tasks = f'/proc/{os.getpid()}/task'
    if not os.path.isdir(tasks):  # not Linux: nothing to count by
        return 0
    count = 0
    for task in os.listdir(tasks):
        try:
            with open(f'{tasks}/{task}/comm') as comm:
                count += comm.read().startswith('dds.ev')
        except OSError:  # the thread ended meanwhile
            pass
    return count


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_call(item):
    yield
    participants = _dds_participants()
    assert participants <= 1, (
        f'{participants} DDS participants alive in one test process during {item.nodeid}: run the '
        "tests that start their own node before (or apart from) a module's shared one"
    )


# -- DDS isolation: each test session owns a ROS domain, so parallel runs never see each other ----
_domain = None


def pytest_configure(config):
    """
    Claim a free ROS domain id and keep discovery on this machine.

    The domain id is claimed before any rclpy context exists, through the test kit's lock files, so
    sessions and the kit's simulators never share one.
    """
    global _domain
    from torquefree_ros.testing.domains import claim_domain

    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    # the tests stop the processes they start with SIGINT; a session started in the background (a
    # shell's `&` ignores SIGINT there) would hand its processes an ignored SIGINT, which survives
    # exec: handled here, the processes start with the default
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    # a node subprocess that dies of a signal (SIGABRT from the C++ runtime) prints its Python
    # stacks
    os.environ['PYTHONFAULTHANDLER'] = '1'
    try:
        _domain = claim_domain()
    except RuntimeError as error:
        raise pytest.UsageError(f'this test session: {error}') from None
    os.environ['ROS_DOMAIN_ID'] = str(_domain.domain_id)
