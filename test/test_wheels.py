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
The ``reaction_wheels`` effect against independent references.

Conservation of the inertial momentum, closed forms of a wheel on a principal axis (spin-up,
viscous and Coulomb coast-down, the speed limit's band), and LSODA on the equations written out
here in the relative speeds ``Omega`` (the effect integrates absolute momenta ``h``). Every check
runs on both paths of the numerical propagators (compiled kernels, scipy/numpy reference).
"""

from __future__ import annotations

import math

from conftest import require_numba
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation
from torquefree_ros.core.compiled import drivers
from torquefree_ros.core.effects import ENERGY, MOMENTUM
from torquefree_ros.core.frames import quaternion
from torquefree_ros.core.numerics import kernels as switch
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping

pytestmark = pytest.mark.usefixtures('integrator_path')

TIGHT = {'rtol': 1e-12, 'atol': 1e-14}
EPS = np.finfo(float).eps


def wheel(axis, spin_inertia=0.08, **extra):
    return {
        'axis': list(axis),
        'spin_inertia': spin_inertia,
        'max_torque': 1.0,
        'max_speed': 1000.0,
        **extra,
    }


def scene(inertia, omega, effect, orientation=(0.0, 0.0, 0.0, 1.0)):
    return scene_from_mapping(
        {
            'body': {'inertia': list(inertia)},
            'initial': {'angular_velocity': list(omega), 'orientation': list(orientation)},
            'effects': [{'reaction_wheels': effect}],
        }
    )


# A tumbling body with a full inertia tensor and a four-wheel pyramid: one wheel driven into its
# speed limit's band, one braked through zero speed (the Coulomb band), one coasting to rest under
# strong dry friction, two with a Stribeck peak; commands clipped (0.5 > 0.2) and switched twice.
PYRAMID_INERTIA = [12.0, 10.0, 8.0, 0.3, -0.2, 0.1]
PYRAMID_OMEGA = [0.05, -0.03, 0.02]
PYRAMID_ORIENTATION = Rotation.from_rotvec([0.2, -0.4, 0.3]).as_quat().tolist()
PYRAMID = {
    'wheels': [
        wheel(
            [1.0, 1.0, 1.0],
            max_torque=0.2,
            max_speed=60.0,
            viscous=2e-4,
            coulomb=3e-3,
            speed=20.0,
            stribeck={'static': 5e-3, 'speed': 2.0},
        ),
        wheel(
            [-1.0, 1.0, 1.0],
            max_torque=0.2,
            max_speed=60.0,
            viscous=2e-4,
            coulomb=3e-3,
            speed=-5.0,
        ),
        wheel([-1.0, -1.0, 1.0], max_torque=0.2, max_speed=60.0, coulomb=0.05, coulomb_band=0.05),
        wheel(
            [1.0, -1.0, 1.0],
            max_torque=0.2,
            max_speed=60.0,
            viscous=1e-4,
            coulomb=2e-3,
            speed=55.0,
            stribeck={'static': 4e-3, 'speed': 1.0},
        ),
    ],
    'schedule': [
        {'start': 0.0, 'torque': [0.1, -0.05, 0.5, 0.15]},
        {'start': 3.3, 'torque': [-0.2, 0.2, 0.0, 0.15]},
        {'start': 7.1, 'torque': [0.05, 0.1, 0.0, -0.02]},
    ],
}
PYRAMID_END = 25.0


def pyramid():
    return scene(PYRAMID_INERTIA, PYRAMID_OMEGA, PYRAMID, PYRAMID_ORIENTATION)


# -- the laws, written out from the module's statement (not through the code under test) ----------
def _law_motor(speed, command, w):
    u = min(max(command, -w['max_torque']), w['max_torque'])
    band = w.get('speed_band', 0.01 * w['max_speed'])
    if u * speed > 0.0:
        u *= min(max((w['max_speed'] - abs(speed)) / band, 0.0), 1.0)
    return u


def _law_friction(speed, w):
    coulomb = w.get('coulomb', 0.0)
    band = w.get('coulomb_band', 0.01)
    stribeck = w.get('stribeck')

    def dry(a):
        if stribeck is None:
            return coulomb
        return coulomb + (stribeck['static'] - coulomb) * math.exp(-((a / stribeck['speed']) ** 2))

    if abs(speed) >= band:
        level = math.copysign(dry(abs(speed)), speed)
    else:
        level = dry(band) * speed / band
    return w.get('viscous', 0.0) * speed + level


def reference_run(inertia, omega0, orientation, effect, times):
    """
    LSODA on ``[I, G^T Js; Js G, Js] [w'; Omega'] = [-w x H; u - f]`` and ``q' = q ⊗ (w, 0) / 2``.

    ``H = I w + G^T Js Omega`` (Schaub & Junkins' balanced wheels in relative speeds), piece by
    piece between the schedule's starts; the wheel angles ``theta' = Omega`` from 0. Returns the
    rates, the attitudes, the speeds and the angles.
    """
    tensor = np.array(
        [
            [inertia[0], inertia[3], inertia[4]],
            [inertia[3], inertia[1], inertia[5]],
            [inertia[4], inertia[5], inertia[2]],
        ]
    )
    wheels = effect['wheels']
    G = np.array([np.asarray(w['axis'], float) / np.linalg.norm(w['axis']) for w in wheels])
    Js = np.array([w['spin_inertia'] for w in wheels])
    n = len(wheels)
    M = np.zeros((3 + n, 3 + n))
    M[:3, :3], M[:3, 3:], M[3:, :3], M[3:, 3:] = tensor, G.T * Js, Js[:, None] * G, np.diag(Js)
    constant = effect.get('torque', [0.0] * n)
    schedule = effect.get('schedule') or [{'start': 0.0, 'torque': constant}]
    if schedule[0]['start'] > 0.0:
        schedule = [{'start': 0.0, 'torque': [0.0] * n}, *schedule]

    def rhs(t, y, commands):
        w, q, speeds = y[:3], y[3:7], y[7: 7 + n]
        H = tensor @ w + G.T @ (Js * speeds)
        net = [
            _law_motor(s, c, spec) - _law_friction(s, spec)
            for s, c, spec in zip(speeds.tolist(), commands, wheels)
        ]
        rates = np.linalg.solve(M, np.concatenate([-np.cross(w, H), net]))
        q_dot = 0.5 * np.append(q[3] * w + np.cross(q[:3], w), -q[:3] @ w)
        return np.concatenate([rates[:3], q_dot, rates[3:], speeds])

    y = np.concatenate([omega0, orientation, [w.get('speed', 0.0) for w in wheels], np.zeros(n)])
    ends = [segment['start'] for segment in schedule[1:]] + [times[-1]]
    out = np.empty((times.size, y.size))
    for segment, end in zip(schedule, ends):
        inside = (times >= segment['start']) & (times <= end)
        t_eval = np.union1d(times[inside], [end])
        solution = solve_ivp(
            rhs,
            (segment['start'], end),
            y,
            method='LSODA',
            rtol=1e-12,
            atol=1e-14,
            t_eval=t_eval,
            args=(segment['torque'],),
        )
        out[inside] = solution.y.T[np.isin(t_eval, times[inside])]
        y = solution.y[:, -1]
    q = out[:, 3:7] / np.linalg.norm(out[:, 3:7], axis=1, keepdims=True)
    return out[:, :3], q, out[:, 7: 7 + n], out[:, 7 + n:]


# -- conservation ---------------------------------------------------------------------------------
def test_the_inertial_momentum_is_constant_under_any_motor_torques_and_friction():
    """
    R(q) H_B is constant without external torque: motors and friction are internal.

    DOP853 at rtol 1e-12 over 25 s (a few hundred steps, kinks at the bands' edges): the drift
    stays within 1e-10 of |H| (~6 N m s), the local tolerance accumulated over a hundred steps
    (measured: 1e-13).
    """
    p = pyramid().propagator('dop853', **TIGHT)
    assert p.conserved == frozenset({MOMENTUM})
    times = np.linspace(0.0, PYRAMID_END, 251)
    omega, q, x = p.states(times)
    H_N = quaternion.rotate(q, p.momentum_B(omega, x))
    scale = np.linalg.norm(H_N[0])
    np.testing.assert_allclose(H_N, np.broadcast_to(H_N[0], H_N.shape), rtol=0, atol=1e-10 * scale)
    # the wheels do change the body's motion and the energy (the test is not vacuous)
    assert np.linalg.norm(omega[-1] - omega[0]) > 0.05
    energy = p.energy(omega, x)
    assert abs(energy[-1] - energy[0]) > 0.1 * energy[0]


def test_with_no_motor_torque_and_no_friction_each_wheel_keeps_its_axial_momentum():
    """
    With u = f = 0, each wheel's Js (Omega + g . w) is constant, and so is the kinetic energy.

    The relative speeds Omega move with the body's nutation; their absolute momentum does not
    (h' = 0 exactly: the integrator keeps it to rounding). Energy and |H| at rtol 1e-12 over 30 s
    of a tumbling body: 1e-10 relative.
    """
    effect = {
        'wheels': [
            wheel([1.0, 0.0, 0.0], spin_inertia=0.1, speed=50.0),
            wheel([0.0, 1.0, 1.0], spin_inertia=0.05, speed=-80.0),
            wheel([0.2, -0.5, 1.0], spin_inertia=0.07, speed=10.0),
        ]
    }
    s = scene([5.0, 4.0, 3.0, 0.2, 0.1, -0.3], [0.3, -0.6, 0.9], effect, PYRAMID_ORIENTATION)
    p = s.propagator('dop853', **TIGHT)
    assert p.conserved == frozenset({ENERGY, MOMENTUM})
    (wheels,) = p.effects
    times = np.linspace(0.0, 30.0, 301)
    omega, q, x = p.states(times)
    speeds = wheels.wheel_speeds(omega, x)
    axial = wheels.spin_inertias * (speeds + omega @ wheels.axes.T)
    np.testing.assert_allclose(axial, np.broadcast_to(axial[0], axial.shape), rtol=1e-14)
    assert np.ptp(speeds, axis=0).min() > 1e-3  # the relative speeds do move
    energy = p.energy(omega, x)
    np.testing.assert_allclose(energy, energy[0], rtol=1e-10)
    H_N = quaternion.rotate(q, p.momentum_B(omega, x))
    np.testing.assert_allclose(
        H_N, np.broadcast_to(H_N[0], H_N.shape), rtol=0, atol=1e-10 * np.linalg.norm(H_N[0])
    )


def test_the_pyramid_follows_an_independent_integration_in_relative_speeds():
    """
    The effect (absolute momenta h, inertia I - sum Js g g^T) equals LSODA on the mass-matrix form.

    Both at rtol 1e-12 through clipped commands, three schedule pieces, both bands' edges: the
    rates agree to 3e-10 rad/s, the wheel speeds (up to 60 rad/s) to 4e-8 rad/s, the angles (up
    to 1400 rad) to 1e-8 rad, the attitudes to 1e-12 in |q . q_ref| (measured on the two paths:
    1.1e-10, 1.9e-8, 1.5e-9, 4e-16): above either integrator's error at a kink it meets at
    slightly different steps (the worst is the wheel in the Coulomb band, a stiff decay, at
    t = 21 s), far below any modelling difference (a sign, a factor Js, a missed band would show
    at 1e-3 and up).
    """
    times = np.linspace(0.0, PYRAMID_END, 126)
    p = pyramid().propagator('dop853', **TIGHT)
    omega, q, x = p.states(times)
    (wheels,) = p.effects
    speeds = wheels.wheel_speeds(omega, x)
    with np.errstate(under='ignore'):  # LSODA's norms of tiny numbers
        ref_omega, ref_q, ref_speeds, ref_angles = reference_run(
            PYRAMID_INERTIA, PYRAMID_OMEGA, PYRAMID_ORIENTATION, PYRAMID, times
        )
    np.testing.assert_allclose(omega, ref_omega, rtol=0, atol=3e-10)
    np.testing.assert_allclose(speeds, ref_speeds, rtol=0, atol=4e-8)
    np.testing.assert_allclose(wheels.wheel_angles(x), ref_angles, rtol=0, atol=1e-8)
    assert np.abs(ref_angles[-1]).max() > 500.0  # (turned many times)
    # the same rotation: q or -q
    np.testing.assert_allclose(np.abs(np.sum(q * ref_q, axis=1)), 1.0, rtol=0, atol=1e-12)
    # what the scene was built to show: a wheel in its speed band, one crossing zero, one stopped
    assert 59.0 < speeds[:, 3].max() <= 60.0
    assert speeds[:, 1].min() < 0.0 < speeds[:, 1].max()
    assert abs(speeds[-1, 2]) < 0.05


# -- a wheel on a principal axis: closed forms ----------------------------------------------------
I_A = 5.0  # the body's moment about its z axis, the wheel's axis
BODY = [3.0, 4.0, I_A]


def test_a_constant_motor_torque_spins_wheel_and_body_up_in_closed_form():
    """
    Body spinning about z, wheel on z, constant u, no friction.

    w' = -u / (I_a - Js), Omega' = u / Js - w': both linear in t, so DOP853 integrates them to
    rounding (1e-12 rad/s); the attitude, a rotation about z by w0 t - u t^2 / (2 (I_a - Js)),
    to 1e-10 over its 20 s.
    """
    Js, u, w0, speed0 = 0.2, 0.05, 0.3, 10.0
    s = scene(
        BODY,
        [0.0, 0.0, w0],
        {'wheels': [wheel([0.0, 0.0, 2.0], spin_inertia=Js, speed=speed0)], 'torque': [u]},
    )
    p = s.propagator('dop853', **TIGHT)
    times = np.linspace(0.0, 20.0, 41)
    omega, q, x = p.states(times)
    (wheels,) = p.effects
    w_dot = -u / (I_A - Js)
    np.testing.assert_allclose(omega[:, 2], w0 + w_dot * times, rtol=0, atol=1e-12)
    np.testing.assert_allclose(omega[:, :2], 0.0, atol=1e-15)
    np.testing.assert_allclose(
        wheels.wheel_speeds(omega, x)[:, 0], speed0 + (u / Js - w_dot) * times, rtol=0, atol=1e-11
    )
    angle = w0 * times + 0.5 * w_dot * times**2
    expected = np.column_stack([np.zeros((times.size, 2)), np.sin(angle / 2), np.cos(angle / 2)])
    np.testing.assert_allclose(q, expected, rtol=0, atol=1e-10)


def test_the_command_is_clipped_and_a_braking_torque_is_never_limited():
    """
    A command of 10 max_torque acts as max_torque; at max_speed a braking torque acts in full.

    Both linear in t (w' = -u / (I_a - Js)): to rounding.
    """
    Js, limit = 0.2, 0.04
    times = np.linspace(0.0, 5.0, 11)
    clipped = scene(
        BODY,
        [0.0, 0.0, 0.0],
        {
            'wheels': [wheel([0.0, 0.0, 1.0], spin_inertia=Js, max_torque=limit)],
            'torque': [10 * limit],
        },
    )
    omega, _ = clipped.propagator('dop853', **TIGHT)(times)
    np.testing.assert_allclose(omega[:, 2], -limit / (I_A - Js) * times, rtol=0, atol=1e-13)
    braking = scene(
        BODY,
        [0.0, 0.0, 0.0],
        {
            'wheels': [
                wheel(
                    [0.0, 0.0, 1.0], spin_inertia=Js, max_torque=limit, max_speed=30.0, speed=30.0
                )
            ],
            'torque': [-limit],
        },
    )
    omega, _ = braking.propagator('dop853', **TIGHT)(times)
    np.testing.assert_allclose(omega[:, 2], limit / (I_A - Js) * times, rtol=0, atol=1e-13)


def _effective(Js):
    """Return the wheel's effective inertia against a free body: Js (I_a - Js) / I_a."""
    return Js * (I_A - Js) / I_A


def test_viscous_friction_coasts_the_wheel_down_exponentially():
    """
    Body at rest, u = 0: Js_eff Omega' = -b Omega, Omega = Omega_0 exp(-b t / Js_eff).

    The body takes up the momentum: I_a w + Js Omega = Js Omega_0. DOP853 at rtol 1e-12 over four
    time constants: 1e-10 relative.
    """
    Js, b, speed0 = 0.2, 0.01, 100.0
    s = scene(
        BODY,
        [0.0, 0.0, 0.0],
        {'wheels': [wheel([0.0, 0.0, 1.0], spin_inertia=Js, viscous=b, speed=speed0)]},
    )
    p = s.propagator('dop853', **TIGHT)
    times = np.linspace(0.0, 4 * _effective(Js) / b, 81)
    omega, q, x = p.states(times)
    (wheels,) = p.effects
    speed = wheels.wheel_speeds(omega, x)[:, 0]
    expected = speed0 * np.exp(-b * times / _effective(Js))
    np.testing.assert_allclose(speed, expected, rtol=1e-10)
    np.testing.assert_allclose(omega[:, 2], Js * (speed0 - expected) / I_A, rtol=1e-10, atol=1e-15)


def test_coulomb_friction_stops_the_wheel_at_the_closed_form_time_and_it_stays_stopped():
    """
    Body at rest, u = 0, dry friction Fc: the ideal wheel stops at t = Js_eff |Omega_0| / Fc.

    The effect follows the ideal Omega_0 - Fc t / Js_eff exactly until |Omega| reaches the band
    w_c, then decays as w_c exp(-Fc (t - t_1) / (Js_eff w_c)): at the ideal stop it is w_c / e,
    and for 100 s after it stays inside the band. Speeds to 1e-9 rad/s: the motion is linear, then
    exponential, but the step across the band's kink is only as good as DOP853's error control,
    rtol 1e-12 of the wheel's momentum Js |Omega_0| = 10 N m s.

    Stopped, the wheel is a stiff linear decay of rate Fc / (Js_eff w_c) (52 /s here) that DOP853
    steps at its stability bound (|h rate| ~ 6): no chatter, ~100 rate / 6 steps for 100 s, twice
    that bounds them (counted on the reference path). Its dense output inside such steps is not
    error-controlled: from 50 time constants on, the speed is that noise, held to 1e-6 rad/s
    (1e-4 of the band; measured 2e-7).
    """
    Js, Fc, speed0, band = 0.2, 0.1, -50.0, 0.01
    s = scene(
        BODY,
        [0.0, 0.0, 0.0],
        {'wheels': [wheel([0.0, 0.0, 1.0], spin_inertia=Js, coulomb=Fc, speed=speed0)]},
    )
    p = s.propagator('dop853', **TIGHT)
    (wheels,) = p.effects
    effective = _effective(Js)
    t_stop = effective * abs(speed0) / Fc
    t_band = effective * (abs(speed0) - band) / Fc
    sliding = np.linspace(0.0, t_band, 50)
    omega, _, x = p.states(sliding)
    np.testing.assert_allclose(
        wheels.wheel_speeds(omega, x)[:, 0], speed0 + Fc * sliding / effective, rtol=0, atol=1e-9
    )
    omega, _, x = p.states(np.array([t_stop]))
    at_stop = wheels.wheel_speeds(omega, x)[0, 0]
    assert at_stop == pytest.approx(-band / math.e, rel=0, abs=1e-9)
    after = np.linspace(t_stop, t_stop + 100.0, 1001)
    omega, _, x = p.states(after)
    speeds = wheels.wheel_speeds(omega, x)[:, 0]
    assert np.abs(speeds).max() <= band / math.e * (1 + 1e-6)
    assert np.abs(speeds[after > t_stop + 1.0]).max() <= 1e-6
    # the momentum went to the body, where it stays: I_a w = Js (Omega_0 - Omega)
    np.testing.assert_allclose(omega[:, 2], Js * (speed0 - speeds) / I_A, rtol=1e-12)
    if not p.compiled:  # count the reference path's steps in the stopped phase
        rate = Fc / (effective * band)
        p = s.propagator('dop853', **TIGHT)
        p.states(np.array([t_stop]))
        calls = []
        derivative = p.dynamics.derivative
        p.dynamics.derivative = lambda t, y, start: calls.append(t) or derivative(t, y, start)
        p.states(np.array([t_stop, t_stop + 100.0]))
        assert min(calls) >= t_stop - 1.0  # (no restart from t = 0)
        # 12 evaluations a DOP853 step
        assert len(calls) / 12 <= 2 * 100.0 * rate / 6, len(calls)


def test_the_speed_limit_fades_the_motor_out_and_the_wheel_never_passes_max_speed():
    """
    Constant u at full torque, no friction: full torque up to max_speed - band, then scaled.

    In the band Js_eff Omega' = u (max_speed - Omega) / band: Omega = max_speed - band exp(-u (t -
    t_1) / (Js_eff band)), t_1 = Js_eff (max_speed - band - Omega_0) / u; it never reaches
    max_speed. Speeds to 1e-9 rad/s (rtol 1e-12 of the wheel's momentum ~20 N m s, over the
    step across the band's kink). With viscous friction b it settles where the scaled torque
    equals b Omega: u (max - Omega) / band = b Omega, after 26 time constants (to 1e-9).
    """
    Js, u, top, band, speed0 = 0.2, 0.05, 100.0, 2.0, 90.0
    effect = {
        'wheels': [
            wheel(
                [0.0, 0.0, 1.0],
                spin_inertia=Js,
                max_torque=u,
                max_speed=top,
                speed_band=band,
                speed=speed0,
            )
        ],
        'torque': [u],
    }
    p = scene(BODY, [0.0, 0.0, 0.0], effect).propagator('dop853', **TIGHT)
    (wheels,) = p.effects
    effective = _effective(Js)
    t_1 = effective * (top - band - speed0) / u
    times = np.linspace(0.0, t_1 + 20.0, 401)
    omega, _, x = p.states(times)
    speed = wheels.wheel_speeds(omega, x)[:, 0]
    expected = np.where(
        times <= t_1,
        speed0 + u * times / effective,
        top - band * np.exp(-u * np.maximum(times - t_1, 0.0) / (effective * band)),
    )
    np.testing.assert_allclose(speed, expected, rtol=0, atol=1e-9)
    assert top - band < speed[-1] and speed.max() < top
    b = 1e-4
    effect['wheels'][0]['viscous'] = b
    p = scene(BODY, [0.0, 0.0, 0.0], effect).propagator('dop853', **TIGHT)
    omega, _, x = p.states(np.array([t_1 + 200.0]))
    settled = (u * top / band) / (u / band + b)
    assert wheels.wheel_speeds(omega, x)[0, 0] == pytest.approx(settled, rel=1e-9)


# -- commands: torque and speed modes -------------------------------------------------------------
COMMAND_RATE = 10.0
SECOND = 1_000_000_000


def commanded(mode, wheels, inertia=BODY, omega=(0.0, 0.0, 0.0), extra=None, settings=TIGHT):
    """Return a simulation of a commanded wheel scene at COMMAND_RATE, and its wheels effect."""
    s = scene_from_mapping(
        {
            'body': {'inertia': list(inertia)},
            'initial': {'angular_velocity': list(omega)},
            'effects': [
                {'reaction_wheels': {'wheels': wheels, 'mode': mode, 'timeout': 0.5}},
                *(extra or []),
            ],
        }
    )
    simulation = Simulation(s.propagator('dop853', **settings), COMMAND_RATE)
    (effect,) = [e for e, _ in simulation.command_holds if e.name == 'reaction_wheels']
    return simulation, effect


def test_torque_commands_hold_merge_and_time_out_as_an_independent_integration():
    """
    Motor torques commanded by name follow the hold's rules, against LSODA with those torques.

    The pyramid's wheels (friction, clipping) in torque mode, timeout 0.5 s: a command at t = 0
    naming the wheels in another order, zero torque from its timeout (sample 5); one at 0.75 s
    naming one wheel (the others keep the latest command's values), holding from sample 8; a stale
    one refused; none after it, so zero torque from t = 1.25 s (sample 13); one at 2 s until its
    timeout (sample 25). The inputs per interval, written out here from the rules, drive the
    reference (``reference_run``'s schedule); the tolerances are the pyramid test's (both at rtol
    1e-12, kinks met at other steps).
    """
    wheels = [dict(w, name=f'rw{i}') for i, w in enumerate(PYRAMID['wheels'])]
    simulation, effect = commanded('torque', wheels, PYRAMID_INERTIA, PYRAMID_OMEGA)
    hold = effect.hold
    assert effect.receive(0, 'any', ['rw3', 'rw1', 'rw0', 'rw2'], [], [0.15, -0.05, 0.1, 0.5])[0]
    assert effect.receive(750_000_000, '', ['rw2'], [], [-0.2])[0]
    assert effect.receive(500_000_000, '', ['rw0'], [], [1.0]) == (
        False,
        'stale: stamped before the latest accepted command',
    )
    assert effect.receive(2 * SECOND, '', ['rw0', 'rw1', 'rw2', 'rw3'], [], [0, 0.1, 0, -0.1])[0]
    a, b, zero, c = [0.1, -0.05, 0.5, 0.15], [0.1, -0.05, -0.2, 0.15], [0.0] * 4, [0, 0.1, 0, -0.1]
    starts = {0: a, 5: zero, 8: b, 13: zero, 20: c, 25: zero}
    times = np.arange(31) / COMMAND_RATE
    block = simulation.samples(0, 31)
    for k, inputs in starts.items():  # the hold gives exactly these inputs
        np.testing.assert_array_equal(effect.inputs(k / COMMAND_RATE), inputs)
    reference = {
        'wheels': wheels,
        'schedule': [{'start': k / COMMAND_RATE, 'torque': u} for k, u in starts.items()],
    }
    with np.errstate(under='ignore'):  # LSODA's norms of tiny numbers
        ref_omega, ref_q, ref_speeds, ref_angles = reference_run(
            PYRAMID_INERTIA, PYRAMID_OMEGA, [0.0, 0.0, 0.0, 1.0], reference, times
        )
    np.testing.assert_allclose(block.omega_B, ref_omega, rtol=0, atol=3e-10)
    speeds = effect.wheel_speeds(block.omega_B, block.internal)
    np.testing.assert_allclose(speeds, ref_speeds, rtol=0, atol=4e-8)
    np.testing.assert_allclose(effect.wheel_angles(block.internal), ref_angles, rtol=0, atol=1e-8)
    assert dict(hold.refused) == {'stale': 1} and hold.accepted == 3


def test_a_speed_command_is_held_by_the_drives_proportional_loop_then_the_wheel_coasts():
    """
    Speed mode: ``Js_eff Omega' = K (Omega_ref - Omega) - b Omega``, ``K = Js speed_bandwidth``.

    Body at rest, wheel on its principal axis z: ``Omega = Omega_inf + (Omega_0 - Omega_inf)
    exp(-(K + b) t / Js_eff)``, ``Omega_inf = K Omega_ref / (K + b)`` (a proportional loop stops
    short under friction), inside the torque limit throughout; after the command's timeout (0.5 s
    after its stamp 0.2 s, so from sample 7) the drive is off and the wheel coasts,
    ``Omega(t_7) exp(-b (t - t_7) / Js_eff)``. Exponentials: DOP853 at rtol 1e-12 to 1e-9 rad/s.
    """
    Js, bw, b, speed0, ref = 0.2, 2.0, 0.01, 10.0, 30.0
    wheels = [wheel([0.0, 0.0, 1.0], spin_inertia=Js, max_torque=10.0, speed=speed0, viscous=b)]
    wheels[0]['name'] = 'z'
    s = scene_from_mapping(
        {
            'body': {'inertia': BODY},
            'initial': {'angular_velocity': [0.0, 0.0, 0.0]},
            'effects': [
                {
                    'reaction_wheels': {
                        'wheels': wheels,
                        'mode': 'speed',
                        'speed_bandwidth': bw,
                        'timeout': 0.5,
                    }
                }
            ],
        }
    )
    simulation = Simulation(s.propagator('dop853', **TIGHT), COMMAND_RATE)
    ((effect, hold),) = simulation.command_holds
    assert effect.command_field == 'velocity'
    # no command yet: the drive is off (NaN set-point), the wheel coasts
    assert math.isnan(effect.inputs(0.0)[0])
    assert effect.receive(200_000_000, '', ['z'], [ref], [])[0]  # holds from sample 2
    block = simulation.samples(0, 21)
    t = block.times
    speed = effect.wheel_speeds(block.omega_B, block.internal)[:, 0]
    K, effective = Js * bw, _effective(Js)
    coast0 = speed0 * np.exp(-b * np.minimum(t, 0.2) / effective)  # until sample 2
    settle = K * ref / (K + b)
    loop = settle + (coast0 - settle) * np.exp(-(K + b) * np.clip(t - 0.2, 0.0, 0.5) / effective)
    expected = np.where(t <= 0.7, loop, loop * np.exp(-b * np.maximum(t - 0.7, 0.0) / effective))
    np.testing.assert_allclose(speed, expected, rtol=0, atol=1e-9)
    assert np.abs(K * (ref - speed)).max() < 10.0  # inside the torque limit
    # the momentum went to the body: I_a w = Js (Omega_0 - Omega)
    np.testing.assert_allclose(
        block.omega_B[:, 2], Js * (speed0 - speed) / I_A, rtol=1e-10, atol=1e-15
    )
    # the motor torque the drive applies at each sample (its set-point on the interval before)
    u, torque_limited, speed_limited = effect.applied(
        speed[:, None], effect.inputs_before(t)
    )
    on = (t > 0.2) & (t <= 0.7)
    np.testing.assert_allclose(u[on, 0], K * (ref - speed[on]), rtol=1e-15)
    assert not u[~on].any() and not torque_limited.any() and not speed_limited.any()


@pytest.mark.parametrize('mode', ['torque', 'speed'])
def test_one_sample_of_applied_equals_the_array_rule_bit_for_bit(mode):
    """A closed loop's one-sample path (floats) and the block path (arrays): the same numbers."""
    wheels = [
        wheel([1.0, 0.0, 0.0], max_torque=0.5, max_speed=100.0, speed_band=5.0),
        wheel([0.0, 1.0, 0.0], max_torque=2.0, max_speed=50.0),
        wheel([0.0, 0.0, 1.0], max_torque=0.1, max_speed=300.0, speed_band=30.0),
    ]
    _, effect = commanded(mode, wheels)
    rng = np.random.default_rng(5)
    # speeds across each band and beyond the limits, inputs inside and beyond max_torque
    speeds = rng.uniform(-1.05, 1.05, (400, 3)) * np.array([100.0, 50.0, 300.0])
    inputs = rng.uniform(-3.0, 3.0, (400, 3)) * (100.0 if mode == 'speed' else 1.0)
    inputs[::7, 1] = math.nan if mode == 'speed' else 0.0  # a drive off
    block = effect.applied(speeds, inputs)
    assert block[1].any() and block[2].any() and (~block[2]).any()  # both limits met, not always
    for row in range(speeds.shape[0]):
        once = effect.applied(speeds[row:row + 1], inputs[row:row + 1])
        for single, many in zip(once, block):
            np.testing.assert_array_equal(single[0], many[row])


BAD_COMMANDS = {
    'unknown name': ((['rw0', 'rw9'], [], [0.1, 0.2]), "unknown name: 'rw9' (wheels: rw0, rw1)"),
    'repeated name': ((['rw0', 'rw0'], [], [0.1, 0.2]), "repeated name: 'rw0'"),
    'fewer values': ((['rw0', 'rw1'], [], [0.1]), 'wrong length: 2 names and 1 effort values'),
    'no names': (([], [], [0.1]), 'wrong length: 0 names and 1 effort values'),
    'no values': ((['rw0'], [], []), 'wrong length: 1 names and 0 effort values'),
    'both fields': ((['rw0'], [1.0], [0.1]), 'both fields: effort and velocity both given'),
    'wrong mode': ((['rw0'], [1.0], []), 'wrong mode: velocity given to wheels in torque mode'),
    'NaN': ((['rw1', 'rw0'], [], [0.1, math.nan]), 'not finite: a NaN or infinite component'),
    'infinite': ((['rw1'], [], [-math.inf]), 'not finite: a NaN or infinite component'),
}


def test_bad_wheel_commands_are_refused_counted_and_never_reach_the_state():
    wheels = [wheel([1.0, 0.0, 0.0], name='rw0'), wheel([0.0, 1.0, 0.0], name='rw1')]
    simulation, effect = commanded('torque', wheels, omega=(0.1, 0.0, 0.0))
    hold = effect.hold
    for label, (message, reason) in BAD_COMMANDS.items():
        accepted, said = effect.receive(0, '', *message)
        assert not accepted and said.startswith(reason), (label, said)
    assert hold.commands == [] and hold.accepted == 0
    assert dict(hold.refused) == {
        'unknown name': 1,
        'repeated name': 1,
        'wrong length': 3,
        'both fields': 1,
        'wrong mode': 1,
        'not finite': 2,
    }
    # the state is the torque-free one's (no motor torque ever held): the wheels stay as they are
    block = simulation.samples(0, 11)
    np.testing.assert_array_equal(block.omega_B, np.broadcast_to([0.1, 0.0, 0.0], (11, 3)))
    # a speed-mode drive refuses effort
    _, speedy = commanded('speed', wheels)
    assert speedy.receive(0, '', ['rw0'], [], [0.1])[1].startswith(
        'wrong mode: effort given to wheels in speed mode, which take velocity (rad/s)'
    )


def test_wheels_and_a_torque_command_in_one_scene_each_take_their_own_commands():
    """
    The inertial momentum changes by exactly the commanded body torque, whatever the wheels do.

    ``torque_command`` in the inertial frame beside commanded wheels: ``R(q) H_B(t_k) = H_N(0) +
    sum_j tau_j / rate`` (the wheels' torques are internal). DOP853 at rtol 1e-12 over 2 s: to
    1e-11 of |H| (~0.6 N m s).
    """
    wheels = [wheel(axis, spin_inertia=0.05, name=f'rw{i}') for i, axis in enumerate(np.eye(3))]
    simulation, effect = commanded(
        'torque',
        wheels,
        PYRAMID_INERTIA,
        (0.05, -0.03, 0.02),
        extra=[{'torque_command': {'frame': 'inertial', 'timeout': 10.0}}],
    )
    holds = dict(simulation.command_holds)
    assert {e.name for e in holds} == {'reaction_wheels', 'torque_command'}
    (torque_hold,) = [h for e, h in holds.items() if e.name == 'torque_command']
    torque_hold.frame_id = 'world'
    assert effect.receive(0, '', ['rw0', 'rw1', 'rw2'], [], [0.2, -0.1, 0.05])[0]
    assert torque_hold.receive(0, [0.01, 0.0, -0.02], frame_id='world')[0]
    assert effect.receive(SECOND, '', ['rw1'], [], [0.3])[0]
    assert torque_hold.receive(SECOND // 2, [0.0, 0.03, 0.0], frame_id='world')[0]
    block = simulation.samples(0, 21)
    propagator = simulation.propagator
    H_N = quaternion.rotate(block.q_NB, propagator.momentum_B(block.omega_B, block.internal))
    k = np.arange(21)[:, None]
    expected = H_N[0] + np.where(
        k <= 5, k * [0.01, 0.0, -0.02], [0.05, 0.0, -0.1] + (k - 5) * np.array([0.0, 0.03, 0.0])
    ) / COMMAND_RATE
    np.testing.assert_allclose(H_N, expected, rtol=0, atol=1e-11 * np.linalg.norm(H_N[0]))
    # the wheels did move (the test is not vacuous)
    speeds = effect.wheel_speeds(block.omega_B, block.internal)
    assert np.abs(speeds[-1]).min() > 1.0


def test_the_compiled_right_hand_side_equals_the_python_one_in_speed_mode():
    """
    The speed loop (and a drive that is off: a NaN set-point) on random states, both ways.

    Same operations, other order of the torques' sum: within 16 eps of the terms' size.
    """
    if not switch.AVAILABLE:
        require_numba()
    wheels = [dict(w, name=f'rw{i}') for i, w in enumerate(PYRAMID['wheels'])]
    simulation, effect = commanded('speed', wheels, PYRAMID_INERTIA, PYRAMID_OMEGA)
    dynamics = simulation.propagator.dynamics
    rng = np.random.default_rng(41)
    count = 200
    omega = rng.normal(size=(count, 3)) * 10.0 ** rng.uniform(-3, 0, size=(count, 1))
    q = Rotation.random(count, random_state=rng).as_quat()
    speeds = rng.uniform(-70.0, 70.0, size=(count, 4)) * 10.0 ** rng.uniform(-4, 0, (count, 1))
    h = effect.spin_inertias * (speeds + omega @ effect.axes.T)
    angles = rng.uniform(-1e3, 1e3, size=(count, 4))
    states = np.hstack([omega, q, np.stack([h, angles], axis=2).reshape(count, 8)])
    # set-points on [1 s, ...): the first half of the times sees the drive off
    assert effect.receive(SECOND, '', effect.names[:3], [50.0, -20.0, 0.5], [])[0]
    times = np.concatenate([rng.uniform(0.0, 0.9, count // 2), rng.uniform(1.0, 2.0, count // 2)])
    expected = np.array([dynamics.derivative(t, y, t) for t, y in zip(times, states)])
    got = drivers.derivatives(dynamics, times, states)
    size = 10.0 * (1.0 + np.abs(states[:, :9]).max(axis=1, keepdims=True) ** 2)
    assert np.all(np.abs(got - expected) <= 16 * EPS * size), np.abs(got - expected).max()
    # the drive is on in the second half only: the torques differ there
    off = [dynamics.derivative(0.5, y, 0.5) for y in states[count // 2:]]
    assert np.abs(expected[count // 2:, 7] - np.array(off)[:, 7]).max() > 1e-3


# -- the compiled path ----------------------------------------------------------------------------
def test_the_compiled_right_hand_side_equals_the_python_one_for_several_wheels():
    """
    Several wheels (a kernel entry each) on random states, across the bands and the schedule.

    Same operations, other order of the torques' sum: within 16 eps of the terms' size.
    """
    if not switch.AVAILABLE:
        require_numba()
    p = pyramid().propagator('dop853')
    dynamics = p.dynamics
    rng = np.random.default_rng(40)
    count = 400
    omega = rng.normal(size=(count, 3)) * 10.0 ** rng.uniform(-3, 0, size=(count, 1))
    q = Rotation.random(count, random_state=rng).as_quat()
    # wheel momenta for speeds from 0 to past max_speed, and inside the Coulomb band
    speeds = rng.uniform(-70.0, 70.0, size=(count, 4)) * 10.0 ** rng.uniform(-4, 0, (count, 1))
    (wheels,) = dynamics.effects
    h = wheels.spin_inertias * (speeds + omega @ wheels.axes.T)
    angles = rng.uniform(-1e3, 1e3, size=(count, 4))  # (no part of the rates: any value)
    states = np.hstack([omega, q, np.stack([h, angles], axis=2).reshape(count, 8)])
    times = rng.uniform(0.0, 10.0, size=count)
    expected = np.array([dynamics.derivative(t, y, t) for t, y in zip(times, states)])
    got = drivers.derivatives(dynamics, times, states)
    size = 10.0 * (1.0 + np.abs(states).max(axis=1, keepdims=True) ** 2)
    assert np.all(np.abs(got - expected) <= 16 * EPS * size), np.abs(got - expected).max()


def test_the_compiled_run_equals_the_reference_run(monkeypatch):
    """
    The compiled DOP853 and scipy's agree within the scene's accuracy.

    At the default accuracy (rtol 1e-10, atol 1e-12) over 25 s through the bands' kinks, each
    path's error against a run at rtol 1e-13 is ~1e-8 in the wheels' momenta (~4 N m s), ~1e-9 in
    the rates, ~3e-8 in the angles (up to 1200 rad; measured: 8e-9, 6e-10, 2.7e-8). Rounding in a
    few sums moves a step's acceptance at a kink, so their steps part there: they differ by up to
    the sum of their errors, bounded here by 3e-8 (N m s), 3e-9 (rad/s, and the attitude's
    components), 1e-7 (rad).
    """
    if not switch.AVAILABLE:
        require_numba()
    times = np.linspace(0.0, PYRAMID_END, 101)
    runs = []
    for enabled in (True, False):
        monkeypatch.setattr(switch, 'ENABLED', enabled)
        p = pyramid().propagator()
        assert p.compiled is enabled and p.settings == {'rtol': 1e-10, 'atol': 1e-12}
        runs.append(p.states(times))
    tight = pyramid().propagator('dop853', rtol=1e-13, atol=1e-15).states(times)

    def parts(run):  # rates, attitudes, momenta, angles
        return run[0], run[1], run[2][:, 0::2], run[2][:, 1::2]

    for part, bound in zip(range(4), (3e-9, 3e-9, 3e-8, 1e-7)):
        np.testing.assert_allclose(parts(runs[0])[part], parts(runs[1])[part], rtol=0, atol=bound)
        for run in runs:
            np.testing.assert_allclose(
                parts(run)[part], parts(tight)[part], rtol=0, atol=bound / 2
            )


# -- refused input --------------------------------------------------------------------------------
def _with(change):
    effect = {
        'wheels': [wheel([1.0, 0.0, 0.0], speed=5.0), wheel([0.0, 1.0, 0.0])],
        'torque': [0.01, -0.02],
    }
    change(effect)
    return effect


BAD = {
    'zero axis': (
        lambda e: e['wheels'][1].update(axis=[0.0, 0.0, 0.0]),
        r'\.wheels\[1\]\.axis: must not be the zero vector',
    ),
    'non-finite axis': (
        lambda e: e['wheels'][0].update(axis=[float('nan'), 0.0, 1.0]),
        r'\.wheels\[0\]\.axis: every entry must be finite',
    ),
    'axis of two numbers': (
        lambda e: e['wheels'][0].update(axis=[1.0, 0.0]),
        r'\.wheels\[0\]\.axis: expected 3 numbers',
    ),
    'zero spin inertia': (
        lambda e: e['wheels'][0].update(spin_inertia=0.0),
        r'\.wheels\[0\]\.spin_inertia: must be > 0',
    ),
    'negative max torque': (
        lambda e: e['wheels'][1].update(max_torque=-1.0),
        r'\.wheels\[1\]\.max_torque: must be > 0',
    ),
    'zero max speed': (
        lambda e: e['wheels'][0].update(max_speed=0.0),
        r'\.wheels\[0\]\.max_speed: must be > 0',
    ),
    'negative viscous': (
        lambda e: e['wheels'][0].update(viscous=-1e-3),
        r'\.wheels\[0\]\.viscous: must be >= 0',
    ),
    'negative coulomb': (
        lambda e: e['wheels'][1].update(coulomb=-1e-3),
        r'\.wheels\[1\]\.coulomb: must be >= 0',
    ),
    'zero coulomb band': (
        lambda e: e['wheels'][1].update(coulomb_band=0.0),
        r'\.wheels\[1\]\.coulomb_band: must be > 0',
    ),
    'speed band over max speed': (
        lambda e: e['wheels'][0].update(speed_band=2000.0),
        r'\.wheels\[0\]\.speed_band: must not exceed max_speed',
    ),
    'initial speed beyond max speed': (
        lambda e: e['wheels'][0].update(speed=-1500.0),
        r'\.wheels\[0\]\.speed: .*beyond max_speed',
    ),
    'static friction under coulomb': (
        lambda e: e['wheels'][0].update(coulomb=0.01, stribeck={'static': 0.005, 'speed': 1.0}),
        r'\.wheels\[0\]\.stribeck\.static: must be at least coulomb',
    ),
    'stribeck without speed': (
        lambda e: e['wheels'][0].update(stribeck={'static': 0.005}),
        r'\.wheels\[0\]\.stribeck\.speed: missing',
    ),
    'misspelt key': (
        lambda e: e['wheels'][0].update(axes=[1.0, 0.0, 0.0]),
        r"\.wheels\[0\]\.axes: unknown key; did you mean 'axis'",
    ),
    'no wheels': (lambda e: e.update(wheels=[]), r'\.wheels: expected at least 1'),
    'a torque per wheel': (
        lambda e: e.update(torque=[0.1]),
        r'\.torque: expected 2 numbers \(one per wheel\), got 1',
    ),
    'torque and schedule': (
        lambda e: e.update(schedule=[{'start': 0.0, 'torque': [0.0, 0.0]}]),
        r': give either .*not both',
    ),
    'schedule torque per wheel': (
        lambda e: (e.pop('torque'), e.update(schedule=[{'start': 1.0, 'torque': [0.0]}])),
        r'\.schedule\[0\]\.torque: expected 2 numbers',
    ),
    'schedule order': (
        lambda e: (
            e.pop('torque'),
            e.update(
                schedule=[
                    {'start': 2.0, 'torque': [0.0, 0.0]},
                    {'start': 1.0, 'torque': [0.0, 0.0]},
                ]
            ),
        ),
        r'\.schedule\[1\]\.start: segments must start in increasing order',
    ),
    'non-finite torque': (
        lambda e: e.update(torque=[0.0, float('inf')]),
        r'\.torque\[1\]: expected a finite number',
    ),
    'a commanded mode with a torque': (
        lambda e: e.update(mode='torque'),
        r"\.torque: mode torque: the motors take their torque commands on 'wheel_command'; leave "
        'out torque and schedule',
    ),
    'an unknown mode': (
        lambda e: e.update(mode='velocity'),
        r'\.mode: expected one of schedule, torque, speed',
    ),
    'a zero speed bandwidth': (
        lambda e: e.update(speed_bandwidth=0.0),
        r'\.speed_bandwidth: must be > 0',
    ),
    'a zero timeout': (lambda e: e.update(timeout=0.0), r'\.timeout: must be > 0'),
    'two wheels of one name': (
        lambda e: e['wheels'][1].update(name='wheel_0'),
        r"\.wheels\[1\]\.name: 'wheel_0' names wheels\[0\] already",
    ),
    'an empty name': (
        lambda e: e['wheels'][0].update(name=''),
        r'\.wheels\[0\]\.name: expected a non-empty string',
    ),
    'spin inertia beyond the body': (
        lambda e: e['wheels'][0].update(spin_inertia=3.5),
        r'\.wheels: the wheels leave I - sum\(Js g g\^T\) not positive definite',
    ),
}


@pytest.mark.parametrize('label', BAD)
def test_bad_wheels_are_refused_with_their_field_path(label):
    change, message = BAD[label]
    with pytest.raises(ValueError, match=r'effects\[0\]\.reaction_wheels' + message):
        scene(BODY, [0.0, 0.0, 0.1], _with(change))


def test_wheels_that_together_take_the_whole_moment_are_refused_when_the_propagator_is_built():
    """
    Two effects, each fine alone, that together leave I - sum Js g g^T singular.

    Each is checked at load against the body; the sum is checked by the equations of motion.
    """
    half = {'wheels': [wheel([1.0, 0.0, 0.0], spin_inertia=1.5)]}
    s = scene_from_mapping(
        {
            'body': {'inertia': BODY},
            'initial': {'angular_velocity': [0.0, 0.0, 0.1]},
            'effects': [{'reaction_wheels': half}, {'reaction_wheels': half}],
        }
    )
    with pytest.raises(ValueError, match=r'^effects: the wheels leave I - sum\(Js g g\^T\)'):
        s.propagator()
    # an override of the body is checked the same way, with the effect's path
    single = scene(BODY, [0.0, 0.0, 0.1], half)
    with pytest.raises(ValueError, match=r'^effects\[0\]\.reaction_wheels\.wheels: the wheels'):
        single.propagator(inertia=[1.0, 4.0, 5.0])


def test_scenes_with_the_same_wheels_compare_equal():
    assert pyramid().effects == pyramid().effects
    assert pyramid().effects != scene(BODY, [0.0, 0.0, 0.1], _with(lambda e: None)).effects


def test_wheel_states_report_every_wheel_of_every_effect_and_need_one():
    """
    The wheel_states rows: angles, speeds, then motor torques applied, every wheel in scene order.

    Two effects, one scheduled (a torque of 3 max_torque: clipped) and one commanded; the rows
    are the effects' own state and laws (``wheel_speeds``, ``wheel_angles``, ``applied``), the
    effort the input of the interval ending at each sample. A scene without wheels is refused.
    """
    s = scene_from_mapping(
        {
            'body': {'inertia': BODY},
            'initial': {'angular_velocity': [0.01, 0.02, 0.03]},
            'effects': [
                {'reaction_wheels': {'wheels': [wheel([1.0, 0, 0], name='a')], 'torque': [3.0]}},
                {
                    'reaction_wheels': {
                        'wheels': [wheel([0, 1.0, 0], name='b'), wheel([0, 0, 1.0], name='c')],
                        'mode': 'torque',
                    }
                },
                {'wheel_states': {'rate': 5.0}},
            ],
        }
    )
    simulation = Simulation(s.propagator(), COMMAND_RATE, outputs=s.outputs)
    (output,) = simulation.outputs
    assert output.names == ('a', 'b', 'c') and output.layout_options == {'names': ('a', 'b', 'c')}
    ((commanded, _),) = simulation.command_holds
    assert commanded.receive(0, '', ['c', 'b'], [], [0.5, -0.25])[0]
    block = simulation.samples(0, 9)
    rows, picked = block.outputs[0], block.output_positions[0]
    assert picked.tolist() == [0, 2, 4, 6, 8]
    scheduled = simulation.propagator.effects[0]
    x = block.internal[picked]
    speeds = np.hstack(
        [scheduled.wheel_speeds(block.omega_B[picked], x[:, :2]),
         commanded.wheel_speeds(block.omega_B[picked], x[:, 2:])]
    )
    np.testing.assert_array_equal(rows[:, 0:3], x[:, 1::2])
    np.testing.assert_array_equal(rows[:, 3:6], speeds)
    # clipped to max_torque 1; the commanded ones from their first interval (none at sample 0)
    np.testing.assert_array_equal(
        rows[:, 6:9], [[1.0, 0.0, 0.0]] + [[1.0, -0.25, 0.5]] * 4
    )
    with pytest.raises(ValueError, match=r'effects\[0\]\.wheel_states: reports on a '):
        scene_from_mapping(
            {
                'body': {'inertia': BODY},
                'initial': {'angular_velocity': [0.0, 0.0, 0.1]},
                'effects': [{'wheel_states': {}}],
            }
        )
