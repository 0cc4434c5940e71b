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
The same checks over every registered propagator (after scipy's test_ivp).

Plus what is specific to each: convergence order, geometric |q| = 1, exactness of the analytic one.
"""

import ast
import json
from pathlib import Path
import subprocess
import sys

from conftest import ACCURATE_SETTINGS
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from torquefree_ros import make_propagator, propagate, RigidBody
from torquefree_ros.bench.cases import REFERENCE_FILE
from torquefree_ros.core.frames import quaternion

INERTIA = [1.0, 2.0, 3.0]
OMEGA = [0.4, -0.3, 0.9]
Q0 = Rotation.from_rotvec([0.2, -0.5, 0.9]).as_quat()
TIMES = np.linspace(0.0, 10.0, 41)


def run(name, inertia=INERTIA, omega=OMEGA, q0=Q0, times=TIMES):
    return propagate(inertia, omega, q0, times, propagator=name, **ACCURATE_SETTINGS[name])


def test_shapes_and_initial_state(propagator_name):
    w, q = run(propagator_name)
    assert w.shape == (TIMES.size, 3) and q.shape == (TIMES.size, 4)
    np.testing.assert_array_equal(w[0], OMEGA)
    np.testing.assert_array_equal(q[0], Q0)


def test_inertial_angular_momentum_and_energy_are_conserved(propagator_name):
    w, q = run(propagator_name)
    body = RigidBody.from_inertia(INERTIA)
    H = body.angular_momentum_inertial(w, q)
    T = body.kinetic_energy(w)
    # analytic: rounding only; numerical at ACCURATE_SETTINGS: truncation below 1e-10
    tol = 1e-14 if propagator_name == 'analytic' else 1e-10
    np.testing.assert_allclose(
        H, np.broadcast_to(H[0], H.shape), rtol=0, atol=tol * np.linalg.norm(H[0])
    )
    np.testing.assert_allclose(T, T[0], rtol=tol)


# The independent reference: tools/make_reference.py's mpmath Taylor integration at 45 digits (no
# code of the propagators), case large_angle_q0 (I = 1, 2, 3; |w| = 1.02 rad/s), its samples 0 ...
# 10 s.
REFERENCE_CASE = next(
    case
    for case in json.loads(REFERENCE_FILE.read_text())['cases']
    if case['name'] == 'large_angle_q0'
)
REFERENCE_SAMPLES = 11
# analytic: float64 rounding only; the case's floor (the solution's change for a one-ulp change of
# the inputs) is < 7e-15 over 30 s, and 100 floors is the bound test_hard_cases.py holds it to.
# Numerical at ACCURATE_SETTINGS: truncation, 1e-8 being what they promise over 10 s at |w| ~ 1
# rad/s.
AGREEMENT_TOLERANCE = {'analytic': 1e-12}


def test_agrees_with_the_exact_solution(propagator_name):
    case = REFERENCE_CASE
    times = np.array(case['times'][:REFERENCE_SAMPLES])
    assert times[-1] == 10.0
    w, q = propagate(
        case['inertia'],
        case['angular_velocity'],
        case['orientation'],
        times,
        propagator=propagator_name,
        **ACCURATE_SETTINGS[propagator_name],
    )
    w_exact, q_exact = (
        np.array(case['omega'][:REFERENCE_SAMPLES]),
        np.array(case['q'][:REFERENCE_SAMPLES]),
    )
    tolerance = AGREEMENT_TOLERANCE.get(propagator_name, 1e-8)
    np.testing.assert_allclose(w, w_exact, rtol=0, atol=tolerance)
    assert quaternion.angle_between(q, q_exact).max() < tolerance
    assert np.all(np.sum(q * q_exact, axis=1) > 0)  # the same sign: q is continuous from q0


def test_kinematics_match_finite_differences_of_q(propagator_name):
    """dq/dt = 1/2 q ⊗ (w, 0) with w in the body frame: the convention the contract states."""
    h = 1e-4
    times = np.array([3.0 - h, 3.0, 3.0 + h])
    w, q = run(propagator_name, times=times)
    dq = (q[2] - q[0]) / (2 * h)
    expected = 0.5 * quaternion.multiply(q[1], np.append(w[1], 0.0))
    # central difference: truncation h^2 |q'''| / 6 ~ 2e-9, rounding eps / h ~ 1e-12
    np.testing.assert_allclose(dq, expected, atol=5e-9)


def test_negated_quaternion_gives_the_negated_trajectory(propagator_name):
    w, q = run(propagator_name)
    w_neg, q_neg = run(propagator_name, q0=-Q0)
    np.testing.assert_array_equal(w_neg, w)
    np.testing.assert_allclose(q_neg, -q, rtol=0, atol=1e-15)


# Describing the same body in another frame changes only rounding, except for the adaptive method:
# its error norm is taken component-wise, so its step sequence (and truncation error, < 1e-10 at
# ACCURATE_SETTINGS) depends on the frame.
FRAME_TOLERANCE = {'dop853': 1e-10}


@pytest.mark.parametrize(
    'rotation, as_moments',
    [
        # axes relabelled (a proper permutation): the inertia is given as unsorted principal
        # moments
        (np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), True),
        # a general body frame: the inertia is given as the full tensor
        (Rotation.from_rotvec([0.4, 0.1, -0.8]).as_matrix(), False),
    ],
    ids=['relabelled-axes', 'full-tensor'],
)
def test_the_same_body_in_another_frame_moves_identically(propagator_name, rotation, as_moments):
    """``rotation`` maps principal coordinates to the new body frame's coordinates."""
    tensor = rotation @ np.diag(INERTIA) @ rotation.T
    inertia = np.diag(tensor) if as_moments else tensor
    q_R = quaternion.from_matrix(rotation.T)  # maps new-body coordinates to principal ones
    w, q = run(propagator_name)
    w_b, q_b = run(
        propagator_name, inertia=inertia, omega=rotation @ OMEGA, q0=quaternion.multiply(Q0, q_R)
    )
    tol = FRAME_TOLERANCE.get(propagator_name, 1e-12)
    np.testing.assert_allclose(w_b, w @ rotation.T, atol=tol)
    assert quaternion.angle_between(q_b, quaternion.multiply(q, q_R)).max() < tol


def test_samples_do_not_depend_on_how_they_are_requested(propagator_name):
    """The node asks in blocks, offline tools all at once: the samples must be identical."""
    propagator = make_propagator(
        INERTIA, OMEGA, Q0, propagator_name, **ACCURATE_SETTINGS[propagator_name]
    )
    w_all, q_all = make_propagator(
        INERTIA, OMEGA, Q0, propagator_name, **ACCURATE_SETTINGS[propagator_name]
    )(TIMES)
    blocks = [propagator(chunk) for chunk in np.array_split(TIMES, 7)]
    np.testing.assert_array_equal(np.concatenate([b[0] for b in blocks]), w_all)
    np.testing.assert_array_equal(np.concatenate([b[1] for b in blocks]), q_all)
    # one sample at a time (a node's block can be a single sample)
    singles = [
        make_propagator(INERTIA, OMEGA, Q0, propagator_name, **ACCURATE_SETTINGS[propagator_name])(
            [t]
        )
        for t in TIMES[:12]
    ]
    np.testing.assert_array_equal(np.concatenate([s[0] for s in singles]), w_all[:12])
    np.testing.assert_array_equal(np.concatenate([s[1] for s in singles]), q_all[:12])
    # asking for an earlier time again restarts rather than failing
    w_again, _ = propagator(TIMES[:5])
    np.testing.assert_array_equal(w_again, w_all[:5])


@pytest.mark.parametrize(
    'kwargs, message',
    [
        (
            {'angular_velocity': [0.0, float('nan'), 1.0]},
            r'^angular_velocity: every entry must be finite',
        ),
        ({'angular_velocity': [0.0, 1.0]}, r'^angular_velocity: expected 3 numbers'),
        ({'orientation': [0.0, 0.0, 0.0, 0.0]}, r'^orientation: the zero quaternion'),
        ({'orientation': [0.0, 0.0, 0.0, 2.0]}, r'^orientation: expected a unit quaternion'),
        ({'orientation': [0.0, 0.0, 1.0]}, r'^orientation: expected 4 numbers'),
        ({'inertia': [1.0, 2.0, 4.0]}, r'^inertia: .*triangle inequality'),
        ({'times': [0.0, 2.0, 1.0]}, r'^times: must be sorted'),
        ({'times': [-1.0, 2.0]}, r'^times: .*>= 0'),
        ({'times': [0.0, float('inf')]}, r'^times: every time must be finite'),
    ],
)
def test_bad_input_names_the_argument(propagator_name, kwargs, message):
    args = {
        'inertia': INERTIA,
        'angular_velocity': OMEGA,
        'orientation': Q0,
        'times': TIMES,
        **kwargs,
    }
    with pytest.raises(ValueError, match=message):
        propagate(
            args['inertia'],
            args['angular_velocity'],
            args['orientation'],
            args['times'],
            propagator=propagator_name,
        )


def test_unknown_propagator_and_option_are_refused():
    with pytest.raises(
        ValueError, match=r"^propagator: unknown propagator 'rk45' \(known: auto, analytic"
    ):
        propagate(INERTIA, OMEGA, Q0, TIMES, propagator='rk45')
    with pytest.raises(ValueError, match=r"^step: not an option of propagator 'analytic'"):
        propagate(INERTIA, OMEGA, Q0, TIMES, propagator='analytic', step=0.1)
    with pytest.raises(ValueError, match=r'^step: must be a positive finite number'):
        propagate(INERTIA, OMEGA, Q0, TIMES, propagator='rk4', step=-0.1)


def test_auto_is_the_analytic_propagator_for_a_torque_free_body():
    assert type(make_propagator(INERTIA, OMEGA, Q0)).name == 'analytic'


@pytest.mark.parametrize('name', ['rk4', 'lie_rk4'])
def test_fixed_step_methods_converge_at_fourth_order(name):
    w_exact, q_exact = run('analytic')
    errors = []
    for step in (0.04, 0.02, 0.01):
        w, q = propagate(INERTIA, OMEGA, Q0, TIMES, propagator=name, step=step)
        errors.append(max(np.abs(w - w_exact).max(), quaternion.angle_between(q, q_exact).max()))
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    # order 4: halving the step divides the error by 2^4 = 16 (asymptotically; 12..20 allowed)
    assert np.all((ratios > 12) & (ratios < 20)), ratios


@pytest.mark.parametrize('name', ['rk4', 'lie_rk4'])
def test_outputs_on_the_grid_take_no_partial_step(name, integrator_path):
    """
    Outputs on the step grid take no partial step.

    100 Hz outputs on a 1 ms grid: k * 0.01 differs from (10 k) * 0.001 by rounding, and must not
    cost a partial step. 1 s of outputs is exactly 1000 steps of 4 evaluations each (compiled: 1000
    whole grid steps, and no step outside them).
    """
    p = make_propagator(INERTIA, OMEGA, Q0, name, step=1e-3)
    calls = []
    if integrator_path == 'compiled':
        # the split and partial steps; whole grid steps run in the kernel
        advance = p._kernel._advance
        p._kernel._advance = lambda *args: calls.append(1) or advance(*args)
        omega, q = p(np.arange(101) * 0.01)
        assert calls == [] and p._grid_index == 1000
    else:
        derivative = p.dynamics.derivative
        p.dynamics.derivative = lambda *args: calls.append(1) or derivative(*args)
        omega, q = p(np.arange(101) * 0.01)
        assert len(calls) == 4 * 1000
    # the snapped samples are the grid states themselves
    grid = make_propagator(INERTIA, OMEGA, Q0, name, step=1e-3)(np.arange(0, 1001, 10) * 1e-3)
    np.testing.assert_array_equal(omega, grid[0])
    np.testing.assert_array_equal(q, grid[1])


def test_dop853_error_falls_with_the_tolerance():
    w_exact, q_exact = run('analytic')
    errors = []
    for rtol in (1e-6, 1e-9, 1e-12):
        w, q = propagate(
            INERTIA, OMEGA, Q0, TIMES, propagator='dop853', rtol=rtol, atol=rtol * 1e-2
        )
        errors.append(quaternion.angle_between(q, q_exact).max())
    assert errors[0] > 30 * errors[1] > 30 * 30 * errors[2], errors


def test_geometric_method_keeps_unit_quaternions_by_construction():
    times = np.linspace(0.0, 200.0, 11)  # 20 000 steps
    _, q = propagate(INERTIA, OMEGA, Q0, times, propagator='lie_rk4', step=0.01)
    assert np.abs(np.linalg.norm(q, axis=1) - 1.0).max() <= 1e-14


CORE = Path(__file__).resolve().parent.parent / 'torquefree_ros' / 'core'


def test_core_imports_no_ros_module():
    ros = (
        'rclpy',
        'rosidl',
        'geometry_msgs',
        'std_srvs',
        'sensor_msgs',
        'builtin_interfaces',
        'rosgraph_msgs',
    )
    for path in CORE.rglob('*.py'):
        for node in ast.walk(ast.parse(path.read_text())):
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else ([node.module or ''] if isinstance(node, ast.ImportFrom) else [])
            )
            for name in names:
                assert not name.startswith(ros), f'{path.name} imports {name}'
    code = (
        'import sys, torquefree_ros; '
        'torquefree_ros.propagate([1,2,3],[0,1,0],[0,0,0,1],[1.0]); '
        "print(sorted(m for m in sys.modules if m.startswith('rclpy')))"
    )
    out = subprocess.run(
        [sys.executable, '-c', code],
        capture_output=True,
        text=True,
        check=True,
        cwd=CORE.parent.parent,
    )
    assert out.stdout.strip().splitlines()[-1] == '[]'


@pytest.mark.parametrize(
    'duration, rate, count',
    [(2.3, 100.0, 231), (0.7, 10.0, 8), (1.0, 3.0, 4), (0.0, 50.0, 1), (0.99, 1.0, 1)],
)
def test_contract_sample_times_include_both_ends(duration, rate, count):
    from torquefree_ros.core.timing.grid import sample_times

    times = sample_times(duration, rate)
    assert times.size == count  # k = 0 ... floor(duration * rate)
    np.testing.assert_array_equal(times, np.arange(count) / rate)


@pytest.mark.parametrize(
    'duration, rate, message',
    [(-1.0, 10.0, '^duration: '), (1.0, 0.0, '^rate: '), (float('nan'), 1.0, '^duration: ')],
)
def test_contract_sample_times_refuse_bad_input(duration, rate, message):
    from torquefree_ros.core.timing.grid import sample_times

    with pytest.raises(ValueError, match=message):
        sample_times(duration, rate)


def test_a_state_that_overflows_float64_is_refused(propagator_name):
    with pytest.raises(ValueError, match=r'^angular_velocity: .*overflows float64'):
        make_propagator(INERTIA, [1e200, 1.0, 1.0], Q0, propagator_name)
