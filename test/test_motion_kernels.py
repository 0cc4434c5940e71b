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
The compiled equations of motion and integrators (core/integrators).

Held to the reference path (Dynamics.derivative in Python, scipy's DOP853, numpy's RK4 stages) and
to closed forms. The effects' physics is checked against independent references in test_effects.py,
on both paths.
"""

import math

from conftest import require_numba
from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.special import ellipj, ellipk
from torquefree_ros import load_scene
from torquefree_ros.core.body.rigid_body import RigidBody
from torquefree_ros.core.compiled import drivers, motion_kernels
from torquefree_ros.core.effects import EFFECTS, MotionEffect, parse_effect
from torquefree_ros.core.environment.place import Place
from torquefree_ros.core.numerics import kernels as switch
from torquefree_ros.core.propagators import (
    ATOL_PER_RTOL,
    DEFAULT_ACCURACY as ACCURACY,
    StepBudgetExceeded,
)
from torquefree_ros.core.propagators.dynamics import Dynamics
from torquefree_ros.core.scene.loader import scene_from_mapping

if not switch.AVAILABLE:
    require_numba()

EPS = np.finfo(float).eps
#: one configuration of every motion effect, with a parameter of each kind it has
EFFECT_ENTRIES = {
    'external_torque (body)': {'external_torque': {'torque': [1e-3, -2e-3, 3e-3]}},
    'external_torque (inertial)': {
        'external_torque': {'torque': [0.02, -0.01, 0.03], 'frame': 'inertial'}
    },
    'external_torque (schedule)': {
        'external_torque': {
            'schedule': [
                {'start': 0.5, 'torque': [0.0, 0.1, 0.0]},
                {'start': 1.5, 'torque': [0.2, 0.0, -0.1]},
            ],
            'frame': 'inertial',
        }
    },
    'gravity_gradient': {'gravity_gradient': {'mean_motion': 0.3, 'argument_of_latitude': 0.4}},
    # on ORBIT (ON_ORBIT): the position and the fields held per environment window
    'gravity_gradient (orbit)': {'gravity_gradient': {}},
    'residual_dipole (igrf)': {'residual_dipole': {'dipole': [0.3, -0.1, 0.2]}},
    'residual_dipole (dipole)': {
        'residual_dipole': {'dipole': [-0.2, 0.5, 0.1], 'field': 'dipole'}
    },
    'damper': {'damper': {'inertia': 0.1, 'damping': 0.05, 'initial_rate': [0.1, 0.2, 0.3]}},
    'rotor': {'rotor': {'momentum': 1.5, 'axis': [0.3, -1.0, 0.2]}},
    'torque_command': {'torque_command': {'frame': 'inertial'}},
    # four rods, one saturated by the command _dynamics gives: the applied dipole in its slot
    'magnetorquers': {
        'magnetorquers': {
            'rods': [
                {'axis': [1.0, 0.0, 0.0], 'max_dipole': 0.2},
                {'axis': [0.0, 1.0, 0.0], 'max_dipole': 0.2},
                {'axis': [0.0, 0.0, 1.0], 'max_dipole': 0.2},
                {'axis': [1.0, 1.0, 1.0], 'max_dipole': 0.001},
            ],
            'field': 'dipole',
        }
    },
    # random states put the wheel in its speed limit's band, past it and in the Coulomb band
    'reaction_wheels': {
        'reaction_wheels': {
            'wheels': [
                {
                    'axis': [0.3, -1.0, 0.2],
                    'spin_inertia': 0.05,
                    'max_torque': 0.1,
                    'max_speed': 30.0,
                    'speed_band': 5.0,
                    'viscous': 1e-3,
                    'coulomb': 2e-3,
                    'coulomb_band': 0.5,
                    'stribeck': {'static': 3e-3, 'speed': 2.0},
                    'speed': 12.0,
                }
            ],
            'schedule': [{'start': 0.5, 'torque': [0.05]}, {'start': 1.5, 'torque': [-0.2]}],
        }
    },
}


#: the scene orbit of the entries in ON_ORBIT: eccentric, inclined, J2 drifting
ORBIT = {
    'epoch': '2026-03-20T12:00:00Z',
    'semi_major_axis': 6878137.0,
    'eccentricity': 0.02,
    'inclination': 1.7,
    'raan': 0.3,
    'argument_of_perigee': 1.1,
    'mean_anomaly': 0.4,
    'j2': True,
}
ON_ORBIT = {
    'gravity_gradient (orbit)',
    'residual_dipole (igrf)',
    'residual_dipole (dipole)',
    'magnetorquers',
}
PLACE = Place.from_mapping(ORBIT)


def _dynamics(labels, inertia=(4.0, 3.0, 2.0, 0.1, -0.2, 0.05)):
    body = RigidBody.from_inertia(list(inertia))
    effects = [
        parse_effect(EFFECT_ENTRIES[label], f'effects[{i}]')
        .placed(PLACE if label in ON_ORBIT else None, f'effects[{i}]')
        .bound(body.tensor)
        for i, label in enumerate(labels)
    ]
    for effect in effects:
        if getattr(effect, 'hold', None) is not None:
            # a command in force from the start, so the torque is not zero
            effect.hold.receive(0, [0.01, -0.02, 0.005], frame_id='')
    return Dynamics(body, effects)


def test_every_motion_effect_has_a_compiled_form():
    """
    Every motion effect has a compiled form.

    A kernel code the kernels read, with as many parameters as its section reads, or a held torque.
    """
    motion = [cls for cls in EFFECTS.values() if issubclass(cls, MotionEffect)]
    assert {cls.name for cls in motion} == {next(iter(e)) for e in EFFECT_ENTRIES.values()}
    for label in EFFECT_ENTRIES:
        (effect,) = _dynamics([label]).effects
        if effect.kernel_code is None:
            torque, inertial = effect.held_torque(0.0)
            assert np.shape(torque) == (3,) and isinstance(inertial, bool), label
        else:
            assert (
                len(effect.kernel_parameters())
                == motion_kernels.PARAMETER_COUNTS[effect.kernel_code]
            ), label


def _random_states(rng, count, state_size):
    omega = rng.normal(size=(count, 3)) * 10.0 ** rng.uniform(-3, 1, size=(count, 1))
    q = Rotation.random(count, random_state=rng).as_quat()
    x = rng.normal(size=(count, state_size))
    return np.hstack([omega, q, x])


@pytest.mark.parametrize('label', [*EFFECT_ENTRIES, 'all at once'])
def test_the_compiled_right_hand_side_equals_the_python_one_on_random_states(label):
    """
    The compiled right-hand side equals the Python one on random states, to rounding.

    Same formulas, other order of a few sums: within 16 eps of the largest term, per component.
    """
    labels = list(EFFECT_ENTRIES) if label == 'all at once' else [label]
    dynamics = _dynamics(labels)
    rng = np.random.default_rng(sum(map(ord, label)))
    states = _random_states(rng, 200, dynamics.state_size)
    # across the schedule's switches; on the orbit, across environment windows too
    times = rng.uniform(0.0, 300.0 if label in ON_ORBIT else 3.0, size=200)
    expected = np.array([dynamics.derivative(t, y, t) for t, y in zip(times, states)])
    got = drivers.derivatives(dynamics, times, states)
    # the terms' size: |I| |w|^2 and every torque (|I^-1| ~ 1 here), the quaternion rate |w|
    size = 10.0 * (
        1.0
        + np.abs(states[:, :3]).max(axis=1, keepdims=True) ** 2
        + np.abs(states).max(axis=1, keepdims=True)
    )
    assert np.all(np.abs(got - expected) <= 16 * EPS * size), np.abs(got - expected).max()


@settings(max_examples=60, deadline=None)
@given(
    moments=st.tuples(*[st.floats(0.1, 100.0)] * 3),
    rate=st.floats(1e-3, 20.0),
    n=st.floats(1e-4, 2.0),
    J=st.floats(1e-3, 1.0),
    c=st.floats(1e-3, 1.0),
    h=st.floats(-10.0, 10.0).filter(lambda v: v == 0.0 or abs(v) > 1e-6),
    seed=st.integers(0, 2**32 - 1),
)
def test_the_compiled_right_hand_side_holds_for_any_body_and_parameters(
    moments, rate, n, J, c, h, seed
):
    """Hypothesis over bodies (any three moments and a tilt of the axes) and effect parameters."""
    a, b, cc = sorted(moments)
    if a + b < cc:  # not a rigid body
        moments = (a, b, a + b)
    rng = np.random.default_rng(seed)
    axes = Rotation.random(random_state=rng).as_matrix()
    tensor = axes @ np.diag(moments) @ axes.T
    tensor = 0.5 * (tensor + tensor.T)
    body = RigidBody.from_inertia(tensor.tolist())
    entries = [
        {'gravity_gradient': {'mean_motion': n}},
        {'damper': {'inertia': J, 'damping': c}},
        {'rotor': {'momentum': h, 'axis': rng.normal(size=3).tolist()}},
    ]
    effects = [parse_effect(e, f'effects[{i}]').bound(body.tensor) for i, e in enumerate(entries)]
    dynamics = Dynamics(body, effects)
    states = _random_states(rng, 8, dynamics.state_size)
    states[:, :3] *= rate / np.linalg.norm(states[:, :3], axis=1, keepdims=True)
    times = rng.uniform(0.0, 100.0, size=8)
    expected = np.array([dynamics.derivative(t, y, t) for t, y in zip(times, states)])
    got = drivers.derivatives(dynamics, times, states)
    # terms up to |I| |w|^2 (+ 3 n^2 |I|, c |nu - w|, |h| |w|), divided by the smallest moment
    scale = max(moments) * (rate**2 + 3 * n * n + 1.0) + c * (rate + 10.0) + abs(h) * rate + 10.0
    size = scale / min(moments) + c / J * (rate + 10.0) + rate * 10.0
    assert np.all(np.abs(got - expected) <= 64 * EPS * size)


def test_the_stage_sums_leave_out_only_the_tableau_s_zeros():
    """
    The compiled stage sums leave out only the coefficients that are zero in scipy's tableau.

    Each stage's sum is unrolled in the order of j: on random stages the sums equal the whole sum
    in that order bit for bit.
    """
    motion_kernels.compile_kernels()
    rng = np.random.default_rng(27)
    n = 10
    K = rng.normal(size=(motion_kernels.STAGES_EXTENDED, n)) * 10.0 ** rng.uniform(
        -3, 3, size=(1, n)
    )
    y, h = rng.normal(size=n), 0.37
    work = np.zeros((3, n))
    for s in [
        *range(1, motion_kernels.STAGES),
        *range(motion_kernels.STAGES + 1, motion_kernels.STAGES_EXTENDED),
    ]:
        stage_state = (
            motion_kernels._stage_state
            if s < motion_kernels.STAGES
            else motion_kernels._extra_stage_state
        )
        stage_state(K, drivers._A, s, y, h, work)
        expected = np.empty(n)
        for i in range(n):
            total = 0.0
            for j in range(s):
                total += K[j, i] * drivers._A[s, j]
            expected[i] = y[i] + total * h
        np.testing.assert_array_equal(work[motion_kernels.STAGE], expected, err_msg=f'stage {s}')


def test_the_kernels_are_compiled_without_numba_s_runtime():
    """
    The kernels are compiled without numba's runtime: no kernel allocates.

    With numba's runtime, each array handed to an inlined helper or sliced was an atomic increment
    and decrement, two calls that spill the registers: 2.5 times the time of a step.
    """
    motion_kernels.compile_kernels()
    kernels = [
        name for name, value in vars(motion_kernels).items() if hasattr(value, 'targetoptions')
    ]
    assert {'_rhs', 'derivative', 'dop853_outputs', 'dop853_outputs_batch', 'fixed_step'} <= set(
        kernels
    )
    for name in kernels:
        assert getattr(motion_kernels, name).targetoptions.get('_nrt') is False, name


SCENES_WITH_EFFECTS = ['explorer1', 'gyrostat', 'gravity_gradient']


@pytest.mark.parametrize('name', SCENES_WITH_EFFECTS)
def test_compiled_dop853_follows_scipy_dop853_at_the_same_tolerances(name, monkeypatch):
    """
    The compiled DOP853 follows scipy's DOP853 at the same tolerances.

    Both paths at the scene's accuracy take the same steps (but for rounding in a few sums), so
    their errors against a tight reference agree to 1 % and they differ by far less than either's
    error: rtol and atol mean what they mean in scipy.
    """
    scene = load_scene(name)
    duration = {'explorer1': 200.0, 'gyrostat': 60.0, 'gravity_gradient': 3000.0}[name]
    times = np.linspace(0.0, duration, 401)
    runs = {}
    for path, enabled in (('compiled', True), ('reference', False)):
        monkeypatch.setattr(switch, 'ENABLED', enabled)
        # auto's DOP853 at the scene's accuracy (the library gyrostat's rotor lies along a
        # principal axis: auto takes the exact gyrostat for it)
        accuracy = ACCURACY if scene.accuracy is None else scene.accuracy
        propagator = scene.propagator('dop853', rtol=accuracy, atol=accuracy * ATOL_PER_RTOL)
        assert propagator.compiled is enabled
        runs[path] = propagator.states(times)
    monkeypatch.setattr(switch, 'ENABLED', True)
    tight = scene.propagator('dop853', rtol=1e-13, atol=1e-15).states(times)
    floor = 1e-13 * (1.0 + np.abs(tight[0]).max() * duration)  # the tight run's own error
    for part in (0, 1):  # rates, attitude
        errors = {path: np.abs(run[part] - tight[part]).max() for path, run in runs.items()}
        assert (
            abs(errors['compiled'] - errors['reference']) <= 0.01 * errors['reference'] + floor
        ), errors
        assert (
            np.abs(runs['compiled'][part] - runs['reference'][part]).max()
            <= 0.01 * errors['reference'] + floor
        )


#: effects whose commands come through a Simulation's hold (test_torque_command.py and
#: test_magnetorquers.py run them on both paths)
COMMANDED = {'torque_command', 'magnetorquers'}


@pytest.mark.parametrize('method', ['rk4', 'lie_rk4'])
@pytest.mark.parametrize('label', [label for label in EFFECT_ENTRIES if label not in COMMANDED])
def test_compiled_fixed_step_methods_repeat_the_reference_steps(method, label, monkeypatch):
    """The same stages in the same order: equal to rounding after 300 steps with breakpoints."""
    entry = EFFECT_ENTRIES[label]
    s = scene_from_mapping(
        {
            'body': {'inertia': [4.0, 3.0, 2.0, 0.1, -0.2, 0.05]},
            'initial': {
                'angular_velocity': [0.3, -0.7, 1.1],
                'orientation': Rotation.from_rotvec([0.3, 0.2, -0.1]).as_quat().tolist(),
            },
            'effects': [entry],
            **({'orbit': ORBIT} if label in ON_ORBIT else {}),
        }
    )
    times = np.linspace(0.0, 3.0, 31) + 0.0037  # off the grid: partial steps too
    step = 0.01
    if label in ON_ORBIT:  # across two environment windows (a breakpoint at 60 s), 300 steps
        times, step = times * 20.0 + 1.0, 0.2
    results = []
    for enabled in (True, False):
        monkeypatch.setattr(switch, 'ENABLED', enabled)
        results.append(s.propagator(method, step=step).states(times))
    for got, expected in zip(results[0], results[1]):
        np.testing.assert_allclose(
            got, expected, rtol=0, atol=1e-13 * (1 + np.abs(expected).max(initial=0.0))
        )


@pytest.mark.parametrize('method', ['dop853', 'rk4', 'lie_rk4'])
def test_samples_do_not_depend_on_how_the_times_are_asked(method):
    """
    Samples do not depend on how the times are asked for.

    All at once, in blocks, one by one, or going back (a restart): the same samples bit for bit.
    """
    s = load_scene('explorer1')
    options = {'step': 0.01} if method != 'dop853' else {}
    times = np.linspace(0.0, 20.0, 201)
    whole = s.propagator(method, **options).states(times)
    p = s.propagator(method, **options)
    assert p.compiled
    blocks = [p.states(times[i: i + 17]) for i in range(0, times.size, 17)]
    for got, expected in zip(blocks and [np.concatenate(parts) for parts in zip(*blocks)], whole):
        np.testing.assert_array_equal(got, expected)
    again = p.states(times[50:60])  # before the last step: from the start again
    for got, expected in zip(again, whole):
        np.testing.assert_array_equal(got, expected[50:60])


def test_a_sphere_under_a_constant_body_torque_spins_up_in_closed_form():
    """About a principal axis: w(t) = w0 + tau t / I, the angle w0 t + tau t^2 / (2 I)."""
    I, w0, tau = 2.5, 0.4, 0.03
    s = scene_from_mapping(
        {
            'body': {'inertia': [I, I, I]},
            'initial': {'angular_velocity': [0.0, 0.0, w0]},
            'effects': [{'external_torque': {'torque': [0.0, 0.0, tau]}}],
            'accuracy': 1e-12,
        }
    )
    p = s.propagator()
    assert p.compiled
    times = np.linspace(0.0, 50.0, 101)
    omega, q = p(times)
    np.testing.assert_allclose(omega[:, 2], w0 + tau * times / I, rtol=0, atol=1e-12)
    angle = w0 * times + tau * times**2 / (2 * I)
    expected = np.column_stack([np.zeros((times.size, 2)), np.sin(angle / 2), np.cos(angle / 2)])
    # the angle reaches ~45 rad; rtol 1e-12 per step over ~1000 steps
    np.testing.assert_allclose(q, expected, rtol=0, atol=1e-9)


def test_gravity_gradient_pitch_follows_the_pendulum_in_closed_form():
    """
    A gravity-gradient pitch motion follows the pendulum's closed form.

    A planar pitch motion: the angle a between body x and the local vertical obeys
    C a'' = -3 n^2 (B - A) sin a cos a, a pendulum in 2a: sin a = sin a0 sn(K - w t | sin^2 a0),
    w = n sqrt(3 (B - A) / C), at finite amplitude (not the small-angle frequency).
    """
    n, (A, B, C) = 0.05, (1.0, 3.0, 3.5)
    a0 = 0.6
    # orbit in the x-y plane; the body turned by -a0 about z, spinning with the orbit (a' = 0)
    s = scene_from_mapping(
        {
            'body': {'inertia': [A, B, C]},
            'initial': {
                'angular_velocity': [0.0, 0.0, n],
                'orientation': [0.0, 0.0, math.sin(-a0 / 2), math.cos(-a0 / 2)],
            },
            'effects': [{'gravity_gradient': {'mean_motion': n}}],
            'accuracy': 1e-12,
        }
    )
    p = s.propagator()
    assert p.compiled
    times = np.linspace(0.0, 600.0, 601)
    _, q = p(times)
    phi = 2 * np.arctan2(q[:, 2], q[:, 3])
    a = np.angle(np.exp(1j * (n * times - phi)))
    w = n * math.sqrt(3 * (B - A) / C)
    m = math.sin(a0) ** 2
    sn, _, _, _ = ellipj(ellipk(m) - w * times, m)
    expected = np.arcsin(math.sin(a0) * sn)
    # ~6 libration periods at rtol 1e-12: 1e-8 rad
    np.testing.assert_allclose(a, expected, rtol=0, atol=1e-8)
    assert np.abs(q[:, :2]).max() < 1e-12  # the motion stays planar


def test_the_step_budget_and_stiffness_are_refused_as_on_the_reference_path(monkeypatch):
    s = load_scene('explorer1')
    messages = []
    for enabled in (True, False):
        monkeypatch.setattr(switch, 'ENABLED', enabled)
        p = s.propagator()
        p.max_steps_per_sample = 3
        with pytest.raises(StepBudgetExceeded) as error:
            p(np.array([0.0, 100.0]))
        messages.append(str(error.value).split('(the step')[0])
    assert messages[0] == messages[1]
    stiff = scene_from_mapping(
        {
            'body': {'inertia': [1.0, 10.0, 10.5]},
            'initial': {'angular_velocity': [2.0, 0.05, 0.0]},
            'effects': [{'damper': {'inertia': 0.1, 'damping': 1e9}}],
        }
    )
    for enabled in (True, False):
        monkeypatch.setattr(switch, 'ENABLED', enabled)
        # numpy's default error handling (scipy's steps overflow on the way, as they would for a
        # user)
        with (
            np.errstate(all='ignore'),
            pytest.raises(RuntimeError, match='too stiff for an explicit integrator'),
        ):
            stiff.propagator()(np.array([0.0, 10.0]))
