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
Scenes on an orbit (issue 41): the ``orbit:`` section, the torques and sensors of the environment.

The references never go through the code under test: positions from Kepler's equation solved
here by bisection, the field from ppigrf (a second IGRF implementation) rotated by the tested
Earth frames, rotations by scipy, the eclipse from the tangent cones in closed form, the momentum
law by quadrature, the environment held per window against continuous evaluation (the compiled
environment kernels, called at every stage of scipy's DOP853).
"""

import datetime
import math
import pickle

from conftest import require_numba
import numpy as np
from numpy.polynomial.chebyshev import chebval
import pytest
from scipy.integrate import simpson, solve_ivp
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation
from torquefree_ros import Plant
from torquefree_ros.bag.layouts import LAYOUTS
from torquefree_ros.core.environment import earth, environment_kernels, epochs, magnetic, sun
from torquefree_ros.core.environment.earth import EQUATORIAL_RADIUS, GM
from torquefree_ros.core.environment.place import NODES, Place, QUANTITIES, WINDOW
from torquefree_ros.core.numerics import kernels as switch
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import load_scene, scene_from_mapping, SceneError

EPOCH = '2026-03-20T12:00:00Z'
#: a 500 km orbit, inclined, slightly eccentric
LEO = {
    'epoch': EPOCH,
    'semi_major_axis': 6878137.0,
    'eccentricity': 0.001,
    'inclination': 1.7,
    'raan': 0.3,
    'argument_of_perigee': 0.5,
    'mean_anomaly': 0.2,
}
INERTIA = [0.03, 0.035, 0.01]  # a 3U-class body, kg m^2
ISS_TLE = [
    '1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927',
    '2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537',
]


def scene(effects, orbit=LEO, omega=(0.1, -0.05, 0.12), orientation=(0.0, 0.0, 0.0, 1.0), **extra):
    data = {
        'body': {'inertia': list(INERTIA)},
        'initial': {'angular_velocity': list(omega), 'orientation': list(orientation)},
        'effects': effects,
        **extra,
    }
    if orbit is not None:
        data['orbit'] = orbit
    return scene_from_mapping(data, source='s.yaml')


def kepler_position(elements, t):
    """Position (m) ``t`` s after the epoch: Kepler's equation by bisection, scipy's rotations."""
    a, e = elements['semi_major_axis'], elements.get('eccentricity', 0.0)
    n = math.sqrt(GM / a**3)
    positions = []
    for time in np.atleast_1d(t):
        mean = math.remainder(elements.get('mean_anomaly', 0.0) + n * time, 2.0 * math.pi)
        anomaly = brentq(lambda E: E - e * math.sin(E) - mean, -math.pi, math.pi, xtol=1e-15)
        perifocal = a * np.array(
            [math.cos(anomaly) - e, math.sqrt(1.0 - e * e) * math.sin(anomaly), 0.0]
        )
        turn = Rotation.from_euler(
            'ZXZ',
            [
                elements.get('raan', 0.0),
                elements.get('inclination', 0.0),
                elements.get('argument_of_perigee', 0.0),
            ],
        )
        positions.append(turn.apply(perifocal))
    return np.array(positions)


def ppigrf_inertial(position_N, instant):
    """IGRF-14 at an inertial position (T, inertial): ppigrf's geocentric field, rotated here."""
    ppigrf = pytest.importorskip('ppigrf')
    matrix = earth.earth_fixed_matrix(instant)  # r_EF = W r_N (tested against SOFA)
    x, y, z = matrix @ position_N
    r = math.sqrt(x * x + y * y + z * z)
    colatitude, longitude = math.acos(z / r), math.atan2(y, x)
    when = (epochs.J2000 + datetime.timedelta(seconds=float(instant))).replace(tzinfo=None)
    with np.errstate(all='ignore'):  # ppigrf's arithmetic
        radial, south, east = ppigrf.igrf_gc(
            r / 1e3, math.degrees(colatitude), math.degrees(longitude), when
        )
    # geocentric r, theta (south), phi (east) unit vectors in the Earth-fixed frame
    st, ct, sp, cp = math.sin(colatitude), math.cos(colatitude), math.sin(longitude), math.cos(
        longitude
    )
    up = np.array([st * cp, st * sp, ct])
    southward = np.array([ct * cp, ct * sp, -st])
    eastward = np.array([-sp, cp, 0.0])
    field_EF = 1e-9 * (
        float(np.ravel(radial)[0]) * up
        + float(np.ravel(south)[0]) * southward
        + float(np.ravel(east)[0]) * eastward
    )
    return matrix.T @ field_EF


# -- the orbit: section ---------------------------------------------------------------------------
def test_an_orbit_section_loads_elements_a_tle_and_a_start():
    s = scene([], orbit={'epoch': EPOCH, 'semi_major_axis': 7.0e6})
    place = s.orbit
    assert place.start == epochs.utc_seconds(EPOCH) and place.offset == 0.0
    assert place.orbit.eccentricity == 0.0 and place.orbit.j2 is False
    assert place.start_path == 'orbit.epoch'
    later = scene([], orbit={**LEO, 'j2': True, 'start': '2026-03-20T13:00:00Z'}).orbit
    assert later.offset == 3600.0 and later.start_path == 'orbit.start' and later.orbit.j2
    np.testing.assert_array_equal(later.state(0.0)[0], later.orbit.state(3600.0)[0])
    tle = scene([], orbit={'tle': ISS_TLE}).orbit
    assert tle.start == tle.orbit.epoch and tle.start_path == 'orbit.tle'
    assert 'TLE 25544' in tle.describe() and 'Keplerian a 6878.1 km' in scene([]).orbit.describe()
    assert scene([]) == scene([]) and hash(scene([])) == hash(scene([]))
    assert scene([]) != scene([], orbit={**LEO, 'start': '2026-03-21T00:00:00Z'})


def test_a_scene_file_takes_an_unquoted_yaml_timestamp(tmp_path):
    path = tmp_path / 'leo.yaml'
    path.write_text(
        'body: {inertia: [0.03, 0.035, 0.01]}\n'
        'initial: {angular_velocity: [0.1, 0.0, 0.0]}\n'
        'orbit: {epoch: 2026-03-20T12:00:00Z, semi_major_axis: 6878137.0, '
        'start: 2026-03-20 12:30:00}\n'
    )
    place = load_scene(path).orbit
    assert place.start == epochs.utc_seconds(EPOCH) + 1800.0


def test_without_an_orbit_and_with_one_but_nothing_reading_it_the_scene_is_as_before(monkeypatch):
    """Promise 3: a torque-free scene stays exact, and an orbit nobody reads is never evaluated."""
    plain = scene([{'imu': {}}], orbit=None)
    assert plain.orbit is None and plain.propagator().name == 'analytic'
    placed = scene([{'imu': {}}, {'pose': {}}])
    for name in ('state', 'field_N', 'sun_N', 'chebyshev'):
        monkeypatch.setattr(Place, name, lambda *a, **k: pytest.fail('the orbit was evaluated'))
    propagator = placed.propagator()
    assert propagator.name == 'analytic'
    simulation = Simulation(propagator, 10.0, outputs=placed.outputs)
    expected = Simulation(plain.propagator(), 10.0, outputs=plain.outputs).samples(0, 50)
    block = simulation.samples(0, 50)
    np.testing.assert_array_equal(block.q_NB, expected.q_NB)
    np.testing.assert_array_equal(block.outputs[0], expected.outputs[0])


GOOD_TLE_2 = ISS_TLE[1]
BAD_CHECKSUM = ISS_TLE[0][:-1] + '0'


@pytest.mark.parametrize(
    'orbit, effects, where, reason',
    [
        ({'epoch': EPOCH, 'semi_major_axis': -7e6}, [], 'orbit.semi_major_axis', 'must be > 0'),
        ({'epoch': EPOCH, 'semi_major_axis': 6e6}, [], 'orbit.semi_major_axis', "Earth's"),
        ({**LEO, 'eccentricity': 1.0}, [], 'orbit.eccentricity', 'must be < 1'),
        ({**LEO, 'eccentricity': 0.5}, [], 'orbit.eccentricity', 'inside the Earth'),
        ({**LEO, 'eccentricity': -0.1}, [], 'orbit.eccentricity', 'must be >= 0'),
        ({**LEO, 'inclination': 4.0}, [], 'orbit.inclination', 'must be <= 3.14159'),
        ({**LEO, 'raan': float('nan')}, [], 'orbit.raan', 'finite number'),
        ({**LEO, 'epoch': 'yesterday'}, [], 'orbit.epoch', 'ISO 8601'),
        ({'semi_major_axis': 7e6}, [], 'orbit.epoch', 'missing'),
        ({'epoch': EPOCH}, [], 'orbit.semi_major_axis', 'missing'),
        ({**LEO, 'inclinaton': 1.0}, [], 'orbit.inclinaton', "did you mean 'inclination'"),
        ({**LEO, 'j2': 'yes'}, [], 'orbit.j2', 'true or false'),
        ({**LEO, 'start': 'noon'}, [], 'orbit.start', 'ISO 8601'),
        ({'tle': [BAD_CHECKSUM, GOOD_TLE_2]}, [], 'orbit.tle.line1', 'checksum'),
        ({'tle': ISS_TLE[:1]}, [], 'orbit.tle', 'the two lines of a TLE'),
        ({'tle': ISS_TLE, 'semi_major_axis': 7e6}, [], 'orbit.semi_major_axis', 'not both'),
        ([1, 2], [], 'orbit', 'expected a mapping'),
        # the field model's years: the start, wherever it comes from
        (
            {**LEO, 'epoch': '2031-01-01T00:00:00Z'},
            [{'residual_dipole': {'dipole': [0.1, 0, 0]}}],
            'orbit.epoch',
            'IGRF-14 covers 1900.0 to 2030.0',
        ),
        (
            {**LEO, 'start': '1899-12-31T00:00:00Z'},
            [{'magnetometer': {}}],
            'orbit.start',
            'IGRF-14 covers',
        ),
        # effects and outputs that read the environment
        (None, [{'residual_dipole': {'dipole': [0.1, 0, 0]}}], 'effects[0].residual_dipole',
         "needs the scene's orbit"),
        (None, [{'imu': {}}, {'magnetometer': {}}], 'effects[1].magnetometer',
         "needs the scene's orbit"),
        (None, [{'sun_sensor': {}}], 'effects[0].sun_sensor', "needs the scene's orbit"),
        (None, [{'orbit': {}}], 'effects[0].orbit', "needs the scene's orbit"),
        (None, [{'gravity_gradient': {}}], 'effects[0].gravity_gradient.radius', 'missing'),
        (LEO, [{'gravity_gradient': {'radius': 7e6}}], 'effects[0].gravity_gradient.radius',
         "the scene's orbit gives"),
        (LEO, [{'gravity_gradient': {'mean_motion': 1e-3}}],
         'effects[0].gravity_gradient.mean_motion', "the scene's orbit gives"),
        (LEO, [{'gravity_gradient': {'argument_of_latitude': 0.3}}],
         'effects[0].gravity_gradient.argument_of_latitude', "the scene's orbit gives"),
        (LEO, [{'residual_dipole': {'dipole': [0.1, float('inf'), 0]}}],
         'effects[0].residual_dipole.dipole', 'finite'),
        (LEO, [{'residual_dipole': {}}], 'effects[0].residual_dipole.dipole', 'missing'),
        (LEO, [{'residual_dipole': {'dipole': [1, 0, 0], 'field': 'wmm'}}],
         'effects[0].residual_dipole.field', 'expected one of igrf, dipole'),
        (LEO, [{'magnetometer': {'noise': -1e-9}}], 'effects[0].magnetometer.noise',
         'must be >= 0'),
        (LEO, [{'magnetometer': {'bias': [0, 0]}}], 'effects[0].magnetometer.bias',
         'expected 3 numbers'),
        (LEO, [{'sun_sensor': {'boresight': [0, 0, 0]}}], 'effects[0].sun_sensor.boresight',
         'zero vector'),
        (LEO, [{'sun_sensor': {'field_of_view': 190}}], 'effects[0].sun_sensor.field_of_view',
         'must be <= 180'),
        (LEO, [{'sun_sensor': {'shadow_threshold': 0.0}}],
         'effects[0].sun_sensor.shadow_threshold', 'must be > 0'),
        (LEO, [{'orbit': {'topic': 'attitude'}}], 'effects[0].orbit.topic', "simulator's own"),
    ],
)
def test_bad_orbits_and_effects_on_them_are_refused_with_the_field_path(
    orbit, effects, where, reason
):
    with pytest.raises(SceneError) as error:
        scene(effects, orbit=orbit)
    assert str(error.value).startswith(f's.yaml: {where}: '), str(error.value)
    assert reason in str(error.value), str(error.value)


def test_a_run_past_the_field_model_s_years_stops_with_the_reason_before_the_state_moves():
    """A start inside 2030 loads; the piece past 2030.0 is refused, naming the orbit."""
    late = scene(
        [{'residual_dipole': {'dipole': [0.1, 0.0, 0.0]}}],
        orbit={**LEO, 'epoch': '2029-12-31T23:50:00Z'},
    )
    propagator = late.propagator()
    omega, _ = propagator(np.array([0.0, 300.0]))  # inside 2029
    assert np.isfinite(omega).all()
    with pytest.raises(ValueError, match=r'^orbit: IGRF-14 covers 1900\.0 to 2030\.0'):
        propagator(np.array([900.0]))


# -- the environment held per window, against continuous evaluation -------------------------------
ORBITS = {
    'leo 400 km, J2': {**LEO, 'semi_major_axis': 6778137.0, 'j2': True},
    'leo 300 km, circular polar': {'epoch': EPOCH, 'semi_major_axis': 6678137.0,
                                   'inclination': 1.5},
    'e = 0.9 through a 638 km perigee': {
        'epoch': EPOCH, 'semi_major_axis': 7016000.0 / 0.1, 'eccentricity': 0.9,
        'inclination': 1.0, 'argument_of_perigee': 0.7, 'mean_anomaly': -0.05,
    },
}


@pytest.mark.parametrize('name', ORBITS)
def test_the_environment_held_per_window_is_the_continuous_one_to_float64_s_floor(name):
    """
    Position and fields held per window against their continuous evaluation, 41 times a window.

    Measured (environment.place's docstring): the position within 1.5e-15 of the radius
    (float64's floor: 1e-8 m in LEO, 1.5e-7 m at the 133 000 km apogee), the fields within 9e-8
    nT. Bounds 1e-6 m and 1e-6 nT (2e-11 of |B|): windows of 120 s, or six points a window, fail
    them. Sums by numpy's chebval, not the Clenshaw recurrence under test; that one is held to it
    to rounding.
    """
    place = scene([], orbit=ORBITS[name]).orbit
    # a whole LEO orbit; the eccentric one's perigee pass (its fastest part) and a stretch near
    # apogee
    span = place.orbit.period if place.orbit.eccentricity < 0.5 else 3000.0
    starts = [0.0] if place.orbit.eccentricity < 0.5 else [0.0, 0.5 * place.orbit.period]
    fractions = np.linspace(0.0, 1.0, 41)
    for start in starts:
        windows = np.arange(int(start // WINDOW), int((start + span) // WINDOW))
        times = (windows[:, None] + fractions) * WINDOW
        position = place.state(times)[0]
        exact = {
            'position': position,
            'igrf': place.field_N(times, position, 'igrf'),
            'dipole': place.field_N(times, position, 'dipole'),
        }
        x = 2.0 * fractions - 1.0
        for quantity, label in enumerate(QUANTITIES):
            held = np.stack([chebval(x, place.chebyshev(j, quantity).T).T for j in windows])
            error = np.abs(held - exact[label]).max()
            bound = 1e-6 if label == 'position' else 1e-15
            assert error <= bound, (label, error)
    j = int(windows[3])
    for t in (j * WINDOW, (j + 0.37) * WINDOW, (j + 1) * WINDOW):  # both ends: its own window
        for quantity in range(len(QUANTITIES)):
            coefficients = place.chebyshev(j, quantity)
            expected = chebval(2.0 * (t / WINDOW - j) - 1.0, coefficients.T)
            got = np.array(place.evaluate(quantity, j * WINDOW + 1.0, t))
            scale = np.abs(expected).max()
            np.testing.assert_allclose(got, expected, rtol=1e-15, atol=1e-15 * scale)
    assert place.chebyshev(0, 0).shape == (3, NODES)


def test_the_field_at_sample_times_is_numpy_s_on_both_paths_to_rounding(monkeypatch):
    """
    The kernels' ``fields_inertial`` (instant by instant) against numpy's vectorised models.

    The same operations in the same order but for libm's and numpy's sines and cosines in the
    frame: 16 eps of |B|, the bound test_magnetic_field.py holds the single-instant kernels to.
    """
    if not switch.AVAILABLE:
        require_numba()
    place = scene([], orbit={**LEO, 'j2': True}).orbit
    times = np.linspace(0.0, 6000.0, 37)
    position = place.state(times)[0]
    for model in ('igrf', 'dipole'):
        monkeypatch.setattr(switch, 'ENABLED', True)
        compiled = place.field_N(times, position, model)
        monkeypatch.setattr(switch, 'ENABLED', False)
        reference = place.field_N(times, position, model)
        bound = 16 * np.finfo(float).eps * np.linalg.norm(reference, axis=1, keepdims=True)
        assert np.all(np.abs(compiled - reference) <= bound), model
    monkeypatch.setattr(switch, 'ENABLED', True)
    with pytest.raises(ValueError, match=r'^orbit: IGRF-14 covers'):
        place.field_N(np.array([1e10]), position[:1], 'igrf')


# -- gravity_gradient on the orbit ----------------------------------------------------------------
def test_the_gravity_gradient_on_an_orbit_is_3_mu_over_r5_r_cross_I_r_at_the_true_position():
    """On an e = 0.3 orbit, at random times and attitudes; positions from Kepler solved here."""
    elements = {**LEO, 'semi_major_axis': 1.2e7, 'eccentricity': 0.3}
    inertia = np.array([[5.0, 0.3, -0.2], [0.3, 4.0, 0.1], [-0.2, 0.1, 3.0]])
    s = scene_from_mapping(
        {
            'body': {'inertia': [5.0, 4.0, 3.0, 0.3, -0.2, 0.1]},
            'initial': {'angular_velocity': [0.0, 0.0, 0.0]},
            'orbit': elements,
            'effects': [{'gravity_gradient': {}}],
        }
    )
    (effect,) = s.propagator('dop853').effects
    rng = np.random.default_rng(11)
    for t in rng.uniform(0.0, 20000.0, 12):
        q = Rotation.random(random_state=rng).as_quat()
        r_B = Rotation.from_quat(q).inv().apply(kepler_position(elements, t)[0])
        r = np.linalg.norm(r_B)
        expected = 3.0 * GM / r**5 * np.cross(r_B, inertia @ r_B)
        got = effect.torque_B(t, np.zeros(3), q, np.empty(0), t)
        # the held position is within 1e-13 of the radius; the bisection to 1e-15 rad
        scale = np.linalg.norm(expected)
        np.testing.assert_allclose(got, expected, rtol=1e-11, atol=1e-11 * scale)


@pytest.mark.usefixtures('integrator_path')
def test_on_a_circular_equatorial_orbit_the_gravity_gradient_is_today_s_mean_motion_effect():
    """
    Two orbits of a librating body: the orbit's effect equals the circular one within tolerance.

    Both at rtol 1e-12: the difference (measured 1e-12 rad/s and 2e-10 in q, on both paths) is
    the integrators' (different pieces: a breakpoint every 60 s on the orbit), bounded at 1e-10
    rad/s and 1e-8 in q.
    """
    radius, u0 = 6778137.0, 0.4
    n = math.sqrt(GM / radius**3)
    common = {
        'body': {'inertia': [3.0, 4.0, 2.0, 0.1, 0.0, -0.05]},
        'initial': {'angular_velocity': [0.002, -n, 0.001], 'orientation': [0.5, -0.5, 0.5, 0.5]},
        'accuracy': 1e-12,
    }
    own = {'radius': radius, 'argument_of_latitude': u0}
    circular = scene_from_mapping({**common, 'effects': [{'gravity_gradient': own}]})
    on_orbit = scene_from_mapping(
        {
            **common,
            'orbit': {'epoch': EPOCH, 'semi_major_axis': radius, 'mean_anomaly': u0},
            'effects': [{'gravity_gradient': {}}],
        }
    )
    times = np.linspace(0.0, 2 * 2 * math.pi / n, 301)
    w1, q1 = circular.propagator()(times)
    w2, q2 = on_orbit.propagator()(times)
    assert np.abs(w2 - w1).max() <= 1e-10 and np.abs(q2 - q1).max() <= 1e-8
    assert np.abs(w1[:, 1] + n).max() > 1e-4  # the torque did something: a libration


# -- residual_dipole ------------------------------------------------------------------------------
def test_the_residual_dipole_torque_is_m_cross_b_in_the_body_frame():
    """Against ppigrf's IGRF (a second implementation) rotated here; the tilted dipole too."""
    m = np.array([0.05, -0.02, 0.08])
    rng = np.random.default_rng(5)
    for field in ('igrf', 'dipole'):
        s = scene([{'residual_dipole': {'dipole': m.tolist(), 'field': field}}])
        (effect,) = s.propagator('dop853').effects
        for t in rng.uniform(0.0, 6000.0, 4):
            q = Rotation.random(random_state=rng).as_quat()
            position = kepler_position(LEO, t)[0]
            instant = s.orbit.start + t
            if field == 'igrf':
                field_N = ppigrf_inertial(position, instant)
                tolerance = 0.5e-9  # T: ppigrf interpolates between epochs in days (0.2 nT)
            else:  # the degree-1 terms alone, written here
                w = earth.earth_fixed_matrix(instant)
                g = magnetic.schmidt_table()  # g, h by epoch; 2026.2: 2025 + 0.24 of the SV
                year = epochs.decimal_year(instant)
                k = int((year - 1900.0) // 5.0)
                k = min(k, g.shape[0] - 2)
                f = (year - (1900.0 + 5.0 * k)) / 5.0
                g10, g11, h11 = (g[k, i, 1, j] + f * (g[k + 1, i, 1, j] - g[k, i, 1, j])
                                 for i, j in ((0, 0), (0, 1), (1, 1)))
                moment = np.array([g11, h11, g10]) * 1e-9
                x = w @ position
                ratio = magnetic._k.IGRF_RADIUS / np.linalg.norm(x)
                unit = x / np.linalg.norm(x)
                field_N = w.T @ (ratio**3 * (3.0 * (moment @ unit) * unit - moment))
                tolerance = 1e-15  # T: the held field is within 1e-16 T
            expected = np.cross(m, Rotation.from_quat(q).inv().apply(field_N))
            got = effect.torque_B(t, np.zeros(3), q, np.empty(0), t)
            assert np.abs(got - expected).max() <= np.linalg.norm(m) * tolerance


@pytest.mark.usefixtures('integrator_path')
def test_the_inertial_momentum_changes_by_the_integral_of_the_dipole_torque():
    """
    Euler's law in the inertial frame: ``H_N(t) - H_N(0) = int (R m) x B_N dt``.

    The integral by Simpson's rule on 0.05 s samples of the propagated attitude and the exact
    field, continuous (error ~ h^4 w^4 / 180 of the torque, 1e-11 of the change here); the
    propagation at rtol 1e-12. Bound: 1e-10 of the change (measured 7e-13 on both paths).
    """
    m = np.array([0.2, -0.1, 0.3])
    s = scene(
        [{'residual_dipole': {'dipole': m.tolist()}}],
        omega=(0.02, 0.05, -0.03),
        accuracy=1e-12,
    )
    p = s.propagator()
    times = np.arange(0.0, 300.0 + 1e-9, 0.05)
    omega, q, x = p.states(times)
    momentum_N = Rotation.from_quat(q).apply(p.momentum_B(omega, x))
    position = s.orbit.state(times)[0]
    field_N = s.orbit.field_N(times, position, 'igrf')
    torque_N = np.cross(Rotation.from_quat(q).apply(m), field_N)
    change = simpson(torque_N, x=times, axis=0)
    np.testing.assert_allclose(
        momentum_N[-1] - momentum_N[0], change, rtol=0, atol=1e-10 * np.linalg.norm(change)
    )
    assert np.linalg.norm(change) > 1e-3 * np.linalg.norm(momentum_N[0])  # a real change


def test_the_held_environment_changes_a_trajectory_by_less_than_the_integrator_s_tolerance():
    """
    Continuous evaluation at every stage against the environment held per window.

    scipy's DOP853 on the equations written here, the field and the position evaluated at every
    stage by the compiled environment kernels (Kepler's state, IGRF-14 with the Earth's rotation;
    held to the numpy models in their own tests), against the propagator at the same tolerances,
    over 20 minutes (20 windows) of a tumbling 3U-class body with gravity gradient and a residual
    dipole. Both integrate at rtol 1e-11: their difference is their own error, measured 4e-12
    rad/s and 2e-11 in q; bounds 1e-10 rad/s (7e-10 of |w|) and 1e-9.
    """
    if not switch.AVAILABLE:
        require_numba('the continuous reference runs through the compiled environment kernels')
    m = np.array([0.02, -0.01, 0.03])
    s = scene(
        [{'gravity_gradient': {}}, {'residual_dipole': {'dipole': m.tolist()}}],
        omega=(0.1, -0.05, 0.12),
        accuracy=1e-11,
    )
    tensor = np.diag(INERTIA)
    inverse = np.linalg.inv(tensor)
    row = s.orbit.orbit.kernel_row()
    table = magnetic.kernel_table()
    kepler_state = environment_kernels.kernel('kepler_state')
    igrf_inertial = environment_kernels.kernel('igrf_inertial')
    state, field = np.empty(6), np.empty(3)

    def rhs(t, y):
        w, q = y[:3], y[3:7]
        kepler_state(s.orbit.offset + t, row, state)
        r_N = state[:3]
        igrf_inertial(r_N, s.orbit.start + t, table, field)
        to_body = Rotation.from_quat(q).inv()
        r_B, b_B = to_body.apply(r_N), to_body.apply(field)
        r = np.linalg.norm(r_B)
        torque = 3.0 * GM / r**5 * np.cross(r_B, tensor @ r_B) + np.cross(m, b_B)
        w_dot = inverse @ (torque - np.cross(w, tensor @ w))
        x, y_, z, s_ = q
        q_dot = 0.5 * np.array([
            s_ * w[0] + y_ * w[2] - z * w[1],
            s_ * w[1] - x * w[2] + z * w[0],
            s_ * w[2] + x * w[1] - y_ * w[0],
            -(x * w[0] + y_ * w[1] + z * w[2]),
        ])
        return np.concatenate([w_dot, q_dot])

    times = np.linspace(0.0, 1200.0, 61)
    y0 = np.concatenate([s.angular_velocity, s.orientation])
    with np.errstate(under='ignore'):  # scipy's step floor, nextafter(0) at t = 0
        reference = solve_ivp(
            rhs, (0.0, times[-1]), y0, method='DOP853', t_eval=times, rtol=1e-11, atol=1e-13
        ).y.T
    omega, q = s.propagator()(times)
    assert np.abs(omega - reference[:, :3]).max() <= 1e-10
    assert np.abs(q - reference[:, 3:7]).max() <= 1e-9
    assert np.abs(omega[-1] - omega[0]).max() > 1e-6  # the torques did change the rates


# -- outputs --------------------------------------------------------------------------------------
def _messages(output, rows, message_class, stamps=None):
    """Encode ``rows`` as the node and the bags do, and decode them with rclpy's deserializer."""
    from rclpy.serialization import deserialize_message

    stamps = np.arange(len(rows), dtype=np.int64) * 10**9 if stamps is None else stamps
    frame = 'world' if output.frame == 'inertial' else 'body'
    block = LAYOUTS[output.layout](stamps, frame, 'body', rows, None)
    return [deserialize_message(data, message_class) for data in block]


def _simulation(s, rate=1.0):
    return Simulation(s.propagator(), rate, outputs=s.outputs)


def test_the_magnetometer_reads_the_field_in_body_axes_with_its_bias_and_seeded_noise():
    """IGRF against ppigrf (0.5 nT: its interpolation between epochs); the noise re-drawn here."""
    from sensor_msgs.msg import MagneticField

    sigma, bias, seed = 50e-9, np.array([1e-7, -2e-7, 3e-7]), 7
    s = scene(
        [
            {'magnetometer': {'noise': sigma, 'bias': bias.tolist(), 'seed': seed}},
            {'magnetometer': {'topic': 'truth/field'}},
        ]
    )
    block = _simulation(s).samples(0, 30)
    noisy, clean = block.outputs
    for k in (0, 11, 29):
        field_N = ppigrf_inertial(kepler_position(LEO, float(k))[0], s.orbit.start + k)
        expected = Rotation.from_quat(block.q_NB[k]).inv().apply(field_N)
        assert np.abs(clean[k, :3] - expected).max() <= 0.5e-9
    normals = np.random.Generator(np.random.PCG64(seed)).standard_normal((30, 3))
    np.testing.assert_allclose(noisy[:, :3] - clean[:, :3] - bias, sigma * normals, atol=1e-20)
    np.testing.assert_array_equal(noisy[:, 3:], np.tile(np.diag([sigma**2] * 3).ravel(), (30, 1)))
    np.testing.assert_array_equal(clean[:, 3:], 0.0)  # no noise: "unknown", as the message says
    for message, row in zip(_messages(s.outputs[0], noisy, MagneticField), noisy):
        field = message.magnetic_field
        assert [field.x, field.y, field.z] == row[:3].tolist()
        assert message.magnetic_field_covariance.tolist() == row[3:].tolist()
        assert message.header.frame_id == 'body'
    assert s.outputs[0].message_type == 'sensor_msgs/msg/MagneticField'


@pytest.mark.parametrize('name', ['magnetometer', 'sun_sensor', 'orbit'])
def test_rows_do_not_depend_on_blocks_and_an_own_rate_takes_every_nth_sample(name):
    parameters = {'noise': 1e-7} if name == 'magnetometer' else {}
    if name == 'sun_sensor':
        parameters = {'noise': 0.1, 'field_of_view': 80.0}
    s = scene([{name: parameters}], omega=(0.3, -0.2, 0.4))
    whole = _simulation(s, 2.0).samples(0, 120).outputs[0]
    simulation = _simulation(s, 2.0)
    cut = np.vstack([simulation.samples(first, 7).outputs[0] for first in range(0, 120, 7)])
    np.testing.assert_array_equal(cut[:120], whole)
    again = simulation.samples(30, 5).outputs[0]  # back: the draws start over
    np.testing.assert_array_equal(again, whole[30:35])
    slow = scene([{name: {**parameters, 'rate': 0.5}}], omega=(0.3, -0.2, 0.4))
    block = _simulation(slow, 2.0).samples(0, 120)
    np.testing.assert_array_equal(block.output_positions[0], np.arange(0, 120, 4))
    at_own_rate = _simulation(slow, 0.5).samples(0, 30).outputs[0]
    np.testing.assert_array_equal(block.outputs[0], at_own_rate)


EQUATORIAL = {'epoch': EPOCH, 'semi_major_axis': 7000e3}  # circular, in the equator


def test_the_sun_sensor_loses_the_sun_where_the_tangent_cones_say():
    """
    Eclipse entry and exit of a circular equatorial orbit at the March equinox, in closed form.

    With ``shadow_threshold`` 0.5 the Sun is lost about when its centre crosses the Earth's limb
    seen from the body: ``r^ . s^ = -cos(asin(R / r))``, so ``cos(dec) cos(u - ra) = -sqrt(1 - (R /
    r)^2)`` for the argument of latitude ``u``. Its limb's curvature moves the half-hidden point by
    ~0.01 s, the parallax (the Sun's 1 au against the 7000 km orbit) by 0.04 s, the Sun's motion
    over the orbit is taken at each crossing; the switch is known to half a sample (0.05 s at 10
    Hz): bound 0.1 s (measured 0.006 s at entry, 0.024 s at exit). Lit samples carry
    a unit vector: the Sun's direction from the body (``sun.sun_position``, tested against
    astropy) in body axes by scipy's rotation, to 1e-12 rad.
    """
    s = scene([{'sun_sensor': {}}], orbit=EQUATORIAL, omega=(0.01, 0.02, -0.03))
    rate = 10.0
    simulation = _simulation(s, rate)
    n = math.sqrt(GM / 7000e3**3)
    period = 2.0 * math.pi / n
    block = simulation.samples(0, int(period * rate) + 1)
    rows = block.outputs[0]
    norms = np.linalg.norm(rows, axis=1)
    lit = norms > 0.5
    np.testing.assert_allclose(norms[lit], 1.0, atol=1e-14)
    np.testing.assert_array_equal(rows[~lit], 0.0)
    switches = np.flatnonzero(np.diff(lit.astype(int)))
    assert switches.size == 2  # one eclipse an orbit
    limb = math.sqrt(1.0 - (EQUATORIAL_RADIUS / 7000e3) ** 2)
    for index in switches:
        t = block.times[index] + 0.5 / rate  # between the two samples
        direction = sun.sun_position(s.orbit.start + t)
        direction = direction / np.linalg.norm(direction)
        ra, dec = math.atan2(direction[1], direction[0]), math.asin(direction[2])
        half = math.acos(-limb / math.cos(dec))  # u - ra at the two crossings: +-half
        entering = lit[index]  # lit before the switch
        u = ra + (half if entering else -half)
        expected = math.remainder(u, 2.0 * math.pi) / n % period
        assert abs(expected - t) <= 0.1, (entering, expected, t)
    k = int(np.flatnonzero(lit)[len(np.flatnonzero(lit)) // 2])
    t = block.times[k]
    towards = sun.sun_position(s.orbit.start + t) - kepler_position(EQUATORIAL, t)[0]
    expected = Rotation.from_quat(block.q_NB[k]).inv().apply(towards / np.linalg.norm(towards))
    assert np.arccos(np.clip(rows[k] @ expected, -1.0, 1.0)) <= 1e-7  # (the orbit to 1e-8 m)


def test_the_sun_sensor_sees_the_sun_only_inside_its_field_of_view_and_turns_it_by_its_noise():
    from geometry_msgs.msg import Vector3Stamped

    boresight, fov, sigma, seed = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0), 50.0, 0.2, 3
    sensors = [
        {'sun_sensor': {'boresight': [2.0, 2.0, 0.0], 'field_of_view': fov, 'topic': 'a'}},
        {'sun_sensor': {'noise': sigma, 'seed': seed, 'topic': 'b'}},
        {'sun_sensor': {'topic': 'c'}},
    ]
    s = scene(sensors, omega=(0.05, 0.08, -0.06), orbit={**LEO, 'mean_anomaly': 5.0})  # lit
    block = _simulation(s, 2.0).samples(0, 400)
    limited, noisy, truth = block.outputs
    assert (np.linalg.norm(truth, axis=1) > 0.5).all()
    angle = np.degrees(np.arccos(np.clip(truth @ boresight, -1.0, 1.0)))
    inside = angle <= fov
    assert 0 < inside.sum() < inside.size  # the sweep crosses the edge
    np.testing.assert_array_equal(limited[inside], truth[inside])
    np.testing.assert_array_equal(limited[~inside], 0.0)
    normals = np.random.Generator(np.random.PCG64(seed)).standard_normal((400, 3))
    expected = Rotation.from_rotvec(np.radians(sigma) * normals).apply(truth)
    np.testing.assert_allclose(noisy, expected, atol=1e-15)
    for message, row in zip(_messages(s.outputs[0], limited, Vector3Stamped), limited):
        assert [message.vector.x, message.vector.y, message.vector.z] == row.tolist()


def test_the_orbit_output_is_the_orbit_s_position_and_velocity_with_the_attitude():
    """Odometry decoded by rclpy: r_N, q_NB, R(q)^T v_N and w; Kepler solved here."""
    from nav_msgs.msg import Odometry

    s = scene([{'orbit': {}}], omega=(0.05, 0.08, -0.06))
    block = _simulation(s, 0.1).samples(0, 40)
    (rows,) = block.outputs
    position = kepler_position(LEO, block.times)
    h = 1e-3  # the velocity by a central difference of the independent position: 1e-8 m/s
    velocity = (kepler_position(LEO, block.times + h) - kepler_position(LEO, block.times - h)) / (
        2 * h
    )
    assert np.abs(rows[:, 0:3] - position).max() <= 1e-6
    expected = Rotation.from_quat(block.q_NB).inv().apply(velocity)
    assert np.abs(rows[:, 7:10] - expected).max() <= 1e-6
    np.testing.assert_array_equal(rows[:, 3:7], block.q_NB)
    np.testing.assert_array_equal(rows[:, 10:13], block.omega_B)
    for message, row in zip(_messages(s.outputs[0], rows, Odometry), rows):
        pose, twist = message.pose.pose, message.twist.twist
        assert [pose.position.x, pose.position.y, pose.position.z] == row[0:3].tolist()
        assert [twist.linear.x, twist.linear.y, twist.linear.z] == row[7:10].tolist()
        assert (message.header.frame_id, message.child_frame_id) == ('world', 'body')


# -- the engines ----------------------------------------------------------------------------------
ON_ORBIT = [{'gravity_gradient': {}}, {'residual_dipole': {'dipole': [0.02, -0.01, 0.03]}}]


def test_samples_on_an_orbit_do_not_depend_on_how_they_are_asked_and_the_plant_repeats_them():
    """All at once, in blocks, back (a restart), in the plant one step at a time: bit for bit."""
    s = scene(ON_ORBIT, accuracy=1e-10)
    times = np.arange(0.0, 400.0, 0.5)
    whole = s.propagator().states(times)
    p = s.propagator()
    blocks = [p.states(times[i: i + 97]) for i in range(0, times.size, 97)]
    for got, expected in zip([np.concatenate(parts) for parts in zip(*blocks)], whole):
        np.testing.assert_array_equal(got, expected)
    for got, expected in zip(p.states(times[100:110]), whole):
        np.testing.assert_array_equal(got, expected[100:110])
    plant = Plant(s, 2.0)
    steps = np.array([plant.step(None).omega_B for _ in range(times.size - 1)])
    np.testing.assert_array_equal(steps, whole[0][1:])


def test_the_compiled_and_the_reference_paths_agree_on_an_orbit(monkeypatch):
    """The same pieces and steps but for rounding: within 1e-12 rad/s over 10 windows."""
    s = scene(ON_ORBIT, accuracy=1e-10)
    times = np.linspace(0.0, 600.0, 121)
    runs = []
    for enabled in (True, False):
        monkeypatch.setattr(switch, 'ENABLED', enabled)
        propagator = s.propagator()
        assert propagator.compiled is enabled
        runs.append(propagator(times))
    assert np.abs(runs[0][0] - runs[1][0]).max() <= 1e-12
    assert np.abs(runs[0][1] - runs[1][1]).max() <= 1e-11


def test_a_tle_orbit_drives_the_torques_and_the_outputs():
    """SGP4's positions reach the gravity gradient and the orbit output as they are."""
    s = scene([*ON_ORBIT, {'orbit': {}}], orbit={'tle': ISS_TLE})
    block = _simulation(s, 1.0).samples(0, 200)
    position, velocity = s.orbit.orbit.state(block.times)
    np.testing.assert_array_equal(block.outputs[0][:, 0:3], position)
    assert np.isfinite(block.omega_B).all()
    assert 6.6e6 < np.linalg.norm(position, axis=1).min() < 6.8e6


@pytest.mark.parametrize('orbit', [LEO, {'tle': ISS_TLE}], ids=['kepler', 'tle'])
def test_a_scene_on_an_orbit_pickles_for_campaign_workers_and_runs_the_same_there(orbit):
    s = scene([*ON_ORBIT, {'magnetometer': {}}], orbit=orbit)
    times = np.array([0.0, 100.0])
    expected = s.propagator()(times)
    again = pickle.loads(pickle.dumps(s))
    assert again == s
    for got, want in zip(again.propagator()(times), expected):
        np.testing.assert_array_equal(got, want)


def test_the_node_publishes_the_outputs_of_the_orbit_as_the_offline_simulation_computes_them(
    tmp_path,
):
    """In process, stepped: the messages carry the rows of a Simulation of the same scene."""
    from geometry_msgs.msg import Vector3Stamped
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import MagneticField
    from torquefree_ros.testing import simulator

    path = tmp_path / 'leo.yaml'
    path.write_text(
        'body: {inertia: [0.03, 0.035, 0.01]}\n'
        'initial: {angular_velocity: [0.1, -0.05, 0.12]}\n'
        'orbit: {epoch: 2026-03-20T12:00:00Z, semi_major_axis: 6878137.0, inclination: 1.7}\n'
        'effects:\n'
        '  - gravity_gradient: {}\n'
        '  - residual_dipole: {dipole: [0.01, 0.0, 0.02]}\n'
        '  - magnetometer: {noise: 1.0e-7, seed: 4}\n'
        '  - sun_sensor: {}\n'
        '  - orbit: {rate: 1}\n'
    )
    s = load_scene(path)
    expected = _simulation(s, 10.0).samples(0, 21).outputs
    with simulator(str(path), publish_rate=10.0, lockstep=False) as sim:
        taps = [
            sim.tap('magnetometer', MagneticField),
            sim.tap('sun_sensor', Vector3Stamped),
            sim.tap('orbit', Odometry),
        ]
        sim.advance(21)
        for tap, count in zip(taps, (21, 21, 3)):
            tap.wait(count)
    magnetometer, sun_sensor, orbit = (tap.messages for tap in taps)
    got = np.array([[m.magnetic_field.x, m.magnetic_field.y, m.magnetic_field.z]
                    for m in magnetometer])
    np.testing.assert_array_equal(got, expected[0][:, :3])
    got = np.array([[m.vector.x, m.vector.y, m.vector.z] for m in sun_sensor])
    np.testing.assert_array_equal(got, expected[1])
    got = np.array([[m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z]
                    for m in orbit])
    np.testing.assert_array_equal(got, expected[2][:, :3])
