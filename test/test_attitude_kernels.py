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

"""
The compiled attitude (numba, the ``fast`` extra) against the numpy evaluation it mirrors.

The kernels repeat numpy's IEEE operations in numpy's order, so the two agree to the last bit
except where a function's own last bit differs: numpy evaluates ``tanh`` (the ``m > 1/2`` series)
with its own vectorised code, the kernels with the C library's, and both are within an ulp. A
changed last bit of the angle ``psi ~ |w| t`` can change the rounding of every later term of ``q``,
hence the tolerances: ``8 eps |w|_max`` for rates and ``4 eps (16 + |w| t_max)`` for quaternions
(the hard cases measure at most ``1.9 eps |w|`` and ``0.24 eps (1 + |w| t)``). Accuracy itself is
tested on both paths against the references (test_hard_cases.py, the ``attitude_path`` fixture).
"""

from __future__ import annotations

import math
import os
import subprocess
import sys

from hypothesis import assume, given, settings
from hypothesis import strategies as st
import numpy as np
import pytest
from torquefree_ros import propagate, propagate_batch
from torquefree_ros.bench.cases import REFERENCE_FILE
from torquefree_ros.core.body.rigid_body import RigidBody
from torquefree_ros.core.exact import attitude_kernels as kernels
from torquefree_ros.core.exact.polhode import body_polhode
from torquefree_ros.core.exact.polhode_constants import attitude_constants, solver_from_body
from torquefree_ros.core.numerics import kernels as switch
from torquefree_ros.core.numerics.ops import FLOATS
from torquefree_ros.core.propagators import make_propagator

EPS = np.finfo(float).eps

pytestmark = pytest.mark.skipif(
    not switch.AVAILABLE and not os.environ.get('CI'),
    reason='numba (the fast extra) is not installed',
)


def _both(monkeypatch, function):
    results = {}
    for compiled in (True, False):
        monkeypatch.setattr(switch, 'ENABLED', compiled)
        results[compiled] = function()
    return results[True], results[False]


def _assert_close(compiled, reference, speed, horizon, label):
    (w1, q1), (w0, q0) = compiled, reference
    rate_tolerance = 8.0 * EPS * float(np.abs(w0).max(initial=0.0))
    np.testing.assert_allclose(w1, w0, rtol=0, atol=rate_tolerance, err_msg=label)
    np.testing.assert_allclose(
        q1, q0, rtol=0, atol=4.0 * EPS * (16.0 + speed * horizon), err_msg=label
    )


def test_every_hard_case_agrees_with_the_numpy_path(monkeypatch):
    import json

    for case in json.loads(REFERENCE_FILE.read_text())['cases']:
        times = np.linspace(0.0, max(case['times']), 4001)
        compiled, reference = _both(
            monkeypatch,
            lambda: propagate(
                case['inertia'], case['angular_velocity'], case['orientation'], times
            ),
        )
        _assert_close(
            compiled,
            reference,
            float(np.linalg.norm(case['angular_velocity'])),
            times[-1],
            case['name'],
        )


def test_each_kind_of_motion_has_its_kernel():
    """
    Each kind of motion has its kernel; stationary motions keep their closed form.

    The kinds are m <= 1/2, m > 1/2 and the separatrix; stationary motions have no polhode.
    """
    if not switch.ENABLED:
        pytest.skip('the kernels are turned off (TORQUEFREE_ROS_KERNELS=numpy)')
    trigonometric = make_propagator([1.0, 2.0, 3.0], [0.3, 0.2, 1.0], [0, 0, 0, 1])._attitude
    hyperbolic = make_propagator([2.0, 3.0, 4.0], [0.7, 0.5, 0.6], [0, 0, 0, 1])._attitude
    separatrix = make_propagator(
        [3.0, 4.0, 6.0], [2.0, 0.5, 1.0], [0, 0, 0, 1]
    )._attitude  # H^2 = 2 T I2
    assert trigonometric._kernel is kernels.trigonometric_kernel
    assert hyperbolic._kernel is kernels.hyperbolic_kernel
    assert separatrix._kernel is kernels.separatrix_kernel
    assert all(
        a._table.shape == (1, kernels.TABLE_WIDTH) for a in (trigonometric, hyperbolic, separatrix)
    )
    # a pure spin
    assert make_propagator([1.0, 2.0, 3.0], [0.0, 2.0, 0.0], [0, 0, 0, 1])._attitude is None


def _component(low, high):
    """
    Return a strategy of floats in [low, high], those below 1e-6 in magnitude as 0.

    Products of tiny components underflow, which the strict test settings raise on.
    """
    return st.floats(low, high).map(lambda x: 0.0 if abs(x) < 1e-6 else x)


moments = st.lists(st.floats(0.5, 5.0), min_size=3, max_size=3).filter(
    lambda m: max(m) <= 0.99 * (sum(m) - max(m))
)
rates = st.lists(_component(-3.0, 3.0), min_size=3, max_size=3).filter(
    lambda w: math.hypot(*w) > 1e-3
)
unit = st.lists(_component(-1.0, 1.0), min_size=4, max_size=4).filter(
    lambda q: math.hypot(*q) > 0.1
)


@settings(max_examples=150, deadline=None)
@given(moments, rates, unit, st.floats(1.0, 1e4))
def test_random_bodies_agree_with_the_numpy_path(inertia, w, q0, horizon):
    q0 = np.array(q0) / math.hypot(*q0)
    times = np.linspace(0.0, horizon, 301)
    results = {}
    # (hypothesis and function-scoped fixtures do not mix: set and restore)
    for compiled in (True, False):
        saved, switch.ENABLED = switch.ENABLED, compiled
        try:
            results[compiled] = propagate(inertia, w, q0, times)
        finally:
            switch.ENABLED = saved
    _assert_close(results[True], results[False], math.hypot(*w), horizon, f'I={inertia} w={w}')


def test_a_batch_of_both_kinds_agrees_with_the_numpy_path(monkeypatch):
    rng = np.random.default_rng(3)
    inertia = np.concatenate(
        [
            [1.5, 2.0, 3.0] * (1.0 + 0.01 * rng.standard_normal((20, 3))),
            [2.0, 3.0, 4.0] * (1.0 + 0.01 * rng.standard_normal((20, 3))),
        ]
    )
    omega0 = np.concatenate(
        [
            [0.3, 0.2, 1.0] + 0.01 * rng.standard_normal((20, 3)),
            [0.7, 0.5, 0.6] + 0.01 * rng.standard_normal((20, 3)),
        ]
    )
    orientation = rng.normal(size=(40, 4))
    orientation /= np.linalg.norm(orientation, axis=1, keepdims=True)
    times = np.linspace(0.0, 100.0, 57)
    compiled, reference = _both(
        monkeypatch, lambda: propagate_batch(inertia, omega0, orientation, times)
    )
    _assert_close(
        compiled, reference, float(np.linalg.norm(omega0, axis=1).max()), times[-1], 'batch'
    )


def test_one_sample_and_an_empty_request(monkeypatch):
    monkeypatch.setattr(switch, 'ENABLED', True)
    propagator = make_propagator([2.0, 3.0, 4.0], [0.7, 0.5, 0.6], [0, 0, 0, 1])
    omega, q = propagator(np.array([0.5, 1.0, 7.0]))
    one = propagator(7.0)
    np.testing.assert_array_equal(one[0], omega[2:])
    np.testing.assert_array_equal(one[1], q[2:])
    empty = propagator(np.empty(0))
    assert empty[0].shape == (0, 3) and empty[1].shape == (0, 4)


def test_the_environment_turns_the_kernels_off():
    """
    ``TORQUEFREE_ROS_KERNELS=numpy`` selects the numpy path in a new process.

    A user's way to rule the kernels out when a result looks wrong.
    """
    code = 'from torquefree_ros.core.numerics import kernels; print(kernels.ENABLED)'
    for value, expected in (('numpy', 'False'), ('numba', str(switch.AVAILABLE))):
        env = {**os.environ, 'TORQUEFREE_ROS_KERNELS': value}
        printed = subprocess.run(
            [sys.executable, '-c', code], env=env, capture_output=True, text=True, check=True
        )
        assert printed.stdout.strip() == expected


# -- the compiled constants (build_row) against the Python path's (FLOATS) ------------------------
#: columns that depend on a Euclidean norm (math.hypot there, a scaled sum of squares here): the
#: momentum, psi's rate and offset, and the frame change (entries of an orthogonal 4x4 matrix)
NORM_COLUMNS = [
    kernels.MOMENTUM,
    kernels.TWO_MOMENTUM,
    kernels.HALF_PSI_RATE,
    kernels.HALF_PSI_OFFSET,
    *range(kernels.FRAME_CHANGE_ROWS, kernels.FRAME_CHANGE_ROWS + 16),
]


def _python_row(body, omega0, q0):
    """
    Return ``(kind, row)`` from the Python path's values, in the kernels' table layout.

    Both are None for a stationary motion.
    """
    polhode = body_polhode(body, omega0)
    if polhode is None:
        return None, None
    jacobi, rate = polhode.jacobi, polhode.rate
    c = attitude_constants(
        FLOATS,
        polhode.frame,
        solver_from_body(FLOATS, polhode.frame, body.principal_axes.tolist()),
        list(q0),
        jacobi.sn2_integral_slope,
    )
    theta, K = jacobi._theta, jacobi.quarter_period
    values = [
        rate,
        c.initial_phase,
        *((0.5 / K, 2.0 * K, theta.scale) if theta else (0.0, 0.0, 0.0)),
        c.momentum,
        2.0 * c.momentum,
        *c.momentum_amplitudes,
        *c.lever,
        0.5 * c.direction,
        0.5 * c.psi_rate,
        0.5 * c.psi_offset,
        *(v for row in c.rate_matrix for v in row),
        *(v for row in c.frame_change for v in row),
    ]
    if theta is None:
        kind, values = 'separatrix', values + [math.sqrt(-jacobi.n)]
    elif theta.trigonometric:
        kind, values = 'trigonometric', values + [theta.phase.base]
    else:
        kind, values = 'hyperbolic', values + [K, 0.5 * K, jacobi.k_prime, theta.phase.kappa]
    if theta is not None:
        values += [v for cubic in theta.rows + list(theta.phase.cubics) for v in cubic]
    return kind, np.array([float(v) for v in values] + [0.0] * (kernels.TABLE_WIDTH - len(values)))


def _assert_same_constants(body, omega0, q0, label):
    kind, expected = _python_row(body, np.asarray(omega0, dtype=float), q0)
    kinds, table = kernels.build_tables(
        body.moments, body.principal_axes, np.asarray(omega0, dtype=float), q0
    )
    if kind is None:
        assert kinds[0] == -1, label
        return
    assert kernels.KINDS[kinds[0]] == kind, label
    exact = np.setdiff1d(np.arange(kernels.TABLE_WIDTH), NORM_COLUMNS)
    np.testing.assert_array_equal(
        table[0, exact], expected[exact], err_msg=f'{label}: columns {exact}'
    )
    np.testing.assert_allclose(
        table[0, NORM_COLUMNS], expected[NORM_COLUMNS], rtol=8 * EPS, atol=8 * EPS, err_msg=label
    )


def test_compiled_constants_are_the_python_ones_on_every_hard_case():
    """
    Every column but those of a norm is bit for bit the Python path's, on every hard case.

    The compiled constants are computed operation for operation as the Python path computes them.
    """
    import json

    from torquefree_ros.core.exact.elliptic import JacobiElliptic

    assert kernels.TRIGONOMETRIC_MC == JacobiElliptic.TRIGONOMETRIC_MC

    for case in json.loads(REFERENCE_FILE.read_text())['cases']:
        q0 = np.array(case['orientation']) / math.hypot(*case['orientation'])
        _assert_same_constants(
            RigidBody.from_inertia(case['inertia']), case['angular_velocity'], q0, case['name']
        )


symmetric_or_not = st.one_of(
    moments,
    moments.map(lambda m: [m[0], m[0], m[2]] if max(m) <= 0.99 * (2 * m[0]) else m),
    moments.map(lambda m: [m[0], m[2], m[2]]),
)


@settings(max_examples=300, deadline=None)
@given(
    symmetric_or_not,
    st.lists(_component(-3.0, 3.0), min_size=3, max_size=3),
    unit,
    st.floats(0.01, math.pi),
    st.booleans(),
)
def test_compiled_constants_are_the_python_ones_for_any_body(inertia, w, q0, turn, as_tensor):
    """
    The compiled constants are the Python path's for random bodies.

    Symmetric ones, pure spins and rest among them, given by moments or by tensors.
    """
    # the [I0, I2, I2] bodies of symmetric_or_not break the triangle inequality when I0 > 2 I2: no
    # rigid body has those moments, as moments or as a tensor, and RigidBody refuses them
    largest = max(inertia)
    assume(largest <= sum(inertia) - largest)
    q0 = np.array(q0) / math.hypot(*q0)
    if as_tensor:  # principal axes turned about (1, 1, 1) / sqrt(3)
        axis = np.full(3, 1.0 / math.sqrt(3.0))
        cross = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        R = np.eye(3) + math.sin(turn) * cross + (1 - math.cos(turn)) * cross @ cross
        tensor = R @ np.diag(inertia) @ R.T
        inertia = [tensor[i, j] for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))]
    _assert_same_constants(RigidBody.from_inertia(inertia), w, q0, f'I={inertia} w={w}')


def test_a_build_is_cheap_and_the_polhode_comes_when_asked(monkeypatch):
    """
    With the kernels, building the exact propagator computes only the table.

    Its ``polhode`` (the regime parameters, for reports) is computed on first use, by the Python
    path.
    """
    monkeypatch.setattr(switch, 'ENABLED', True)
    propagator = make_propagator([2.0, 3.0, 4.0], [0.7, 0.5, 0.6], [0, 0, 0, 1])
    assert 'polhode' not in vars(propagator)
    assert (
        propagator.polhode.jacobi.mc
        == body_polhode(propagator.body, propagator.omega0_B).jacobi.mc
    )
