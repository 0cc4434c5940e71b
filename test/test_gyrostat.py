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
The exact free gyrostat (issue 43) against an independent reference and the conservation laws.

The reference is torquefree_ros/bench/gyrostat_cases.json, made by
tools/make_gyrostat_reference.py: mpmath Taylor-series integration of ``I w' + w x (I w + h) = 0``
and the quaternion kinematics at 40 digits, with each sample's float64 floor (the change of the
exact solution when an input moves by one rounding unit). Measured (both paths, every sample):
within 2e-14 of it everywhere (1.6e-14 at 1e-10 from a separatrix, whose floor is 1e-7 there), but
for the rates of the dominant rotor (1.2e-13, its floor 1.7e-13) and the 1e5 s case (1.8e-13 rate,
1.6e-13 rad; its floors 2.1e-13 and 1.9e-13): the rounding of ``t`` itself, which the tolerance
grants (:data:`TIME_ROUNDING_FACTOR`).
"""

import json
from pathlib import Path

from conftest import require_numba
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
import torquefree_ros.bench
from torquefree_ros.core.exact import gyrostat as exact
from torquefree_ros.core.frames import quaternion
from torquefree_ros.core.numerics import kernels as switch
from torquefree_ros.core.propagators import make_propagator
from torquefree_ros.core.propagators.gyrostat import GyrostatPropagator, ROTOR_AXIS_TOLERANCE
from torquefree_ros.core.run.accuracy import trajectory_errors
from torquefree_ros.core.scene.loader import load_scene, scene_from_mapping, SceneError

REFERENCE_FILE = Path(torquefree_ros.bench.__file__).with_name('gyrostat_cases.json')
REFERENCE = json.loads(REFERENCE_FILE.read_text())
CASES = {case['name']: case for case in REFERENCE['cases']}
EXACT_CASES = sorted(name for name in CASES if name != 'oblique_rotor')

#: the issue's target: 1e-13 of the reference (relative rate, attitude in rad) ...
TARGET = 1e-13
#: ... or this many times the rounding of the sample time itself where that is larger: ``t`` in
#: float64 moves the exact solution by ``|w'| t u`` (rate) and ``|w| t u`` (attitude),
#: ``u = 2^-53``, which no evaluation at ``t`` escapes (the 1e5 s case: ~1e-13; the dominant
#: rotor's fast rates: ~2e-13). The reference's floors also count the inputs' rounding, 1e-7 next
#: to the separatrix at 1e-10: the closed form takes the inputs as exact (its constants in 80
#: digits) and stays at 1e-14 there, so the inputs' part is not granted.
TIME_ROUNDING_FACTOR = 4.0
ROUNDING_UNIT = 2.0**-53


def scene(inertia, omega, effects, orientation=(0.0, 0.0, 0.0, 1.0)):
    return scene_from_mapping(
        {
            'body': {'inertia': list(inertia)},
            'initial': {'angular_velocity': list(omega), 'orientation': list(orientation)},
            'effects': effects,
        }
    )


def case_scene(case):
    return scene(
        case['inertia'],
        case['angular_velocity'],
        [{'rotor': case['rotor']}],
        case['orientation'],
    )


def tolerances(case):
    """Return each sample's rate and attitude tolerance: the target, or t's rounding (above)."""
    moments = np.asarray(case['inertia'])
    axis = np.asarray(case['rotor']['axis'], dtype=float)
    h = case['rotor']['momentum'] * axis / np.linalg.norm(axis)
    w, t = np.asarray(case['omega']), np.asarray(case['times'])
    acceleration = np.cross(moments * w + h, w) / moments  # I w' = (I w + h) x w
    speed = np.linalg.norm(w, axis=1)
    rate = np.linalg.norm(acceleration, axis=1) * t * ROUNDING_UNIT / speed
    attitude = speed * t * ROUNDING_UNIT
    return (
        np.maximum(TARGET, TIME_ROUNDING_FACTOR * rate),
        np.maximum(TARGET, TIME_ROUNDING_FACTOR * attitude),
    )


@pytest.fixture(params=['compiled', 'reference'])
def gyrostat_path(request, monkeypatch):
    """Run a test on both paths: numba's kernel (gyrostat_kernels) and the numpy reference."""
    if request.param == 'compiled' and not switch.AVAILABLE:
        require_numba()
    monkeypatch.setattr(switch, 'ENABLED', request.param == 'compiled')
    return request.param


# -- against the reference ------------------------------------------------------------------------
def test_the_reference_holds_every_case_the_issue_names():
    names = set(CASES)
    assert {'library_gyrostat', 'small_h_dual_spin', 'dominant_h', 'long_horizon_1e5'} <= names
    for saddle in ('pole_plus', 'pole_minus', 'off_pole'):
        for side in ('above', 'below'):
            for distance in ('1e-6', '1e-10'):
                case = CASES[f'separatrix_{saddle}_{side}_{distance}']
                # the rounded state is where it was asked to be, to its rounding
                assert case['separatrix_distance'] == pytest.approx(
                    (1 if side == 'above' else -1) * float(distance), rel=1e-5
                )
    assert CASES['long_horizon_1e5']['times'][-1] == 1e5
    # h dominant and small against the body's own momentum
    for name, low, high in (('dominant_h', 0.99, 1.0), ('small_h_dual_spin', 0.0, 0.02)):
        case = CASES[name]
        body = np.array(case['inertia']) * np.array(case['angular_velocity'])
        h = abs(case['rotor']['momentum'])
        assert low <= h / (h + np.linalg.norm(body)) <= high


@pytest.mark.parametrize('name', EXACT_CASES)
def test_the_exact_gyrostat_meets_the_reference(name, gyrostat_path):
    case = CASES[name]
    propagator = case_scene(case).propagator()
    assert propagator.name == 'gyrostat'
    omega, q = propagator(np.array(case['times']))
    rate_error, attitude_error = trajectory_errors(omega, q, case['omega'], case['q'])
    rate_tolerance, attitude_tolerance = tolerances(case)
    worst = int(np.argmax(rate_error / rate_tolerance))
    assert rate_error[worst] <= rate_tolerance[worst], (
        f'rate {rate_error[worst]:.2e} at t = {case["times"][worst]}'
    )
    worst = int(np.argmax(attitude_error / attitude_tolerance))
    assert attitude_error[worst] <= attitude_tolerance[worst], (
        f'attitude {attitude_error[worst]:.2e} at t = {case["times"][worst]}'
    )
    # the same quaternion, not only the same rotation: continuous from q0 as the ODE's
    assert np.all(np.sum(q * np.array(case['q']), axis=1) > 0.0)


def test_an_oblique_rotor_stays_on_the_numerical_path_at_its_tolerance():
    """
    The oblique gyrostat has no closed form here: auto takes DOP853 at the scene's accuracy.

    Its error against the reference is the integrator's (rtol 1e-10 over 20 s of ~1 rad/s: a few
    1e-10), far above the closed form's: the numerical path is kept as the reference it was.
    """
    case = CASES['oblique_rotor']
    propagator = case_scene(case).propagator()
    assert propagator.name == 'dop853'
    omega, q = propagator(np.array(case['times']))
    rate_error, attitude_error = trajectory_errors(omega, q, case['omega'], case['q'])
    assert rate_error.max() < 1e-8 and attitude_error.max() < 1e-8


# -- conservation ---------------------------------------------------------------------------------
@pytest.mark.parametrize('name', EXACT_CASES)
def test_invariants_hold_to_the_float64_floor(name, gyrostat_path):
    """
    ``|I w + h|``, ``w . I w`` and the inertial ``R(q)(I w + h)`` hold to rounding at any time.

    The closed form gives each sample anew (nothing accumulates): at 5e5 random times up to
    1e6 s, the invariants stay within 64 rounding units of their initial values (the sums of three
    rounded products of rounded functions; the inertial momentum also carries the quaternion's
    rounding).
    """
    case = CASES[name]
    propagator = case_scene(case).propagator()
    times = np.sort(np.random.default_rng(5).uniform(0.0, 1e6, 50_000))
    omega, q, x = propagator.states(np.concatenate([[0.0], times]))
    with np.errstate(under='ignore'):  # (the transverse rates at the exact separatrix's saddle)
        m_B = propagator.momentum_B(omega, x)
        H = np.linalg.norm(m_B, axis=1)
        T = propagator.energy(omega, x)
        H_N = quaternion.rotate(q, m_B)
    bound = 64 * np.finfo(float).eps
    assert np.abs(H / H[0] - 1.0).max() <= bound
    assert np.abs(T / T[0] - 1.0).max() <= bound
    assert np.abs(H_N - H_N[0]).max() <= bound * H[0]


# -- continuity with the free body ----------------------------------------------------------------
INERTIA, OMEGA = [1.0, 2.0, 3.0], [0.4, -0.3, 0.9]
Q0 = Rotation.from_rotvec([0.2, -0.5, 0.9]).as_quat()


@pytest.mark.parametrize('axis', [[1, 0, 0], [0, 1, 0], [0, 0, -1]])
def test_h_to_zero_is_the_free_body(axis, gyrostat_path):
    """
    As ``h -> 0`` the gyrostat tends to the free body, continuously; at ``h = 0`` it is it.

    The motions differ at first order in ``h``: the rates by about ``|h| t / I`` and the
    attitude by the angle that makes over ``t`` (here within ``|h| t^2`` and ``|h| t``), down to
    the floor: continuity without a jump at ``h = 0`` or at the regimes' borders, each small ``h``
    taking the closed form of its own regime (the poles' regime and the transverse ones).
    """
    times = np.linspace(0.0, 10.0, 41)
    free = make_propagator(INERTIA, OMEGA, Q0, 'analytic')
    w_free, q_free = free(times)
    for h in (1e-4, 1e-7, 1e-10, 1e-13):
        p = scene(INERTIA, OMEGA, [{'rotor': {'momentum': h, 'axis': axis}}], Q0).propagator()
        assert p.name == 'gyrostat' and p.motion is not None
        w, q = p(times)
        rate_error, attitude_error = trajectory_errors(w, q, w_free, q_free)
        assert np.all(rate_error <= 10.0 * h * times + 1e-14), h
        assert np.all(attitude_error <= 10.0 * h * times**2 + 1e-13), h
    zero = scene(INERTIA, OMEGA, [{'rotor': {'momentum': 0.0, 'axis': axis}}], Q0).propagator()
    w, q = zero(times)
    np.testing.assert_array_equal(w, w_free)
    np.testing.assert_array_equal(q, q_free)


# -- the regimes ----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    'name, regime, form, circled',
    [
        ('library_gyrostat', 'rotor_axis_polhode', 'sn2', 2),
        ('complex_roots_transverse', 'transverse_axis_polhode', 'cn', 0),
        ('real_roots_transverse', 'transverse_axis_polhode', 'sn2', 1),
        ('root_at_infinity', 'rotor_axis_polhode', 'sn2', 2),
        ('separatrix_pole_plus_below_1e-10', 'transverse_axis_polhode', 'sn2', 1),
        ('separatrix_off_pole_above_1e-10', 'transverse_axis_polhode', 'cn', 0),
        ('separatrix_exact', 'separatrix', 'sn2', 1),
    ],
)
def test_each_regime_takes_its_closed_form(name, regime, form, circled):
    motion = case_scene(CASES[name]).propagator().motion
    assert (motion.regime, motion.form, motion.reference) == (regime, form, circled)


def test_the_separatrix_distance_sets_the_complementary_parameter():
    """``mc`` falls with the distance to the separatrix (linearly at the poles' saddles)."""
    for saddle in ('pole_plus', 'pole_minus'):
        for side in ('above', 'below'):
            near, nearer = (
                case_scene(CASES[f'separatrix_{saddle}_{side}_{d}']).propagator().motion.mc
                for d in ('1e-6', '1e-10')
            )
            assert nearer == pytest.approx(1e-4 * near, rel=1e-3)


def test_a_rotor_on_the_symmetry_axis_precesses_uniformly(gyrostat_path):
    """``J1 = J2``: ``m3`` constant, ``w`` turns about the axis at ``-κ``, exactly."""
    p = scene([2.0, 2.0, 1.0], [0.5, 0.6, -0.3], [{'rotor': {'momentum': 0.3, 'axis': [0, 0, 1]}}])
    propagator = p.propagator()
    assert propagator.motion is None and propagator._attitude is not None
    times = np.linspace(0.0, 20.0, 21)
    omega, _ = propagator(times)
    kappa = -0.3 - (1.0 * -0.3 + 0.3) / 2.0
    turn = -kappa * times
    expected = np.column_stack(
        [
            0.5 * np.cos(turn) - 0.6 * np.sin(turn),
            0.5 * np.sin(turn) + 0.6 * np.cos(turn),
            np.full_like(times, -0.3),
        ]
    )
    np.testing.assert_allclose(omega, expected, rtol=0, atol=1e-15)


def test_a_relative_equilibrium_spins_at_a_constant_rate():
    """``m x w = 0``: on the rotor axis, and off it where ``m3 = h J1 / (J1 - J3)``."""
    rotor = [{'rotor': {'momentum': 0.3, 'axis': [0, 0, 1]}}]
    on_axis = scene([1.0, 2.0, 3.0], [0.0, 0.0, 0.7], rotor)
    # m3 = 0.3 * 1 / (1 - 3) = -0.15 = 3 w3 + 0.3: (J3 - J1) w3 + h = 0 exactly in binary
    off_axis = scene([1.0, 2.0, 3.0], [0.5, 0.0, -0.15], rotor)
    for s in (on_axis, off_axis):
        p = s.propagator()
        assert p.name == 'gyrostat' and p.motion is None
        omega, _ = p(np.linspace(0.0, 5.0, 6))
        np.testing.assert_array_equal(omega, np.broadcast_to(s.angular_velocity, omega.shape))


# -- the numpy reference path and the kernel ------------------------------------------------------
@pytest.mark.parametrize(
    'name',
    ['library_gyrostat', 'complex_roots_transverse', 'separatrix_pole_plus_above_1e-10',
     'separatrix_exact', 'long_horizon_1e5'],
)
def test_the_kernel_repeats_the_numpy_path(name, monkeypatch):
    """The same operations in the same order: equal but for libm's last bits (sin, cos, tanh)."""
    if not switch.AVAILABLE:
        require_numba()
    case = CASES[name]
    times = np.linspace(0.0, case['times'][-1], 2001)
    runs = {}
    for enabled in (True, False):
        monkeypatch.setattr(switch, 'ENABLED', enabled)
        propagator = case_scene(case).propagator()
        assert propagator._attitude.compiled is enabled
        runs[enabled] = propagator(times)
    rate_error, attitude_error = trajectory_errors(*runs[True], *runs[False])
    # a few ulps of the functions and of psi (up to ~1e3 rad at the long horizon's end)
    assert rate_error.max() <= 1e-14
    assert attitude_error.max() <= 1e-15 * (1.0 + np.abs(runs[False][0]).max() * times[-1])


def test_samples_do_not_depend_on_how_they_are_requested(gyrostat_path):
    """The node asks in blocks, offline tools all at once: the samples are identical."""
    s = load_scene('gyrostat')
    times = np.linspace(0.0, 30.0, 301)
    w_all, q_all = s.propagator()(times)
    propagator = s.propagator()
    blocks = [propagator(chunk) for chunk in np.array_split(times, 7)]
    np.testing.assert_array_equal(np.concatenate([b[0] for b in blocks]), w_all)
    np.testing.assert_array_equal(np.concatenate([b[1] for b in blocks]), q_all)
    single = [s.propagator()([t]) for t in times[:9]]
    np.testing.assert_array_equal(np.concatenate([b[0] for b in single]), w_all[:9])
    np.testing.assert_array_equal(np.concatenate([b[1] for b in single]), q_all[:9])


# -- auto's choice and bad input ------------------------------------------------------------------
def test_auto_chooses_the_exact_gyrostat_for_rotors_along_a_principal_axis():
    rotor = {'rotor': {'momentum': 1.0, 'axis': [0.0, 0.0, 2.0]}}
    assert load_scene('gyrostat').propagator().name == 'gyrostat'
    assert scene(INERTIA, OMEGA, [rotor]).propagator().name == 'gyrostat'
    # two wheels whose momenta add along a principal axis: one gyrostat
    wheels = [rotor, {'rotor': {'momentum': -0.5, 'axis': [0.0, 0.0, 1.0]}}]
    assert scene(INERTIA, OMEGA, wheels).propagator().name == 'gyrostat'
    # off a principal axis by more than rounding, or beside another effect: DOP853
    tilted = {'rotor': {'momentum': 1.0, 'axis': [0.0, 1e-12, 1.0]}}
    assert scene(INERTIA, OMEGA, [tilted]).propagator().name == 'dop853'
    damper = {'damper': {'inertia': 0.1, 'damping': 0.1}}
    assert scene(INERTIA, OMEGA, [rotor, damper]).propagator().name == 'dop853'
    # within rounding of the axis
    nearly = {'rotor': {'momentum': 1.0, 'axis': [0.0, 0.5 * ROTOR_AXIS_TOLERANCE, 1.0]}}
    assert scene(INERTIA, OMEGA, [nearly]).propagator().name == 'gyrostat'


def test_a_full_tensor_whose_principal_axis_carries_the_rotor():
    """The body frame need not be principal: the rotor along a principal axis of the tensor."""
    rotation = Rotation.from_euler('z', 90, degrees=True).as_matrix()  # exact: a permutation
    tensor = rotation @ np.diag(INERTIA) @ rotation.T
    elements = [tensor[0, 0], tensor[1, 1], tensor[2, 2], tensor[0, 1], tensor[0, 2], tensor[1, 2]]
    axis = (rotation @ [1.0, 0.0, 0.0]).tolist()
    q_R = quaternion.from_matrix(rotation.T)  # maps new-body coordinates to principal ones
    turned = scene(elements, rotation @ OMEGA, [{'rotor': {'momentum': 0.7, 'axis': axis}}], q_R)
    plain = scene(INERTIA, OMEGA, [{'rotor': {'momentum': 0.7, 'axis': [1, 0, 0]}}])
    times = np.linspace(0.0, 10.0, 11)
    w_turned, q_turned = turned.propagator()(times)
    w, q = plain.propagator()(times)
    assert turned.propagator().name == 'gyrostat'
    # the same motion, written in the other frame (to rounding: the frame change is exact)
    np.testing.assert_allclose(w_turned, w @ rotation.T, rtol=0, atol=1e-15)
    assert quaternion.angle_between(q_turned, quaternion.multiply(q, q_R)).max() < 1e-14


def test_a_zero_rotor_axis_is_refused_with_its_field_path():
    with pytest.raises(
        SceneError, match=r'effects\[0\]\.rotor\.axis: must not be the zero vector'
    ):
        scene(INERTIA, OMEGA, [{'rotor': {'momentum': 1.0, 'axis': [0.0, 0.0, 0.0]}}])


@pytest.mark.parametrize(
    'effects, words',
    [
        ([{'rotor': {'momentum': 1.0, 'axis': [0.0, 0.6, 0.8]}}], 'off every principal axis'),
        (
            [
                {'rotor': {'momentum': 1.0, 'axis': [0.0, 0.0, 1.0]}},
                {'external_torque': {'torque': [0.0, 0.0, 0.1]}},
            ],
            "effects other than 'rotor' (external_torque)",
        ),
    ],
)
def test_naming_the_gyrostat_where_it_does_not_apply_is_refused(effects, words):
    refusal = r"^propagator: 'gyrostat' is the exact gyrostat"
    with pytest.raises(ValueError, match=refusal) as raised:
        scene(INERTIA, OMEGA, effects).propagator('gyrostat')
    assert words in str(raised.value)


def test_the_gyrostat_propagator_refuses_what_every_propagator_refuses():
    rotor = [{'rotor': {'momentum': 1.0, 'axis': [0.0, 0.0, 1.0]}}]
    with pytest.raises(ValueError, match=r'^angular_velocity: .*overflows float64'):
        scene(INERTIA, OMEGA, rotor).propagator(angular_velocity=[1e200, 1.0, 1.0])
    with pytest.raises(ValueError, match=r"^step: not an option of propagator 'gyrostat'"):
        scene(INERTIA, OMEGA, rotor).propagator('gyrostat', step=0.1)
    with pytest.raises(ValueError, match=r'^times: must be sorted'):
        scene(INERTIA, OMEGA, rotor).propagator()([0.0, 2.0, 1.0])


def test_the_propagator_reports_exact_accuracy_and_its_invariants():
    from torquefree_ros.core.run.accuracy import estimate_accuracy

    propagator = load_scene('gyrostat').propagator()
    assert isinstance(propagator, GyrostatPropagator) and propagator.exact
    assert estimate_accuracy(propagator).reference == 'the closed form'
    assert propagator.conserved == frozenset({'energy', 'momentum'})


def test_constants_come_from_exact_decimal_arithmetic():
    """The decimal context is wide enough for products of three float64 inputs to be exact."""
    assert exact.DIGITS >= 48
