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
The oblique free gyrostat through the ``gyrostat`` propagator and ``auto`` (issue 43).

The closed form itself is held to its mpmath references in test/test_gyrostat_oblique.py; here
the propagator that runs it: ``auto``'s choice, its states equal to the module's bit for bit, the
same references through scenes (rotors, coasting wheels), DOP853 at rtol 1e-13, the
conservation laws over long horizons, continuity at ``h -> 0`` and at the principal axes, the
states the closed form refuses (integrated instead), the sample rules every propagator keeps and
the regime the node reports.
"""

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from test_gyrostat_oblique import tolerances
import torquefree_ros.bench
from torquefree_ros.core.body.rigid_body import RigidBody
from torquefree_ros.core.exact.gyrostat_oblique import (
    ObliqueAttitude,
    ObliqueMotion,
    ObliqueRateIntegrals,
    solve_oblique,
)
from torquefree_ros.core.exact.regime import GyrostatRegime
from torquefree_ros.core.frames import quaternion
from torquefree_ros.core.propagators import make_propagator, motion_regime
from torquefree_ros.core.propagators.analytic import spin_attitude
from torquefree_ros.core.propagators.gyrostat import (
    free_gyrostat,
    OBLIQUE,
    OBLIQUE_MOMENTUM_RATIO,
    ROTOR_AXIS_TOLERANCE,
)
from torquefree_ros.core.run.accuracy import estimate_accuracy, trajectory_errors
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping

OBLIQUE_REFERENCE = json.loads(
    (Path(__file__).parent / 'data' / 'gyrostat_oblique_cases.json').read_text()
)
OBLIQUE_CASES = {case['name']: case for case in OBLIQUE_REFERENCE['cases']}
PRINCIPAL_REFERENCE = json.loads(
    Path(torquefree_ros.bench.__file__).with_name('gyrostat_cases.json').read_text()
)
OBLIQUE_ROTOR = next(c for c in PRINCIPAL_REFERENCE['cases'] if c['name'] == 'oblique_rotor')

INERTIA, OMEGA = [1.0, 2.0, 3.0], [0.3, 0.5, -0.4]
Q0 = Rotation.from_rotvec([0.2, -0.5, 0.9]).as_quat().tolist()
ROTOR = {'rotor': {'momentum': 1.5, 'axis': [0.3, -1.0, 0.2]}}
TIMES = np.linspace(0.0, 20.0, 41)
#: a full inertia tensor: the body frame turned from the principal one
TURN = Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()
TENSOR = TURN @ np.diag([2.0, 3.0, 4.5]) @ TURN.T
ELEMENTS = [TENSOR[0, 0], TENSOR[1, 1], TENSOR[2, 2], TENSOR[0, 1], TENSOR[0, 2], TENSOR[1, 2]]


def scene(inertia, omega, effects, orientation=Q0):
    return scene_from_mapping(
        {
            'body': {'inertia': list(inertia)},
            'initial': {'angular_velocity': list(omega), 'orientation': list(orientation)},
            'effects': effects,
        }
    )


def principal_rotors(vector):
    """
    Return rotors along the three body axes whose momenta add to ``vector`` exactly.

    A rotor's ``h_B = momentum axis / |axis|`` rounds an oblique vector; along a unit axis it is
    the momentum itself, so the sum is the reference's ``h`` bit for bit (next to a separatrix
    one rounding unit of ``h`` moves the motion by far more than the closed form's error).
    """
    return [
        {'rotor': {'momentum': float(v), 'axis': np.eye(3)[k].tolist()}}
        for k, v in enumerate(vector)
        if v != 0.0
    ]


def coasting(axis, spin_inertia, speed):
    """Return one frictionless wheel with no motor torque."""
    return {
        'axis': axis,
        'spin_inertia': spin_inertia,
        'max_torque': 0.1,
        'max_speed': 1000.0,
        'speed': speed,
    }


#: coasting wheels whose absolute momenta add to an oblique ``h`` (of ``I_s``'s axes)
WHEELS = [
    coasting([0, 0, 1], 0.2, 20.0),
    coasting([1, 0, 0], 0.1, 1.0),
    coasting([1, 1, 1], 0.05, -8.0),
]


def wheels_scene(inertia=INERTIA, omega=OMEGA, wheels=WHEELS):
    return scene(inertia, omega, [{'reaction_wheels': {'wheels': wheels}}])


# -- auto's choice ------------------------------------------------------------------------------
def test_auto_picks_the_gyrostat_for_an_oblique_rotor():
    propagator = scene(INERTIA, OMEGA, [ROTOR]).propagator()
    assert propagator.name == 'gyrostat' and propagator.exact
    assert propagator.rotor_axis == OBLIQUE and isinstance(propagator.motion, ObliqueMotion)
    np.testing.assert_array_equal(propagator.momentum_P, propagator.effects[0].h_B)
    assert propagator.rotor_momentum == pytest.approx(1.5, rel=1e-15)
    # coasting wheels with an oblique sum, on a full tensor, and through the Python API
    assert wheels_scene().propagator().rotor_axis == OBLIQUE
    turned = scene(ELEMENTS, OMEGA, [ROTOR]).propagator()
    assert turned.name == 'gyrostat' and turned.rotor_axis == OBLIQUE
    rotor = scene(INERTIA, OMEGA, [ROTOR]).effects
    assert make_propagator(INERTIA, OMEGA, Q0, effects=rotor).name == 'gyrostat'
    assert estimate_accuracy(propagator).reference == 'the closed form'
    assert propagator.conserved == frozenset({'energy', 'momentum'})


def test_beside_another_effect_auto_integrates():
    damper = {'damper': {'inertia': 0.1, 'damping': 0.1}}
    assert scene(INERTIA, OMEGA, [ROTOR, damper]).propagator().name == 'dop853'


# -- the module's closed form, bit for bit --------------------------------------------------------
@pytest.mark.parametrize('inertia', [INERTIA, ELEMENTS], ids=['principal', 'full tensor'])
def test_the_states_are_the_module_s_bit_for_bit(inertia):
    """The propagator runs ``ObliqueAttitude`` on ``h`` and ``w0`` in ``I``'s frame, no more."""
    s = scene(inertia, OMEGA, [ROTOR])
    propagator = s.propagator()
    body = RigidBody.from_inertia(inertia)
    h_P = s.effects[0].h_B @ body.principal_axes
    motion = solve_oblique(body.moments, body.to_principal(np.array(OMEGA)), h_P)
    times = np.concatenate([TIMES, [1e3, 1e5]])
    expected = ObliqueAttitude(motion, h_P, body.principal_axes, Q0)(times)
    omega, q = propagator(times)
    np.testing.assert_array_equal(omega[1:], expected[0][1:])
    np.testing.assert_array_equal(q[1:], expected[1][1:])
    # sample 0 is the initial state itself, as every propagator's
    np.testing.assert_array_equal(omega[0], OMEGA)
    np.testing.assert_array_equal(q[0], np.asarray(Q0) / np.linalg.norm(Q0))


def test_coasting_wheels_states_are_the_module_s_bit_for_bit():
    """``h_i`` constant; ``theta_i`` from ``ObliqueRateIntegrals`` on ``I_s``'s frame."""
    s = wheels_scene()
    propagator = s.propagator()
    (effect,) = propagator.effects
    found = free_gyrostat(s.inertia, s.effects, np.array(OMEGA))
    axes = found.inertia.principal_axes
    attitude = ObliqueAttitude(found.motion, found.momentum_P, axes, Q0)
    omega, q, x = propagator.states(TIMES)
    expected_omega, expected_q = attitude(TIMES)
    np.testing.assert_array_equal(omega[1:], expected_omega[1:])
    np.testing.assert_array_equal(q[1:], expected_q[1:])
    momenta = propagator.x0[0::2]
    np.testing.assert_array_equal(x[:, 0::2], np.broadcast_to(momenta, (TIMES.size, 3)))
    angles = ObliqueRateIntegrals(attitude.rates).wheel_angles(
        TIMES, effect.axes @ axes, momenta / effect.spin_inertias
    )
    np.testing.assert_array_equal(x[1:, 1::2], angles[1:])


# -- against the mpmath references ----------------------------------------------------------------
@pytest.mark.parametrize('name', sorted(OBLIQUE_CASES))
def test_the_oblique_references_hold_through_the_propagator(name):
    """
    Each case's ``h`` as rotors (exactly its value), through ``auto``: the module's tolerances.

    The issue's 1e-13 (relative rate, rad) or four times the rounding of ``t`` where that is
    larger (test_gyrostat_oblique.py's :func:`tolerances`).
    """
    case = OBLIQUE_CASES[name]
    s = scene(case['inertia'], case['angular_velocity'], principal_rotors(case['rotor_vector']),
              case['orientation'])
    propagator = s.propagator()
    assert propagator.name == 'gyrostat' and propagator.rotor_axis == OBLIQUE
    omega, q = propagator(np.array(case['times']))
    rate_error, attitude_error = trajectory_errors(omega, q, case['omega'], case['q'])
    rate_tolerance, attitude_tolerance = tolerances(case)
    assert np.all(rate_error <= rate_tolerance), rate_error.max()
    assert np.all(attitude_error <= attitude_tolerance), attitude_error.max()


def test_the_bench_s_oblique_rotor_meets_its_reference():
    """
    The bench's ``oblique_rotor`` (a scene's rotor, its axis normalised in float64): 1e-13.

    Its reference takes the axis exactly; the rotor's rounding of ``h`` (one unit) moves this
    motion, far from a separatrix, by about as much (1.5e-15 and 1.8e-15 measured).
    """
    case = OBLIQUE_ROTOR
    s = scene(case['inertia'], case['angular_velocity'], [{'rotor': case['rotor']}],
              case['orientation'])
    propagator = s.propagator()
    assert propagator.name == 'gyrostat' and propagator.rotor_axis == OBLIQUE
    omega, q = propagator(np.array(case['times']))
    rate_error, attitude_error = trajectory_errors(omega, q, case['omega'], case['q'])
    assert rate_error.max() <= 1e-13 and attitude_error.max() <= 1e-13


# -- against DOP853 -------------------------------------------------------------------------------
#: DOP853 at rtol 1e-13 over 20 s is within ~1e-12 of the truth in rates, attitude and the
#: wheels' angles (relative to their size); 5e-12 leaves its error room and is far below what a
#: wrong frame or sign costs (~1)
AGREEMENT = 5e-12


@pytest.mark.parametrize(
    'label, inertia, omega, effects',
    [
        ('the library gyrostat, its rotor tilted', [1.0, 2.0, 3.0], [0.01, 1.0, 0.01],
         [{'rotor': {'momentum': 5.0, 'axis': [0.2, 1.0, -0.1]}}]),
        ('a full tensor', ELEMENTS, [0.2, -0.1, 0.5], [ROTOR]),
        ('coasting wheels', INERTIA, OMEGA, [{'reaction_wheels': {'wheels': WHEELS}}]),
    ],
)
def test_the_closed_form_follows_dop853(label, inertia, omega, effects):
    s = scene(inertia, omega, effects)
    exact = s.propagator()
    assert exact.name == 'gyrostat' and exact.rotor_axis == OBLIQUE, label
    w, q, x = exact.states(TIMES)
    w_ref, q_ref, x_ref = s.propagator('dop853', rtol=1e-13, atol=1e-15).states(TIMES)
    rate_error, attitude_error = trajectory_errors(w, q, w_ref, q_ref)
    assert rate_error.max() <= AGREEMENT and attitude_error.max() <= AGREEMENT
    if x.size:
        np.testing.assert_allclose(x, x_ref, rtol=0, atol=AGREEMENT * np.abs(x_ref).max())


# -- conservation ---------------------------------------------------------------------------------
@pytest.mark.parametrize(
    'label, inertia, effects',
    [
        ('a rotor', INERTIA, [ROTOR]),
        ('a rotor on a full tensor', ELEMENTS, [ROTOR]),
        ('coasting wheels', INERTIA, [{'reaction_wheels': {'wheels': WHEELS}}]),
    ],
)
def test_invariants_hold_to_the_float64_floor_over_long_horizons(label, inertia, effects):
    """
    ``|I w + h|``, ``w . I w`` and the inertial ``R(q)(I w + h)`` at random times to 1e6 s.

    Each sample comes anew from the closed form (nothing accumulates): within 64 rounding units
    of their first values (sums of three rounded products of rounded functions, as the
    principal-axis gyrostat's test), the energy's times ``|m| / |I w|`` (the rates come from the
    momentum: :data:`.gyrostat.OBLIQUE_MOMENTUM_RATIO`; ~1.5 here).
    """
    propagator = scene(inertia, OMEGA, effects).propagator()
    assert propagator.rotor_axis == OBLIQUE, label
    times = np.concatenate([[0.0], np.sort(np.random.default_rng(11).uniform(0.0, 1e6, 20_000))])
    omega, q, x = propagator.states(times)
    m_B = propagator.momentum_B(omega, x)
    H = np.linalg.norm(m_B, axis=1)
    T = propagator.energy(omega, x)
    H_N = quaternion.rotate(q, m_B)
    bound = 64 * np.finfo(float).eps
    inertia_ = free_gyrostat(propagator.body, propagator.effects, propagator.omega0_B).inertia
    gain = max(1.0, H[0] / np.linalg.norm(inertia_.tensor @ propagator.omega0_B))
    assert np.abs(H / H[0] - 1.0).max() <= bound
    assert np.abs(T / T[0] - 1.0).max() <= bound * gain
    assert np.abs(H_N - H_N[0]).max() <= bound * H[0]


# -- continuity -----------------------------------------------------------------------------------
def test_h_to_zero_is_the_free_body():
    """
    ``h = eps (1, -2, 1.5)`` tends to the free body continuously; ``h = 0`` is it, bit for bit.

    The motions differ at first order in ``h`` (rates within ``10 |h| t``, attitude within
    ``10 |h| t^2``, as the principal-axis gyrostat's test), down to the floor.
    """
    free = make_propagator(INERTIA, OMEGA, Q0, 'analytic')
    w_free, q_free = free(TIMES)
    direction = np.array([1.0, -2.0, 1.5])
    for eps in (1e-4, 1e-7, 1e-10):
        size = eps * np.linalg.norm(direction)
        rotor = {'rotor': {'momentum': size, 'axis': direction.tolist()}}
        p = scene(INERTIA, OMEGA, [rotor]).propagator()
        assert p.name == 'gyrostat' and p.rotor_axis == OBLIQUE
        w, q = p(TIMES)
        rate_error, attitude_error = trajectory_errors(w, q, w_free, q_free)
        assert np.all(rate_error <= 10.0 * size * TIMES + 1e-13), eps
        assert np.all(attitude_error <= 10.0 * size * TIMES**2 + 1e-13), eps
    zero = {'rotor': {'momentum': 0.0, 'axis': direction.tolist()}}
    w, q = scene(INERTIA, OMEGA, [zero]).propagator()(TIMES)
    np.testing.assert_array_equal(w, w_free)
    np.testing.assert_array_equal(q, q_free)


def test_the_principal_axis_boundary_is_continuous():
    """
    Just past :data:`ROTOR_AXIS_TOLERANCE` off an axis: the oblique form, 1e-13 from the axis'.

    ``h`` tilted by ``2 ROTOR_AXIS_TOLERANCE`` (the oblique closed form) and by half of it (the
    principal-axis one) against ``h`` on the axis: the tilt moves the motion by ~1e-15 over
    20 s, the two closed forms are each at the float64 floor, so no jump between them.
    """
    on_axis = scene(INERTIA, OMEGA, [{'rotor': {'momentum': 0.7, 'axis': [0, 0, 1]}}])
    w_ref, q_ref = on_axis.propagator()(TIMES)
    for tilt, oblique in ((2.0 * ROTOR_AXIS_TOLERANCE, True), (0.5 * ROTOR_AXIS_TOLERANCE, False)):
        rotor = {'rotor': {'momentum': 0.7, 'axis': [tilt, 0.0, 1.0]}}
        p = scene(INERTIA, OMEGA, [rotor]).propagator()
        assert (p.rotor_axis == OBLIQUE) is oblique
        rate_error, attitude_error = trajectory_errors(*p(TIMES), w_ref, q_ref)
        assert rate_error.max() <= 1e-13 and attitude_error.max() <= 1e-13


# -- what the closed form refuses -----------------------------------------------------------------
def test_a_relative_equilibrium_spins_at_a_constant_rate():
    """``I w + h = 4 w`` exactly (``w = (1, 1/2, 1/4)``, ``h = (3, 1, 1/4)``): ``m x w = 0``."""
    s = scene(INERTIA, [1.0, 0.5, 0.25], principal_rotors([3.0, 1.0, 0.25]))
    p = s.propagator()
    assert p.name == 'gyrostat' and p.rotor_axis == OBLIQUE and p.motion is None
    omega, q = p(TIMES)
    np.testing.assert_array_equal(omega, np.broadcast_to([1.0, 0.5, 0.25], omega.shape))
    np.testing.assert_array_equal(q[1:], spin_attitude(p.omega0_B, p.q0_NB, TIMES[1:]))
    assert motion_regime(p).kind == 'gyrostat_relative_equilibrium'


@pytest.mark.parametrize('name', ['oblique_separatrix_exact', 'oblique_separatrix_exact_one_root'])
def test_a_state_exactly_on_a_separatrix_is_the_gyrostat_s(name):
    """
    ``mc = 0`` (the energy a saddle's, exactly in float64): ``auto`` takes the closed form.

    The regime says so, with no period, the distance to the saddle's separatrix 0 (2T and the
    saddle's energy each rounded: within 4 rounding units), and the saddle the motion tends to
    among the equilibria (``w = 3/8 m_s`` from 200 s on, test_gyrostat_oblique.py).
    """
    case = OBLIQUE_CASES[name]
    s = scene(case['inertia'], case['angular_velocity'], principal_rotors(case['rotor_vector']),
              case['orientation'])
    p = s.propagator()
    assert p.name == 'gyrostat' and p.rotor_axis == OBLIQUE and p.motion.mc == 0.0
    regime = motion_regime(p)
    assert regime.kind == 'gyrostat_separatrix' and regime.polhode_period == np.inf
    assert abs(regime.separatrix_distance) <= 4.0 * np.finfo(float).eps
    omega, _ = p(np.array([1e4]))
    saddle = np.array(case['inertia']) * omega[0] + np.array(case['rotor_vector'])
    nearest = min(regime.equilibria, key=lambda e: np.linalg.norm(e.momentum - saddle))
    assert nearest.kind == 'saddle'
    assert np.linalg.norm(nearest.momentum - saddle) <= 1e-13 * regime.momentum


def test_states_the_closed_form_refuses_are_integrated_and_named():
    """
    A sphere's oblique rotor (a circle: a uniform precession) and a momentum over the ratio.

    ``auto`` takes DOP853; naming ``gyrostat`` is refused with the reason.
    """
    sphere = scene([1.0, 1.0, 1.0], OMEGA, [ROTOR])
    dominant = scene(INERTIA, [1e-3, 0.0, 0.0], [{'rotor': {'momentum': 1e4, 'axis': [1, 1, 1]}}])
    assert 1e4 / np.sqrt(1.0 * 1e-6) > OBLIQUE_MOMENTUM_RATIO  # |H| / sqrt(I_min 2T)
    for s, words in ((sphere, 'which the oblique closed form refuses'),
                     (dominant, "times the body's own momentum")):
        assert s.propagator().name == 'dop853'
        with pytest.raises(ValueError, match=r"^propagator: 'gyrostat' is the exact") as raised:
            s.propagator('gyrostat')
        assert words in str(raised.value)


# -- the sample rules every propagator keeps ------------------------------------------------------
def test_samples_do_not_depend_on_how_they_are_requested():
    """The node asks in blocks, offline tools all at once: the samples are identical."""
    s = wheels_scene()
    times = np.linspace(0.0, 30.0, 301)
    w_all, q_all, x_all = s.propagator().states(times)
    propagator = s.propagator()
    blocks = [propagator.states(chunk) for chunk in np.array_split(times, 7)]
    for index, whole in enumerate((w_all, q_all, x_all)):
        np.testing.assert_array_equal(np.concatenate([b[index] for b in blocks]), whole)
    single = [s.propagator().states([t]) for t in times[:9]]
    for index, whole in enumerate((w_all, q_all, x_all)):
        np.testing.assert_array_equal(np.concatenate([b[index] for b in single]), whole[:9])


def test_the_propagator_refuses_what_every_propagator_refuses():
    s = scene(INERTIA, OMEGA, [ROTOR])
    with pytest.raises(ValueError, match=r'^times: must be sorted'):
        s.propagator()([0.0, 2.0, 1.0])
    with pytest.raises(ValueError, match=r"^step: not an option of propagator 'gyrostat'"):
        s.propagator('gyrostat', step=0.1)


# -- the regime the node reports ------------------------------------------------------------------
def test_the_regime_is_the_oblique_gyrostat_s_and_its_period_the_rates():
    """
    The regime names the oblique ``h``, ``|I w + h|`` and ``2T``; its period is the rates'.

    DOP853 (rtol 1e-12, independent of the closed form) is back at ``w0`` after the period, to
    1e-9 of ``|w0|``, and not after half of it. The node's start-up line says so.
    """
    s = scene(INERTIA, OMEGA, [ROTOR])
    simulation = Simulation(s.propagator(), 10.0)
    regime = simulation.regime
    assert isinstance(regime, GyrostatRegime) and regime.kind == 'gyrostat_oblique_polhode'
    assert regime.rotor_axis == -1
    np.testing.assert_array_equal(regime.rotor_vector, s.effects[0].h_B)
    omega0 = np.array(OMEGA)
    assert regime.energy == pytest.approx(omega0 @ (np.array(INERTIA) * omega0), rel=1e-15)
    period = regime.polhode_period
    integrated = s.propagator('dop853', rtol=1e-12, atol=1e-14)
    omega, _ = integrated(np.array([0.0, 0.5 * period, period]))
    assert np.linalg.norm(omega[2] - omega0) <= 1e-9 * np.linalg.norm(omega0)
    assert np.linalg.norm(omega[1] - omega0) > 1e-3 * np.linalg.norm(omega0)
    summary = simulation.summary()
    assert 'regime: free gyrostat (h (' in summary and 'off every principal axis' in summary
    assert 'oblique polhode, polhode period' in summary


@pytest.mark.parametrize(
    'name', sorted(n for n in OBLIQUE_CASES if 'separatrix_distance' in OBLIQUE_CASES[n])
)
def test_the_regime_finds_the_equilibria_and_the_separatrix_distance(name):
    """
    Against the reference's distances (its saddles found in mpmath from the same sextic).

    Each equilibrium is one (``m x w = 0`` on ``|m| = H`` to 1e-13 of the scale); centres less
    saddles is 2 (Poincaré-Hopf on the sphere); the distance within 1e-4 relative (2T and the
    saddle's energy each rounded, ~1e-16 of a distance of 1e-10 at worst: 2.3e-5 measured).
    """
    case = OBLIQUE_CASES[name]
    s = scene(case['inertia'], case['angular_velocity'], principal_rotors(case['rotor_vector']))
    regime = motion_regime(s.propagator())
    assert regime.kind == 'gyrostat_oblique_polhode'
    assert regime.separatrix_distance == pytest.approx(case['separatrix_distance'], rel=1e-4)
    kinds = [e.kind for e in regime.equilibria]
    assert kinds.count('centre') - kinds.count('saddle') == 2 and 'degenerate' not in kinds
    J, h = np.array(case['inertia']), np.array(case['rotor_vector'])
    for equilibrium in regime.equilibria:
        m = np.array(equilibrium.momentum)
        w = (m - h) / J
        assert np.linalg.norm(m) == pytest.approx(regime.momentum, rel=1e-13)
        assert np.abs(np.cross(m, w)).max() <= 1e-13 * regime.momentum * np.abs(w).max()


def test_a_refused_state_keeps_the_gyrostat_s_regime():
    """A sphere with an oblique rotor: integrated, but a gyrostat: its ``h`` and equilibria."""
    s = scene([1.0, 1.0, 1.0], OMEGA, [ROTOR])
    simulation = Simulation(s.propagator(), 10.0)
    assert simulation.propagator.name == 'dop853'
    regime = simulation.regime
    assert regime.kind == 'gyrostat_oblique' and np.isnan(regime.polhode_period)
    # on a sphere m x w = -m x h / J vanishes where m is along h: the two poles of h, centres
    h = s.effects[0].h_B
    for equilibrium in regime.equilibria:
        assert np.linalg.norm(np.cross(equilibrium.momentum, h)) <= 1e-14 * regime.momentum
    assert [e.kind for e in regime.equilibria] == ['centre', 'centre']
