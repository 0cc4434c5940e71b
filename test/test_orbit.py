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
The Keplerian orbit and Kepler's equation against independent references.

- Kepler's equation: the residual ``E - e sin E - M`` in 50 digits (mpmath) at float64's floor,
  ``e`` from 0 to ``1 - 1e-12`` and ``M`` near 0 and pi.
- Two-body motion against scipy's DOP853 at rtol 1e-12 over 20 orbits (e = 0, 0.1, 0.9): the
  closed form must lie within the integrator's own error, estimated as its distance from a run
  at rtol 1e-13 (the closed form has no truncation error).
- J2's secular node and perigee rates against a DOP853 integration with the J2 acceleration.
- The compiled kernel against the numpy path to rounding; bad elements refused naming the field.
"""

from __future__ import annotations

import math
import os

import mpmath
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from torquefree_ros.core.checks.schema import FieldError
from torquefree_ros.core.environment import environment_kernels as kernels
from torquefree_ros.core.environment import epochs
from torquefree_ros.core.environment.earth import EQUATORIAL_RADIUS, GM, J2
from torquefree_ros.core.environment.orbit import eccentric_anomaly, KeplerOrbit
from torquefree_ros.core.numerics import kernels as switch

EPS = np.finfo(float).eps
EPOCH = '2026-03-20T12:00:00Z'


def _two_body(t, y):
    r = y[:3]
    return np.concatenate([y[3:], -GM * r / math.sqrt(r @ r) ** 3])


def _two_body_j2(t, y):
    r = y[:3]
    norm2 = r @ r
    norm = math.sqrt(norm2)
    # the J2 acceleration: the gradient of the potential -GM J2 R^2 P2(z/r) / r^3
    factor = -1.5 * J2 * GM * EQUATORIAL_RADIUS**2 / norm**5
    z2 = 5.0 * r[2] ** 2 / norm2
    j2 = factor * np.array([r[0] * (1.0 - z2), r[1] * (1.0 - z2), r[2] * (3.0 - z2)])
    return np.concatenate([y[3:], -GM * r / norm**3 + j2])


@pytest.mark.parametrize('e', [0.0, 1e-8, 0.1, 0.5, 0.9, 0.99, 0.999999, 1.0 - 1e-12])
def test_kepler_equation_is_solved_to_the_floor_of_float64(e):
    rng = np.random.default_rng(41)
    mean_anomaly = np.concatenate([
        rng.uniform(-60.0, 60.0, 3000),
        [0.0, 1e-300, 1e-12, 1e-6, -1e-6, math.pi, -math.pi, math.pi - 1e-9, 2.0 * math.pi],
    ])
    solved = eccentric_anomaly(mean_anomaly, e)
    # the residual of the float64 solution, exactly (50 digits)
    mpmath.mp.dps = 50
    residual = np.array([
        float(abs(mpmath.mpf(E) - mpmath.mpf(e) * mpmath.sin(mpmath.mpf(E)) - mpmath.mpf(M)))
        for E, M in zip(solved.tolist(), mean_anomaly.tolist())
    ])
    # the floor: M's own rounding, and E's (one ulp of E moves the residual by f'(E) ulp(E))
    with np.errstate(under='ignore'):  # M = 1e-300
        slope = (1.0 - e) + 2.0 * e * np.sin(0.5 * solved) ** 2
        floor = np.spacing(np.abs(mean_anomaly)) + slope * np.spacing(np.abs(solved))
        assert np.all(residual <= 2.0 * floor), float(np.max(residual / floor))
    # E stays on M's revolution: E - M = e sin E
    assert np.all(np.abs(solved - mean_anomaly) <= e + 8.0 * np.spacing(np.abs(mean_anomaly)))


@pytest.mark.parametrize('e, semi_major_axis', [(0.0, 7.0e6), (0.1, 8.0e6), (0.9, 7.0e7)])
def test_two_body_motion_matches_dop853_within_the_integrators_own_error(e, semi_major_axis):
    orbit = KeplerOrbit(semi_major_axis, e, 0.9, 0.4, 1.1, 0.3, epoch=EPOCH)
    times = np.linspace(0.0, 20.0 * orbit.period, 401)
    position, velocity = orbit.state(times)
    speed = math.sqrt(GM / semi_major_axis)
    scale = np.array([semi_major_axis] * 3 + [speed] * 3)
    runs = {}
    for rtol in (1e-12, 1e-13):
        with np.errstate(under='ignore'):  # scipy's smallest step: nextafter(0) is subnormal
            solution = solve_ivp(
                _two_body, (0.0, times[-1]), np.concatenate([position[0], velocity[0]]),
                method='DOP853', rtol=rtol, atol=rtol * scale, t_eval=times,
            )
        runs[rtol] = solution.y.T / scale
    closed = np.hstack([position, velocity]) / scale
    # the integrator's error at 1e-12, estimated by the tighter run (measured: 2.5e-11, 9.5e-10
    # and 1.1e-6 for e = 0, 0.1, 0.9, the last at the perigees of a 1:10 ellipse)
    integrator_error = np.abs(runs[1e-12] - runs[1e-13]).max()
    assert np.abs(closed - runs[1e-12]).max() <= 2.0 * integrator_error + 1e-12
    # and the closed form sits nearer the tighter run (measured: 10x nearer)
    assert np.abs(closed - runs[1e-13]).max() <= 0.5 * integrator_error


def test_the_velocity_is_the_derivative_of_the_position_and_the_energy_is_kept():
    orbit = KeplerOrbit(2.4e7, 0.7, 0.5, 1.0, 2.0, 3.0, epoch=EPOCH)
    times = np.linspace(0.0, 3.0 * orbit.period, 997)
    position, velocity = orbit.state(times)
    h = 1e-2  # s: the central difference's truncation (~h^2 |r'''|/6, 1e-7 m/s) is below rounding
    forward, _ = orbit.state(times + h)
    backward, _ = orbit.state(times - h)
    difference = (forward - backward) / (2.0 * h)
    # rounding of the positions (~1e-8 m over 2e7 m) divided by 2h: ~1e-6 m/s
    assert np.abs(difference - velocity).max() <= 1e-5
    energy = 0.5 * (velocity * velocity).sum(axis=1) - GM / np.linalg.norm(position, axis=1)
    assert np.abs(energy / (-GM / (2.0 * orbit.semi_major_axis)) - 1.0).max() <= 1e-14
    momentum = np.cross(position, velocity)
    assert np.abs(momentum / np.linalg.norm(momentum[0]) - momentum[0] / np.linalg.norm(
        momentum[0])).max() <= 1e-14


def _osculating(states):
    r, v = states[:, :3], states[:, 3:]
    h = np.cross(r, v)
    node = np.unwrap(np.arctan2(h[:, 0], -h[:, 1]))
    eccentricity = np.cross(v, h) / GM - r / np.linalg.norm(r, axis=1)[:, None]
    n = np.stack([np.cos(node), np.sin(node), np.zeros_like(node)], axis=1)
    along = np.einsum('ij,ij->i', n, eccentricity)
    normal = h / np.linalg.norm(h, axis=1)[:, None]
    across = np.einsum('ij,ij->i', np.cross(n, eccentricity), normal)
    return node, np.unwrap(np.arctan2(across, along))


@pytest.mark.parametrize('inclination_deg, eccentricity', [(98.19, 0.001), (50.0, 0.05)])
def test_j2_secular_rates_match_an_integration_with_the_j2_acceleration(
    inclination_deg, eccentricity
):
    orbit = KeplerOrbit(7078137.0, eccentricity, math.radians(inclination_deg), 0.5, 1.0, 0.0,
                        epoch=EPOCH, j2=True)
    times = np.linspace(0.0, 5.0 * 86400.0, 4001)
    position, velocity = orbit.state(0.0)
    with np.errstate(under='ignore'):  # scipy's smallest step: nextafter(0) is subnormal
        solution = solve_ivp(_two_body_j2, (0.0, times[-1]),
                             np.concatenate([position, velocity]), method='DOP853', rtol=1e-11,
                             atol=1e-6, t_eval=times)
    node, perigee = _osculating(solution.y.T)
    # the secular rate is the slope of a line fitted through ~75 orbits of the osculating angle
    # (its short-period wobble averages out); mean vs osculating initial elements shift the rate
    # by O(J2) ~ 0.1 %: 1 % allowed
    node_rate = np.polyfit(times, node, 1)[0]
    assert node_rate == pytest.approx(orbit.raan_rate, rel=1e-2)
    if eccentricity > 0.01:  # a near-circular orbit's perigee is not well defined
        perigee_rate = np.polyfit(times, perigee, 1)[0]
        assert perigee_rate == pytest.approx(orbit.perigee_rate, rel=1e-2)
    if inclination_deg > 90.0:
        # 700 km at 98.19 deg is sun-synchronous: the node turns 360 deg a tropical year
        assert orbit.raan_rate == pytest.approx(2.0 * math.pi / (365.2422 * 86400.0), rel=2e-3)


@pytest.mark.skipif(not switch.AVAILABLE and not os.environ.get('CI'),
                    reason='numba (the fast extra) is not installed')
@pytest.mark.parametrize('j2', [False, True])
@pytest.mark.parametrize('e, semi_major_axis', [(0.0, 7.0e6), (0.3, 1.0e7), (0.95, 2.0e8)])
def test_the_compiled_kernel_equals_the_numpy_path(e, semi_major_axis, j2):
    orbit = KeplerOrbit(semi_major_axis, e, 1.2, 0.4, 1.1, 0.3, epoch=EPOCH, j2=j2)
    times = np.concatenate([np.linspace(-3.0, 50.0, 7) * orbit.period, [0.0, 1e-9]])
    position, velocity = orbit.state(times)
    row = orbit.kernel_row()
    kernel = kernels.kernel('kepler_state')
    out = np.empty(6)
    for i, t in enumerate(times):
        kernel(t, row, out)
        # the same operations; libm's and numpy's sin/cos may differ in the last bit (1 ulp of
        # an angle is ~ulp(M) rad, times a, 50 orbits: ~1e-12 relative)
        assert np.abs(out[:3] - position[i]).max() <= 64 * EPS * (semi_major_axis * 50.0)
        assert np.abs(out[3:] - velocity[i]).max() <= 64 * EPS * 50.0 * np.linalg.norm(velocity[i])


@pytest.mark.skipif(not switch.AVAILABLE and not os.environ.get('CI'),
                    reason='numba (the fast extra) is not installed')
@pytest.mark.parametrize('j2', [False, True])
def test_a_place_takes_the_kernel_at_sample_times_and_agrees_with_numpy(j2, monkeypatch):
    """``Place.state`` (the sensors' and outputs' orbit) on both paths, any shape of times."""
    from torquefree_ros.core.environment.place import Place

    orbit = KeplerOrbit(6.9e6, 0.01, 1.7, 0.4, 1.1, 0.3, epoch=EPOCH, j2=j2)
    place = Place(orbit, start=orbit.epoch + 1234.5)
    times = np.linspace(0.0, 3.0 * orbit.period, 12).reshape(3, 4)
    monkeypatch.setattr(switch, 'ENABLED', True)
    position, velocity = place.state(times)
    single = place.state(7.25)
    monkeypatch.setattr(switch, 'ENABLED', False)
    reference = place.state(times)
    assert position.shape == velocity.shape == (3, 4, 3) and single[0].shape == (3,)
    # as the kernel test above: the same operations, libm's and numpy's sin/cos to the last bit
    assert np.abs(position - reference[0]).max() <= 64 * EPS * 6.9e6 * 3.0
    assert np.abs(velocity - reference[1]).max() <= 64 * EPS * 3.0 * 8e3
    assert np.abs(single[0] - place.state(7.25)[0]).max() <= 64 * EPS * 6.9e6


def test_the_epoch_is_a_utc_instant():
    orbit = KeplerOrbit(7.0e6, epoch='2026-03-20T12:00:00Z')
    assert orbit.epoch == epochs.utc_seconds('2026-03-20T12:00:00+00:00')
    # 7 leap days in 2000-2024; March 20 is 78 days after January 1
    assert orbit.epoch == (26 * 365 + 7 + 78) * 86400.0
    assert KeplerOrbit(7.0e6, epoch=orbit.epoch).epoch == orbit.epoch
    assert epochs.utc_datetime(orbit.epoch).isoformat() == '2026-03-20T12:00:00+00:00'


@pytest.mark.parametrize('fields, path, words', [
    ({'semi_major_axis': -7.0e6}, 'orbit.semi_major_axis', 'must be > 0'),
    ({'semi_major_axis': 6.0e6}, 'orbit.semi_major_axis', "Earth's equatorial radius"),
    ({'semi_major_axis': math.inf}, 'orbit.semi_major_axis', 'finite'),
    ({'eccentricity': 1.0}, 'orbit.eccentricity', 'must be < 1'),
    ({'eccentricity': 1.5}, 'orbit.eccentricity', 'must be < 1'),
    ({'eccentricity': -0.1}, 'orbit.eccentricity', 'must be >= 0'),
    ({'eccentricity': 0.2}, 'orbit.eccentricity', 'inside the Earth'),
    ({'eccentricity': math.nan}, 'orbit.eccentricity', 'finite'),
    ({'inclination': 4.0}, 'orbit.inclination', 'must be <= 3.14159'),
    ({'raan': math.nan}, 'orbit.raan', 'finite'),
    ({'mean_anomaly': 'zero'}, 'orbit.mean_anomaly', 'finite number'),
    ({'epoch': '20 March 2026'}, 'orbit.epoch', 'ISO 8601'),
    ({'epoch': math.inf}, 'orbit.epoch', 'finite'),
    ({'j2': 'yes'}, 'orbit.j2', ''),
])
def test_bad_elements_are_refused_naming_the_field(fields, path, words):
    elements = {'semi_major_axis': 7.0e6, 'eccentricity': 0.01, 'epoch': EPOCH, **fields}
    with pytest.raises(FieldError) as raised:
        KeplerOrbit(**elements)
    assert raised.value.path == path
    assert words in str(raised.value)


def test_an_orbit_mapping_is_checked_with_its_scene_path():
    orbit = KeplerOrbit.from_mapping(
        {'epoch': EPOCH, 'semi_major_axis': 6878137.0, 'inclination': 1.7}, 'scene.orbit'
    )
    assert orbit.eccentricity == 0.0 and not orbit.j2
    with pytest.raises(FieldError, match=r'scene\.orbit\.semi_major_axis: missing'):
        KeplerOrbit.from_mapping({'epoch': EPOCH}, 'scene.orbit')
    with pytest.raises(FieldError, match=r'scene\.orbit\.semimajor_axis: unknown key; did you'):
        KeplerOrbit.from_mapping({'epoch': EPOCH, 'semimajor_axis': 7e6}, 'scene.orbit')
