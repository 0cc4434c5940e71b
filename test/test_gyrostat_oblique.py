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
The free gyrostat with an oblique ``h`` in closed form (issue 43), as a module.

The reference is test/data/gyrostat_oblique_cases.json, made by
``tools/make_gyrostat_reference.py --oblique``: mpmath Taylor-series integration of
``I w' + w x (I w + h) = 0`` and ``q' = q ⊗ (w, 0) / 2`` at 40 digits, sharing nothing with the
closed form but the equations of motion; its states next to a separatrix are found from the
saddles of the equilibria's sextic, in mpmath. Measured (every sample): rates within 3.2e-14
relative (the dominant ``h``, whose reference floor is 2.1e-14; 6e-15 elsewhere) and 5.2e-14 at
2000 s, attitude within 1.3e-14 rad and 1.2e-13 at 2000 s (the rounding of ``t``), at 1e-6 and
1e-10 from a separatrix on both sides included; at 1e5 s (the 2000 s motion slowed twenty times)
rates within 2.1e-13 and attitude within 3.0e-13 rad, where the reference's own floor (its
response to the inputs' rounding) is 1.3e-13 and 2.5e-13: the issue's 1e-13 is below what
float64 inputs allow there. The principal-axis references
(torquefree_ros/bench/gyrostat_cases.json) through the same general form: within 3.2e-14 but
for the 1e5 s case and the dominant rotor (1.6e-13 and 1.4e-13: their own floors), the coasting
wheels' angles within one rounding unit of their size. Exactly on a separatrix (``mc = 0``, both
forms; 40 s, the saddle's instability growing the reference's own 1e-24 truncation by 2e5): rates
within 6.8e-16 and attitude within 8.7e-15 rad, compiled and numpy.
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation
import torquefree_ros.bench
from torquefree_ros.core.body.rigid_body import RigidBody
from torquefree_ros.core.exact.gyrostat_oblique import (
    ObliqueAttitude,
    ObliqueRateIntegrals,
    ObliqueRates,
    ONE_REAL_ROOT,
    REAL_ROOTS,
    solve_oblique,
)
from torquefree_ros.core.frames import quaternion
from torquefree_ros.core.propagators import make_propagator
from torquefree_ros.core.run.accuracy import trajectory_errors
from torquefree_ros.core.scene.loader import scene_from_mapping

REFERENCE = json.loads(
    (Path(__file__).parent / 'data' / 'gyrostat_oblique_cases.json').read_text()
)
CASES = {case['name']: case for case in REFERENCE['cases']}

#: the issue's target: 1e-13 of the reference (relative rate, attitude in rad) ...
TARGET = 1e-13
#: ... or this many times the rounding of the sample time where that is larger: ``t`` in float64
#: moves the exact solution by ``|w'| t u`` (rate) and ``|w| t u`` (attitude), ``u = 2^-53``
TIME_ROUNDING_FACTOR = 4.0
ROUNDING_UNIT = 2.0**-53
#: the invariants' bound, in rounding units of their size: sums of three rounded products of
#: rounded functions (the inertial momentum also carries the quaternion's rounding), as the
#: principal-axis gyrostat's test
INVARIANT_ULPS = 64


def attitude(case):
    motion = solve_oblique(case['inertia'], case['angular_velocity'], case['rotor_vector'])
    return ObliqueAttitude(motion, case['rotor_vector'], np.eye(3), case['orientation'])


def tolerances(case):
    """Return each sample's rate and attitude tolerance: the target, or t's rounding (above)."""
    moments, h = np.asarray(case['inertia']), np.asarray(case['rotor_vector'])
    w, t = np.asarray(case['omega']), np.asarray(case['times'])
    acceleration = np.cross(moments * w + h, w) / moments
    speed = np.linalg.norm(w, axis=1)
    rate = np.linalg.norm(acceleration, axis=1) * t * ROUNDING_UNIT / speed
    return (
        np.maximum(TARGET, TIME_ROUNDING_FACTOR * rate),
        np.maximum(TARGET, TIME_ROUNDING_FACTOR * speed * t * ROUNDING_UNIT),
    )


@pytest.mark.parametrize('name', sorted(CASES))
def test_rates_and_attitude_match_the_mpmath_reference(name):
    """Every regime, next to each separatrix on both sides: within the issue's 1e-13 (above)."""
    case = CASES[name]
    omega, q = attitude(case)(np.array(case['times']))
    rate_error, attitude_error = trajectory_errors(omega, q, case['omega'], case['q'])
    rate_tolerance, attitude_tolerance = tolerances(case)
    assert np.all(rate_error <= rate_tolerance), rate_error.max()
    assert np.all(attitude_error <= attitude_tolerance), attitude_error.max()


def test_the_cases_hold_both_forms_and_reach_the_separatrices():
    """
    Both Jacobi forms of ``P``, ``mc`` down to 1e-10 on each, and ``mc = 0`` exactly on each.

    The states exactly on a separatrix (:data:`SADDLES`) apart: they have no period.
    """
    forms, exact = {}, set()
    for case in CASES.values():
        motion = solve_oblique(case['inertia'], case['angular_velocity'], case['rotor_vector'])
        if motion.mc == 0.0:
            exact.add(motion.form)
            assert case['name'] in SADDLES and motion.period == np.inf
            continue
        forms.setdefault(motion.form, []).append(motion.mc)
    assert set(forms) == exact == {REAL_ROOTS, ONE_REAL_ROOT}
    assert min(forms[ONE_REAL_ROOT]) < 1e-9 and min(forms[REAL_ROOTS]) < 1e-4
    separatrix = [c['separatrix_distance'] for c in CASES.values() if 'separatrix_distance' in c]
    assert min(abs(d) for d in separatrix) < 2e-10 and len(separatrix) >= 6


@pytest.mark.parametrize(
    'name',
    [
        'oblique_generic',
        'oblique_dominant_h',
        'oblique_near_center',
        'oblique_separatrix_one_saddle_below_1e-10',
        'oblique_separatrix_one_saddle_above_1e-10',
        'oblique_separatrix_exact',
        'oblique_separatrix_exact_one_root',
    ],
)
def test_invariants_hold_to_the_float64_floor(name):
    """
    ``|I w + h|``, ``w . I w`` and the inertial ``R(q)(I w + h)`` at random times to 1e5 s.

    ``w . I w`` within its bound times ``|m| / |I w|``: the rates come as ``w0`` plus a change of
    ``A`` times a momentum change, rounded to ``|m|``'s units, which a dominant ``h`` makes ~40
    times ``|I w|`` here.
    """
    case = CASES[name]
    moments, h = np.asarray(case['inertia']), np.asarray(case['rotor_vector'])
    times = np.concatenate([[0.0], np.sort(np.random.default_rng(7).uniform(0.0, 1e5, 20_000))])
    omega, q = attitude(case)(times)
    m = moments * omega + h
    H = np.linalg.norm(m, axis=1)
    T = np.einsum('ij,ij->i', omega, moments * omega)
    H_N = quaternion.rotate(q, m)
    bound = INVARIANT_ULPS * np.finfo(float).eps
    assert np.abs(H / H[0] - 1.0).max() <= bound
    gain = max(1.0, H[0] / np.linalg.norm(moments * omega[0]))
    assert np.abs(T / T[0] - 1.0).max() <= bound * gain
    assert np.abs(H_N - H_N[0]).max() <= bound * H[0]


@pytest.mark.parametrize('name', ['oblique_generic', 'oblique_separatrix_two_saddles_below_1e-6'])
def test_the_period_is_the_motions(name):
    """
    After one period DOP853 (rtol 1e-13, an independent integration) is back at ``w0``.

    Within 1e-9 of ``|w0|``: the integrator's own error over up to 130 s next to a separatrix.
    """
    case = CASES[name]
    moments, h = np.asarray(case['inertia']), np.asarray(case['rotor_vector'])
    w0 = np.asarray(case['angular_velocity'])
    motion = solve_oblique(moments, w0, h)
    with np.errstate(under='ignore'):  # (scipy's first step size at t = 0)
        solution = solve_ivp(
            lambda t, w: np.cross(moments * w + h, w) / moments,
            (0.0, motion.period), w0, method='DOP853', rtol=1e-13, atol=1e-16,
        )
    assert np.linalg.norm(solution.y[:, -1] - w0) <= 1e-9 * np.linalg.norm(w0)
    halfway = ObliqueRates(motion)(np.array([0.5 * motion.period]))[0]
    assert np.linalg.norm(halfway - w0) > 1e-3 * np.linalg.norm(w0)  # not a shorter one


#: the states exactly on a separatrix and their saddles ``m_s`` (tools/make_gyrostat_reference.py,
#: exact rational arithmetic), where ``w = A (m_s - h) = 3/8 m_s``
SADDLES = {
    'oblique_separatrix_exact': (-2.0, -2.0, 3.0),
    'oblique_separatrix_exact_one_root': (-1.0, -2.0, 1.0),
}
#: a motion on a separatrix is ``e^{-2 r |t|}`` from its saddle (``r`` 0.149 and 0.125 /s): below
#: 1e-21 from here on, both ways
SADDLE_TIME = 200.0


@pytest.mark.parametrize('name', sorted(SADDLES))
def test_on_a_separatrix_the_rates_tend_to_the_saddle_s_both_ways(name):
    """
    ``mc = 0``: no period, and the rates at ``|t| >= 200 s`` are the saddle's, both ways.

    Within 16 rounding units of the rates' scale (``w = w0 + A k v``, rounded in units of ``|m|
    max(A)``, as the kernels' test), to 1e7 s, where ``sech`` has long underflowed to 0.
    """
    case = CASES[name]
    motion = solve_oblique(case['inertia'], case['angular_velocity'], case['rotor_vector'])
    assert motion.mc == 0.0 and motion.m == 1.0 and motion.period == np.inf
    times = SADDLE_TIME * np.array([-5e4, -5.0, -1.0, 1.0, 5.0, 5e2, 5e4])
    w, m = ObliqueRates(motion).state(times)
    saddle = np.array(SADDLES[name])
    scale = max(np.abs(w).max(), np.abs(m).max() / min(case['inertia']))
    assert np.abs(w - 0.375 * saddle).max() <= 16.0 * np.finfo(float).eps * scale
    assert np.abs(m - saddle).max() <= 16.0 * np.finfo(float).eps * np.abs(saddle).max()


@pytest.mark.parametrize('name', sorted(SADDLES))
def test_on_a_separatrix_the_attitude_becomes_the_saddle_s_steady_spin(name):
    """
    From 200 s on the attitude is ``q(200) ⊗ exp(w_s (t - 200) / 2)`` to 1e5 s.

    The body spins at the saddle's constant ``w_s`` there (its distance below 1e-21): the angle's
    series over the whole line (``WholeLineIntegral``) must end at the saddle's rate with no
    drift. Within ``8 eps (16 + |w| t)`` rad: the angle ``|w| t`` and both sides' rounding.
    """
    case = CASES[name]
    spin = 0.375 * np.array(SADDLES[name])
    times = SADDLE_TIME + np.array([0.0, 1.0, 10.0, 1e3, 1e5])
    omega, q = attitude(case)(times)  # the principal frame is the body frame here
    expected = (
        Rotation.from_quat(q[0]) * Rotation.from_rotvec(np.outer(times - times[0], spin))
    ).as_quat()
    _, angle = trajectory_errors(omega, q, np.broadcast_to(spin, omega.shape), expected)
    assert np.all(angle <= 8.0 * np.finfo(float).eps * (16.0 + np.linalg.norm(spin) * times))
    assert np.all(np.isfinite(q))


@pytest.mark.parametrize('name', sorted(SADDLES))
@pytest.mark.parametrize('span', [(0.0, 40.0), (40.0, 100.0), (100.0, 300.0), (-300.0, 0.0)])
def test_on_a_separatrix_the_angle_is_its_rate_s_integral_over_the_whole_line(name, span):
    """
    ``psi(b) - psi(a)`` against Gauss-Legendre in ``t`` (20 nodes on each of 160 pieces).

    Beyond the reference's 40 s too, where the series in ``s = tanh`` runs into ``s = ±1``: an
    integration in ``t`` shares nothing with it but the rates (``psi'`` is smooth on the scale
    ``1 / 2r``, 3.4 s at most, a piece 1.9 s at most: the rule's error far below rounding).
    Within ``16 eps`` of the angle's size (measured at most 1.1: the angle's rounding, hundreds of
    rad).
    """
    motion = attitude(CASES[name])
    edges = np.linspace(*span, 161)
    nodes, weights = np.polynomial.legendre.leggauss(20)
    middles, halves = 0.5 * (edges[1:] + edges[:-1]), 0.5 * np.diff(edges)
    rates = motion._angle_rate((middles[:, None] + halves[:, None] * nodes).ravel())
    integral = math.fsum((rates.reshape(-1, 20) @ weights * halves).tolist())
    ends = np.array(span)
    psi = motion.psi_rate * ends + motion.angle(ends)
    size = max(np.abs(psi).max(), abs(integral))
    assert abs((psi[1] - psi[0]) - integral) <= 16.0 * np.finfo(float).eps * size


PRINCIPAL_REFERENCE = json.loads(
    Path(torquefree_ros.bench.__file__).with_name('gyrostat_cases.json').read_text()
)
PRINCIPAL_CASES = {
    case['name']: case
    for case in PRINCIPAL_REFERENCE['cases']
    if 'rotor' in case and case['name'] != 'symmetric_rotor_on_axis'
}


@pytest.mark.parametrize('name', sorted(PRINCIPAL_CASES))
def test_the_principal_axis_references_hold_through_the_general_form(name):
    """
    The principal-axis gyrostat's mpmath references hold through the general closed form.

    Their own regimes, 1e5 s, the separatrices at 1e-6 and 1e-10 and on one: the general form
    never asks where ``h`` is. Tolerance as above: the target, or the rounding of t (the 1e5 s
    case: 1.6e-13).
    """
    case = PRINCIPAL_CASES[name]
    axis = np.asarray(case['rotor']['axis'], dtype=float)
    h = case['rotor']['momentum'] * axis / np.linalg.norm(axis)
    motion = solve_oblique(case['inertia'], case['angular_velocity'], h)
    omega, q = ObliqueAttitude(motion, h, np.eye(3), case['orientation'])(np.array(case['times']))
    rate_error, attitude_error = trajectory_errors(omega, q, case['omega'], case['q'])
    rate_tolerance, attitude_tolerance = tolerances({**case, 'rotor_vector': h})
    assert np.all(rate_error <= rate_tolerance), rate_error.max()
    assert np.all(attitude_error <= attitude_tolerance), attitude_error.max()


WHEEL_CASES = {case['name']: case for case in PRINCIPAL_REFERENCE['cases'] if 'wheels' in case}


@pytest.mark.parametrize('name', sorted(WHEEL_CASES))
def test_coasting_wheels_angles_match_the_reference(name):
    """
    Coasting wheels (the gyrostat ``I_s``, ``h = sum h_i g_i``): angles from the rates' series.

    Within 2 rounding units of the angle's size (800 rad: 1.1e-13 measured, the reference's floor
    1.3e-13) or 1e-13; rates and attitude as the principal-axis references above.
    """
    case = WHEEL_CASES[name]
    h = np.asarray(case['gyrostat_momentum'])
    motion = solve_oblique(case['gyrostat_inertia'], case['angular_velocity'], h)
    attitude_ = ObliqueAttitude(motion, h, np.eye(3), case['orientation'])
    times = np.array(case['times'])
    omega, q = attitude_(times)
    rate_error, attitude_error = trajectory_errors(omega, q, case['omega'], case['q'])
    assert rate_error.max() <= TARGET and attitude_error.max() <= TARGET
    axes = np.array([np.asarray(w['axis'], float) for w in case['wheels']])
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    spin_inertias = np.array([w['spin_inertia'] for w in case['wheels']])
    speeds = np.array([w['speed'] for w in case['wheels']])
    momenta = spin_inertias * (speeds + axes @ np.asarray(case['angular_velocity']))
    angles = ObliqueRateIntegrals(attitude_.rates).wheel_angles(
        times, axes, momenta / spin_inertias
    )
    reference = np.asarray(case['wheel_angles'])
    bound = max(1e-13, 2.0 * np.finfo(float).eps * np.abs(reference).max())
    assert np.abs(angles - reference).max() <= bound


def test_a_degenerate_base_point_moves_along_the_motion():
    """A start of symmetry (``w1 = 0``, ``h`` on axis 3: ``a1(0) = 0``) bases the pencil later."""
    case = PRINCIPAL_CASES['turning_point_start']
    h = case['rotor']['momentum'] * np.asarray(case['rotor']['axis'], dtype=float)
    assert solve_oblique(case['inertia'], case['angular_velocity'], h).base_time > 0.0


def test_a_uniform_precession_is_refused_with_its_reason():
    """A symmetric body with ``h`` on its axis: the curve is a circle, no elliptic function."""
    with pytest.raises(ValueError, match='uniform precession'):
        solve_oblique([2.0, 2.0, 1.0], [0.5, 0.6, -0.3], [0.0, 0.0, 0.3])


def test_a_relative_equilibrium_is_stationary():
    """``I w + h = mu w`` exactly (``w = (1, 1/2, 1/4)``, ``mu = 4``): no motion to solve."""
    assert solve_oblique([1.0, 2.0, 3.0], [1.0, 0.5, 0.25], [3.0, 1.0, 0.25]) is None


# -- continuity with the principal-axis solution and the free body --------------------------------
INERTIA, OMEGA = [1.0, 2.0, 3.0], [0.4, -0.3, 0.9]
Q0 = Rotation.from_rotvec([0.2, -0.5, 0.9]).as_quat()
TIMES = np.linspace(0.0, 20.0, 41)


def rotor_scene(h_vector):
    size = float(np.linalg.norm(h_vector))
    return scene_from_mapping(
        {
            'body': {'inertia': INERTIA},
            'initial': {'angular_velocity': OMEGA, 'orientation': list(Q0)},
            'effects': [{'rotor': {'momentum': size, 'axis': list(h_vector)}}],
        }
    )


def oblique(h_vector):
    motion = solve_oblique(INERTIA, OMEGA, h_vector)
    return ObliqueAttitude(motion, h_vector, np.eye(3), Q0)(TIMES)


@pytest.mark.parametrize('axis', [0, 1, 2])
def test_h_on_a_principal_axis_is_the_principal_axis_solution(axis):
    """
    ``h`` exactly along a principal axis: the principal-axis closed form, the independent path.

    Within 1e-13 (rate relative, attitude rad) over 20 s: both at the float64 floor.
    """
    h = np.zeros(3)
    h[axis] = 0.7
    principal = rotor_scene(h).propagator('gyrostat')
    w_ref, q_ref = principal(TIMES)
    w, q = oblique(h)
    rate_error, attitude_error = trajectory_errors(w, q, w_ref, q_ref)
    assert rate_error.max() <= 1e-13 and attitude_error.max() <= 1e-13


def test_a_body_frame_off_the_principal_axes_carries_through():
    """
    A full inertia tensor (principal axes turned from the body's): rates and attitude in the body.

    Against the principal-axis propagator on the same scene (``h`` along the third principal
    axis), within 1e-13 over 20 s: the frame change adds rounding only.
    """
    turn = Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()
    tensor = turn @ np.diag(INERTIA) @ turn.T
    scene = scene_from_mapping(
        {
            'body': {'inertia': [*np.diag(tensor), tensor[0, 1], tensor[0, 2], tensor[1, 2]]},
            'initial': {'angular_velocity': OMEGA, 'orientation': list(Q0)},
            'effects': [{'rotor': {'momentum': 0.7, 'axis': list(turn[:, 2])}}],
        }
    )
    w_ref, q_ref = scene.propagator('gyrostat')(TIMES)
    body = RigidBody.from_inertia(tensor)
    axes = body.principal_axes
    h_P = axes.T @ (0.7 * turn[:, 2])
    motion = solve_oblique(body.moments, axes.T @ np.asarray(OMEGA), h_P)
    w, q = ObliqueAttitude(motion, h_P, axes, Q0)(TIMES)
    rate_error, attitude_error = trajectory_errors(w, q, w_ref, q_ref)
    assert rate_error.max() <= 1e-13 and attitude_error.max() <= 1e-13


def test_an_oblique_component_moves_the_motion_continuously_from_the_principal_axis():
    """
    ``h = 0.7 e3 + eps (1, 1, 0)``: the change from the principal-axis solution is linear in eps.

    The first-order change per unit eps is the same at eps = 1e-5, 1e-7 and 1e-9 within 1%
    (second order: 1e-5 of it; the floor, 1e-14 of a change of ~1e-9: 1e-5): no jump as the
    component vanishes, each eps taking the general closed form.
    """
    base = np.array([0.0, 0.0, 0.7])
    w_ref, q_ref = rotor_scene(base).propagator('gyrostat')(TIMES)
    slopes = []
    for eps in (1e-5, 1e-7, 1e-9):
        w, q = oblique(base + eps * np.array([1.0, 1.0, 0.0]))
        rate_error, attitude_error = trajectory_errors(w, q, w_ref, q_ref)
        slopes.append((rate_error[-1] / eps, attitude_error[-1] / eps))
    slopes = np.array(slopes)
    assert np.all(slopes > 1e-3)  # the component does move the motion
    np.testing.assert_allclose(slopes[1:], slopes[:1].repeat(2, axis=0), rtol=1e-2)


def test_h_to_zero_is_the_free_body():
    """
    ``h = eps (1, -2, 1.5)`` tends to the free body (the ``analytic`` propagator) continuously.

    The motions differ at first order in ``h`` (rates within ``10 |h| t``, attitude within
    ``10 |h| t^2``), down to the floor; at ``h = 0`` the general closed form is the free body's
    to 1e-13.
    """
    w_free, q_free = make_propagator(INERTIA, OMEGA, Q0, 'analytic')(TIMES)
    for eps in (1e-4, 1e-7, 1e-10, 0.0):
        w, q = oblique(eps * np.array([1.0, -2.0, 1.5]))
        rate_error, attitude_error = trajectory_errors(w, q, w_free, q_free)
        size = 2.7 * eps
        assert np.all(rate_error <= 10.0 * size * TIMES + 1e-13), eps
        assert np.all(attitude_error <= 10.0 * size * TIMES**2 + 1e-13), eps


def test_the_angle_series_reaches_the_floor_with_few_panels():
    """Next to a separatrix the panels crowd by the saddle: 1e-10 from it in under 100 panels."""
    case = CASES['oblique_separatrix_one_saddle_below_1e-10']
    assert attitude(case).angle.count < 100
