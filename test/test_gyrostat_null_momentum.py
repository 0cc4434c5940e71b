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
Coasting wheels whose absolute momenta cancel, ``sum h_i g_i = 0``: the free body with ``I_s``.

``I_s = I - sum Js_i g_i g_i^T``; ``auto`` runs the exact gyrostat, whose rates and attitude are
the ``analytic`` propagator's with ``I_s`` and whose wheel angles are
``theta_i = (h_i / Js_i) t - g_i . ∫ w dt`` (``h_i`` constant, the relative speed not). Held to
DOP853 on the wheels' own equations at rtol 1e-13, and to the conservation laws.
"""

from conftest import require_numba
import numpy as np
import pytest
from torquefree_ros.core.effects.actuators import ReactionWheels
from torquefree_ros.core.frames import quaternion
from torquefree_ros.core.numerics import kernels as switch
from torquefree_ros.core.propagators import motion_regime
from torquefree_ros.core.propagators.analytic import AnalyticPropagator
from torquefree_ros.core.propagators.gyrostat import free_gyrostat, spin_less_inertia
from torquefree_ros.core.run.accuracy import trajectory_errors
from torquefree_ros.core.scene.loader import scene_from_mapping

Q0 = [0.1, 0.2, 0.3, 0.9273618495495703]  # a unit quaternion (x, y, z, w)
W0 = [0.3, 0.5, -0.4]
TIMES = np.linspace(0.0, 20.0, 41)
#: over 20 s DOP853 at rtol 1e-13 is within ~1e-12 of the truth in the rates, the attitude and the
#: angles (measured: 1e-13 to 7e-13, angles up to ~1200 rad); a wrong sign, frame or inertia
#: moves them by 1e-3 or more
AGREEMENT = 5e-12


def wheel(axis, spin_inertia, speed):
    """Return one frictionless wheel with no motor torque (a coasting wheel)."""
    return {
        'axis': list(axis),
        'spin_inertia': spin_inertia,
        'max_torque': 0.1,
        'max_speed': 1e4,
        'speed': float(speed),
    }


def scene(inertia, omega, wheels):
    return scene_from_mapping(
        {
            'body': {'inertia': list(inertia)},
            'initial': {'angular_velocity': list(omega), 'orientation': Q0},
            'effects': [{'reaction_wheels': {'wheels': wheels}}],
        }
    )


def at_inertial_rest(axis, spin_inertia, omega, h=0.0):
    """Return a wheel whose absolute axial momentum is ``h``: ``Omega = h / Js - g . w0``."""
    g = np.asarray(axis, float) / np.linalg.norm(axis)
    return wheel(axis, spin_inertia, h / spin_inertia - g @ np.asarray(omega))


def pyramid(spin_inertia, omega):
    """Return four wheels at 54.74 deg elevation with momenta in the null space: ±3 N m s."""
    elevation = np.radians(54.74)
    wheels = []
    for azimuth, h in zip(np.radians([0.0, 90.0, 180.0, 270.0]), (3.0, -3.0, 3.0, -3.0)):
        axis = [
            np.cos(elevation) * np.cos(azimuth),
            np.cos(elevation) * np.sin(azimuth),
            np.sin(elevation),
        ]
        wheels.append(at_inertial_rest(axis, spin_inertia, omega, h))
    return wheels


SCENES = {
    # one wheel with h = 0 (still in inertial space about its axis): I_s = diag(1, 2, 2.8)
    'a wheel at inertial rest': ([1.0, 2.0, 3.0], W0, [at_inertial_rest([0, 0, 1], 0.2, W0)]),
    # two wheels on opposite axes with equal h_i = 2: h g - h g = 0 exactly
    'opposite axes, equal momenta': ([1.0, 2.0, 3.0], W0, [
        at_inertial_rest([0, 0, 1], 0.2, W0, 2.0), at_inertial_rest([0, 0, -1], 0.2, W0, 2.0)]),
    # a pyramid's null motion: sum h_i g_i is a few rounding units of 12 N m s, not zero
    'a pyramid in null motion': ([1.0, 2.0, 3.0], W0, pyramid(0.05, W0)),
    # I_s = diag(1.8, 2, 1): triaxial from an axisymmetric body
    'across the symmetry axis': ([2.0, 2.0, 1.0], [0.5, 0.6, -0.3], [
        at_inertial_rest([1, 0, 0], 0.2, [0.5, 0.6, -0.3])]),
    # I_s = diag(2, 2, 0.8): axisymmetric, a uniform precession
    'on the symmetry axis': ([2.0, 2.0, 1.0], [0.5, 0.6, -0.3], [
        at_inertial_rest([0, 0, 1], 0.2, [0.5, 0.6, -0.3])]),
    # I_s = 2 E: every rate is steady
    'a spherical I_s': ([2.2, 2.0, 2.0], W0, [at_inertial_rest([1, 0, 0], 0.2, W0)]),
    # a spin about a principal axis of I_s: steady
    'a steady spin': ([1.0, 2.0, 3.0], [0.0, 0.7, 0.0], [
        at_inertial_rest([0, 0, 1], 0.2, [0.0, 0.7, 0.0])]),
}


@pytest.fixture(params=['compiled', 'reference'])
def kernel_path(request, monkeypatch):
    """Run a test on both paths: numba's kernels and the numpy reference."""
    if request.param == 'compiled' and not switch.AVAILABLE:
        require_numba()
    monkeypatch.setattr(switch, 'ENABLED', request.param == 'compiled')
    return request.param


def spin_less(s):
    effect = s.effects[0]
    return spin_less_inertia(np.diag(s.inertia) - effect.spin_inertia_B())


@pytest.mark.parametrize('label', sorted(SCENES))
def test_null_momentum_wheels_follow_the_integrated_reference(label, kernel_path):
    inertia, omega, wheels = SCENES[label]
    s = scene(inertia, omega, wheels)
    exact_path = s.propagator()
    assert exact_path.name == 'gyrostat' and exact_path.rotor_momentum == 0.0
    w, q, x = exact_path.states(TIMES)
    w_ref, q_ref, x_ref = s.propagator('dop853', rtol=1e-13, atol=1e-15).states(TIMES)
    rate_error, attitude_error = trajectory_errors(w, q, w_ref, q_ref)
    assert rate_error.max() <= AGREEMENT and attitude_error.max() <= AGREEMENT
    np.testing.assert_allclose(x, x_ref, rtol=0, atol=AGREEMENT * max(1.0, np.abs(x_ref).max()))


@pytest.mark.parametrize('label', sorted(SCENES))
def test_the_body_is_the_analytic_free_body_with_the_spin_less_inertia(label):
    """Rates and attitude are the ``analytic`` propagator's with ``I_s``, bit for bit."""
    inertia, omega, wheels = SCENES[label]
    s = scene(inertia, omega, wheels)
    w, q = s.propagator()(TIMES)
    w_free, q_free = AnalyticPropagator(spin_less(s), omega, Q0)(TIMES)
    np.testing.assert_array_equal(w, w_free)
    np.testing.assert_array_equal(q, q_free)


@pytest.mark.parametrize('label', sorted(SCENES))
def test_momenta_energy_and_inertial_momentum_are_conserved(label, kernel_path):
    """
    ``h_i`` constant bit for bit; ``w . I_s w`` and ``R(q) I_s w`` (``sum h_i g_i = 0``) constant.

    Relative to their size, to 1e-14: the free body's closed form keeps them to a few rounding
    units (the rates' and quaternion's own rounding over 20 s).
    """
    inertia, omega, wheels = SCENES[label]
    s = scene(inertia, omega, wheels)
    propagator = s.propagator()
    w, q, x = propagator.states(TIMES)
    momenta = x[:, 0::2]
    np.testing.assert_array_equal(momenta, np.broadcast_to(propagator.x0[0::2], momenta.shape))
    tensor = spin_less(s).tensor
    momentum_B = w @ tensor
    energy = np.einsum('ij,ij->i', w, momentum_B)
    np.testing.assert_allclose(energy, energy[0], rtol=1e-14)
    momentum_N = quaternion.rotate(q, momentum_B)
    size = np.linalg.norm(momentum_N[0])
    assert np.abs(momentum_N - momentum_N[0]).max() <= 1e-14 * size


def test_the_relative_speeds_change_while_the_absolute_momenta_hold():
    """
    ``Omega_i = h_i / Js_i - g_i . w`` moves with the body's rate along ``g_i``.

    So a wheel's angle is not ``Omega_i(0) t``: at a wheel on axis z of a body circling the
    major axis of ``I_s = diag(1, 2, 2.8)`` the difference reaches 0.58 rad in 20 s.
    """
    inertia, omega, wheels = SCENES['a wheel at inertial rest']
    s = scene(inertia, omega, wheels)
    w, _, x = s.propagator().states(TIMES)
    effect = s.propagator().effects[0]
    speeds = effect.wheel_speeds(w, x)[:, 0]
    assert np.ptp(speeds) > 0.1  # rad/s: w3 swings through about +-0.4 rad/s
    np.testing.assert_allclose(speeds, -w[:, 2], rtol=0, atol=1e-15)  # h = 0: Omega = -w3
    assert np.abs(x[:, 1] - speeds[0] * TIMES).max() > 0.5


def test_cancelling_relative_momenta_are_a_gyrostat_not_the_free_body():
    """
    Two wheels counter-rotating on one axis: ``sum Js Omega_i g_i = 0``, ``h = 2 Js (g . w0) g``.

    The absolute momenta add to ``Js (Omega + g.w) - Js (Omega - g.w)`` along ``g``: the body is
    the gyrostat with that ``h``, solved exactly, and it follows the integrated reference.
    """
    Js, speed = 0.2, 30.0
    s = scene([1.0, 2.0, 3.0], W0, [wheel([0, 0, 1], Js, speed), wheel([0, 0, 1], Js, -speed)])
    found = free_gyrostat(s.inertia, s.effects, np.array(W0))
    assert found.axis == 2 and found.momentum == pytest.approx(2.0 * Js * W0[2], rel=1e-15)
    propagator = s.propagator()
    assert propagator.name == 'gyrostat' and propagator.rotor_momentum != 0.0
    w, q, x = propagator.states(TIMES)
    w_ref, q_ref, x_ref = s.propagator('dop853', rtol=1e-13, atol=1e-15).states(TIMES)
    rate_error, attitude_error = trajectory_errors(w, q, w_ref, q_ref)
    assert rate_error.max() <= AGREEMENT and attitude_error.max() <= AGREEMENT
    np.testing.assert_allclose(x, x_ref, rtol=0, atol=AGREEMENT * np.abs(x_ref).max())


def test_a_momentum_sum_above_its_rounding_is_not_taken_for_zero():
    """``|sum h_i g_i|`` above 4 rounding units of ``sum |h_i|`` keeps the gyrostat's ``h``."""
    h = 1e-12  # N m s: far above 4 eps x 4 N m s ~ 4e-15
    wheels = [
        at_inertial_rest([0, 0, 1], 0.2, W0, 2.0 + h),
        at_inertial_rest([0, 0, -1], 0.2, W0, 2.0),
    ]
    s = scene([1.0, 2.0, 3.0], W0, wheels)
    found = free_gyrostat(s.inertia, s.effects, np.array(W0))
    assert found.momentum == pytest.approx(h, rel=1e-3)


def test_the_regime_is_the_free_body_s_with_the_spin_less_inertia():
    inertia, omega, wheels = SCENES['a wheel at inertial rest']
    s = scene(inertia, omega, wheels)
    regime = motion_regime(s.propagator())
    assert regime == spin_less(s).classify(np.array(omega))
    # the locked body (1, 2, 3) and I_s (1, 2, 2.8) differ in energy ratio: not the same regime
    assert regime != s.propagator().body.classify(np.array(omega))


def test_coasting_problem_still_refuses_what_does_not_coast():
    """A motor torque or friction: the wheels' momenta change, and DOP853 runs them."""
    moving = scene([1.0, 2.0, 3.0], W0, [dict(at_inertial_rest([0, 0, 1], 0.2, W0), viscous=1e-9)])
    assert isinstance(moving.effects[0], ReactionWheels)
    assert moving.propagator().name == 'dop853'
