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

"""Inertia input and validation, invariants, the seed's Duffing analog, regimes and stability."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from torquefree_ros import propagate, RigidBody


def rotated_tensor(moments, rotation):
    R = rotation.as_matrix()
    return R @ np.diag(moments) @ R.T


def test_principal_moments_keep_the_body_frame_exactly():
    body = RigidBody.from_inertia([3.0, 1.0, 2.0])
    assert np.array_equal(body.principal_axes, np.eye(3))
    assert np.array_equal(body.moments, [3.0, 1.0, 2.0])


@pytest.mark.parametrize('form', ['six', 'matrix'])
def test_full_tensor_is_diagonalised_by_a_proper_rotation(form):
    rotation = Rotation.from_rotvec([0.3, -1.1, 0.7])
    T = rotated_tensor([1.0, 2.0, 2.5], rotation)
    inertia = T if form == 'matrix' else [T[0, 0], T[1, 1], T[2, 2], T[0, 1], T[0, 2], T[1, 2]]
    body = RigidBody.from_inertia(inertia)
    E = body.principal_axes
    assert np.linalg.det(E) == pytest.approx(1.0, abs=1e-14)
    # 1e-14: eigh is backward stable, rounding of order eps * |I|
    np.testing.assert_allclose(E @ np.diag(body.moments) @ E.T, T, atol=1e-14)
    np.testing.assert_allclose(np.sort(body.moments), [1.0, 2.0, 2.5], rtol=1e-14)


def test_six_element_order_is_xx_yy_zz_xy_xz_yz():
    body = RigidBody.from_inertia([2.0, 3.0, 4.0, 0.1, 0.2, 0.3])
    np.testing.assert_array_equal(body.tensor, [[2.0, 0.1, 0.2], [0.1, 3.0, 0.3], [0.2, 0.3, 4.0]])


def test_flat_plate_on_the_triangle_bound_is_accepted():
    """
    A flat plate, on the triangle bound, is accepted.

    A flat plate's moments satisfy I3 = I1 + I2 exactly: the limit of a rigid body, not beyond it.
    """
    moments = [1.5, 2.5, 4.0]
    assert moments[2] == moments[0] + moments[1]  # on the bound, exactly in float64
    body = RigidBody.from_inertia(moments)
    np.testing.assert_array_equal(body.moments, moments)
    np.testing.assert_array_equal(body.principal_axes, np.eye(3))
    # the bound itself, not a loose one: 1e-6 beyond it (far above its rounding allowance) is
    # refused
    with pytest.raises(ValueError, match=r'^inertia: .*triangle inequality'):
        RigidBody.from_inertia([1.5, 2.5, 4.0 * (1.0 + 1e-6)])


@pytest.mark.parametrize(
    'inertia, reason',
    [
        ([1.0, float('nan'), 2.0], 'finite'),
        ([1.0, float('inf'), 2.0], 'finite'),
        ([1.0, -2.0, 2.0], 'positive'),
        ([0.0, 1.0, 1.0], 'positive'),
        ([1.0, 2.0, 3.1], 'triangle inequality'),
        ([1.0, 2.0], '3 or 6 numbers'),
        ([1.0, 2.0, 3.0, 4.0], '3 or 6 numbers'),
        ([[1.0, 0.5, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.5]], 'symmetric'),
        ([1.0, 1.0, 1.0, 2.0, 0.0, 0.0], 'positive'),  # indefinite tensor
        ('heavy', 'list of numbers'),
    ],
)
def test_bad_inertia_is_refused_naming_the_argument_and_reason(inertia, reason):
    with pytest.raises(ValueError, match=rf'^inertia: .*{reason}'):
        RigidBody.from_inertia(inertia)


def test_invariants_of_a_known_state():
    body = RigidBody.from_inertia([1.0, 2.0, 3.0])
    w = np.array([1.0, -2.0, 0.5])
    assert body.kinetic_energy(w) == pytest.approx(0.5 * (1 + 8 + 0.75), rel=1e-15)
    assert body.momentum_magnitude(w) == pytest.approx(np.sqrt(1 + 16 + 2.25), rel=1e-15)
    # rotating the body by a quarter turn about z maps its H_B = (1, -4, 1.5) to (4, 1, 1.5)
    q = [0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4)]
    np.testing.assert_allclose(body.angular_momentum_inertial(w, q), [4.0, 1.0, 1.5], atol=1e-15)


def test_momentum_energy_gaps_do_not_cancel_next_to_the_separatrix():
    # H^2 - 2 T I2 for w = (3e-9, 1, 1e-9), I = (1, 2, 3): exactly -1*9e-18 + 3*1e-18 = -6e-18,
    # which the naive difference H^2 - 2 T I2 (both ~4) cannot resolve at all.
    body = RigidBody.from_inertia([1.0, 2.0, 3.0])
    gaps = body.momentum_energy_gaps([3e-9, 1.0, 1e-9])
    assert gaps[1] == pytest.approx(-6e-18, rel=1e-14)


def _five_point_second_derivative(f, t, h):
    return (-f(t + 2 * h) + 16 * f(t + h) - 30 * f(t) + 16 * f(t - h) - f(t - 2 * h)) / (
        12 * h * h
    )


@pytest.mark.parametrize(
    'inertia, omega',
    [
        ([1.0, 2.0, 3.0], [0.3, 0.2, 1.0]),
        ([1.0, 2.0, 3.0], [1.0, 0.3, 0.2]),
        ([3.0, 1.0, 2.5], [0.4, 0.9, -0.3]),
    ],
)
def test_duffing_analog_holds_along_trajectories(inertia, omega):
    """Seed 000: w_i'' + A_i w_i + B_i w_i^3 = 0 and w_i'^2 + A_i w_i^2 + B_i/2 w_i^4 = K_i."""
    body = RigidBody.from_inertia(inertia)
    A, B, K = body.duffing_constants(omega)
    moments = np.asarray(inertia)
    t = np.linspace(0.5, 20.0, 40)
    h = 1e-3

    def rates(times):
        return propagate(inertia, omega, [0, 0, 0, 1], np.atleast_1d(times))[0]

    w = rates(t)
    w_ddot = np.array([_five_point_second_derivative(rates, ti, h)[0] for ti in t])
    # 5-point stencil: truncation ~h^4 |w^(6)| ~ 1e-12, rounding ~ eps/h^2 ~ 2e-10
    np.testing.assert_allclose(w_ddot + A * w + B * w**3, 0.0, atol=2e-9)
    # w' from Euler's equations: I_i w_i' = (I_j - I_k) w_j w_k
    w_dot = np.stack(
        [
            (moments[1] - moments[2]) * w[:, 1] * w[:, 2] / moments[0],
            (moments[2] - moments[0]) * w[:, 2] * w[:, 0] / moments[1],
            (moments[0] - moments[1]) * w[:, 0] * w[:, 1] / moments[2],
        ],
        axis=1,
    )
    np.testing.assert_allclose(
        w_dot**2 + A * w**2 + B / 2 * w**4, np.broadcast_to(K, w.shape), rtol=1e-12, atol=1e-14
    )


def test_duffing_constant_signs_follow_the_seed():
    # seed 000, I1 >= I2 >= I3: B1 > 0, A2 > 0, B2 < 0, B3 > 0; and K2 >= 0 for a physical state
    body = RigidBody.from_inertia([3.0, 2.0, 1.0])
    A, B, K = body.duffing_constants([0.3, 0.5, 0.7])
    assert B[0] > 0 and A[1] > 0 and B[1] < 0 and B[2] > 0 and K[1] >= 0


@pytest.mark.parametrize(
    'inertia, omega, kind',
    [
        ([1.0, 2.0, 3.0], [0.0, 0.0, 0.0], 'at_rest'),
        ([2.0, 2.0, 2.0], [0.1, 0.2, 0.3], 'sphere'),
        ([1.0, 2.0, 3.0], [0.0, 1.0, 0.0], 'pure_spin'),
        ([1.0, 1.0, 2.0], [0.2, 0.1, 1.0], 'axisymmetric_oblate'),
        ([2.0, 1.0, 2.0], [0.2, 1.0, 0.1], 'axisymmetric_prolate'),
        ([1.0, 2.0, 3.0], [0.1, 0.2, 1.0], 'major_axis_polhode'),
        ([1.0, 2.0, 3.0], [1.0, 0.2, 0.1], 'minor_axis_polhode'),
        ([3.0, 4.0, 6.0], [2.0, 0.5, 1.0], 'separatrix'),
    ],
)
def test_regime_classification(inertia, omega, kind):
    assert RigidBody.from_inertia(inertia).classify(omega).kind == kind


@pytest.mark.parametrize(
    'axis, stability', [(0, 'marginally stable'), (1, 'unstable'), (2, 'marginally stable')]
)
def test_pure_spin_stability_follows_seed_002(axis, stability):
    omega = np.zeros(3)
    omega[axis] = 1.5
    regime = RigidBody.from_inertia([1.0, 2.0, 3.0]).classify(omega)
    assert regime.kind == 'pure_spin' and regime.stability == stability
    assert regime.axis == ['minor', 'intermediate', 'major'][axis]


def test_axisymmetric_closed_form_and_precession_rate_of_seed_000():
    IT, I3 = 2.0, 3.5
    w10, w20, w3 = 0.3, -0.2, 1.1
    regime = RigidBody.from_inertia([IT, IT, I3]).classify([w10, w20, w3])
    wp = (I3 / IT - 1.0) * w3
    assert regime.precession_rate == pytest.approx(wp, rel=1e-15)
    assert regime.polhode_period == pytest.approx(2 * np.pi / abs(wp), rel=1e-14)
    t = np.linspace(0.0, 50.0, 101)
    w, _ = propagate([IT, IT, I3], [w10, w20, w3], [0, 0, 0, 1], t)
    expected = np.stack(
        [
            w10 * np.cos(wp * t) - w20 * np.sin(wp * t),
            w20 * np.cos(wp * t) + w10 * np.sin(wp * t),
            np.full_like(t, w3),
        ],
        1,
    )
    # phase wp*t up to ~30 rad: rounding of the phase ~ 30 eps
    np.testing.assert_allclose(w, expected, rtol=0, atol=1e-14)


def test_polhode_period_is_the_period_of_the_rates():
    inertia, omega = [1.0, 2.0, 3.0], [0.3, 0.2, 1.0]
    period = RigidBody.from_inertia(inertia).classify(omega).polhode_period
    w, _ = propagate(inertia, omega, [0, 0, 0, 1], [0.0, 0.5 * period, period])
    # one period is ~10 s of |w| ~ 1 rad/s motion: rounding of u = lambda t + u0 is ~1e-15
    np.testing.assert_allclose(w[2], w[0], atol=1e-14)
    assert not np.allclose(w[1], w[0], atol=1e-3)


@pytest.mark.parametrize('axis', [0, 2])
def test_major_and_minor_axis_spins_stay_in_a_bounded_cone(axis):
    omega = np.full(3, 1e-3)
    omega[axis] = 1.0
    t = np.linspace(0, 200, 2001)
    w, _ = propagate([1.0, 2.0, 3.0], omega, [0, 0, 0, 1], t)
    cone = np.arccos(np.abs(w[:, axis]) / np.linalg.norm(w, axis=1))
    # linear stability (seed 002): the nutation stays within a few times the initial 1.4e-3 rad
    assert cone.max() < 5e-3


def test_intermediate_axis_spin_flips():
    t = np.linspace(0, 100, 2001)
    w, _ = propagate([1.0, 2.0, 3.0], [1e-6, 1.0, 1e-6], [0, 0, 0, 1], t)
    assert w[:, 1].min() < -0.99  # the spin reverses completely (Dzhanibekov)
