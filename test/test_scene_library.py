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
The scene library (torquefree_ros/scenes).

Every scene loads, says what it is in one line, and shows what its description promises, checked
independently of the code that made the promise.
"""

from pathlib import Path

import numpy as np
import pytest
from torquefree_ros import load_scene
from torquefree_ros.core.frames import quaternion
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.library import library_scenes

LIBRARY = Path(__file__).resolve().parents[1] / 'torquefree_ros' / 'scenes'
NAMES = [
    'axisymmetric_coning',
    'bdot_detumble',
    'default',
    'detumble',
    'dzhanibekov',
    'energy_sweep',
    'estimator',
    'explorer1',
    'gravity_gradient',
    'gyrostat',
    'imu',
    'sun_pointing',
    'wheel_slew',
]
TIGHT = {'rtol': 1e-12, 'atol': 1e-14}


def library(name):
    return load_scene(LIBRARY / f'{name}.yaml')


def test_the_library_has_every_scene_each_with_a_one_line_description():
    assert sorted(p.stem for p in LIBRARY.glob('*.yaml')) == NAMES
    assert sorted(library_scenes()) == NAMES
    for name in NAMES:
        description = library(name).description
        assert description and '\n' not in description and len(description) < 200, name


def test_load_scene_takes_library_names_from_any_directory(tmp_path, monkeypatch):
    # not the repository root: names do not depend on the working directory
    monkeypatch.chdir(tmp_path)
    assert load_scene('dzhanibekov') == library('dzhanibekov')
    assert load_scene('explorer1').source == str(LIBRARY / 'explorer1.yaml')
    assert load_scene('default').source == '<built-in default>'
    with pytest.raises(
        ValueError,
        match=r"'dzanibekov' is neither a file nor a library scene \(library: .*dzhanibekov",
    ):
        load_scene('dzanibekov')


def test_a_file_in_the_working_directory_wins_over_a_library_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / 'explorer1').write_text(
        'body: {inertia: [1, 2, 3]}\ninitial: {angular_velocity: [0, 0, 1]}\n'
    )
    assert load_scene('explorer1').inertia == (1.0, 2.0, 3.0)
    assert load_scene('./explorer1').inertia == (1.0, 2.0, 3.0)


def test_dzhanibekov_flips_at_the_reported_period():
    scene = library('dzhanibekov')
    simulation = Simulation(scene.propagator(), 100.0)
    assert simulation.regime.kind in ('major_axis_polhode', 'minor_axis_polhode')
    flip = simulation.regime.flip_period
    times = np.linspace(0.0, 4.5 * flip, 20001)
    omega, _ = scene.propagator('dop853', **TIGHT)(times)  # an independent integrator
    crossings = times[np.where(np.diff(np.sign(omega[:, 1])) != 0)[0]]
    assert len(crossings) == 4  # the intermediate-axis rate reverses once per flip period
    np.testing.assert_allclose(np.diff(crossings), flip, rtol=2e-4)  # grid spacing 2e-4 of a flip
    assert np.abs(omega[:, 1]).max() > 4.99  # a full reversal of the spin, not a wobble


def test_axisymmetric_coning_reports_the_cones_it_sweeps():
    scene = library('axisymmetric_coning')
    regime = Simulation(scene.propagator(), 100.0).regime
    assert 'body cone angle' in regime.summary() and 'space cone angle' in regime.summary()
    times = np.linspace(0.0, 10.0, 1001)
    p = scene.propagator('dop853', **TIGHT)
    omega, q = p(times)
    H_N = p.body.angular_momentum_inertial(omega, q)
    omega_N = quaternion.rotate(q, omega)
    # w to the symmetry axis x
    alpha = np.arctan2(np.linalg.norm(omega[:, 1:], axis=1), np.abs(omega[:, 0]))
    beta = np.arctan2(
        np.linalg.norm(np.cross(omega_N, H_N), axis=1), np.sum(omega_N * H_N, axis=1)
    )
    np.testing.assert_allclose(alpha, regime.body_cone_angle, rtol=1e-9)
    np.testing.assert_allclose(beta, regime.space_cone_angle, rtol=1e-9)
    # the symmetry axis circles H_N at |H| / I_T: unwrap its azimuth about H_N
    h = H_N[0] / np.linalg.norm(H_N[0])
    e1 = quaternion.rotate(q, np.array([1.0, 0.0, 0.0]))
    u = np.cross(h, [0.0, 0.0, 1.0]) if abs(h[2]) < 0.9 else np.cross(h, [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(h, u)
    azimuth = np.unwrap(np.arctan2(e1 @ v, e1 @ u))
    rate = np.polyfit(times, azimuth, 1)[0]
    assert rate == pytest.approx(regime.inertial_precession_rate, rel=1e-9)


def test_explorer1_ends_in_a_flat_spin_about_its_major_axis():
    scene = library('explorer1')
    p = scene.propagator()
    assert [effect.name for effect in p.effects] == ['damper']
    times = np.linspace(0.0, 900.0, 901)
    omega, q, x = p.states(times)
    energy = p.energy(omega, x)
    assert np.all(np.diff(energy) <= 1e-12 * energy[0])
    momentum = np.linalg.norm(p.momentum_B(omega, x), axis=1)
    np.testing.assert_allclose(momentum, momentum[0], rtol=1e-7)  # scene accuracy 1e-9 over 900 s
    major = int(np.argmax(p.body.moments))
    assert omega[0, major] == 0.0 and abs(omega[-1, major]) / np.linalg.norm(omega[-1]) > np.cos(
        np.radians(2.0)
    )


def test_gravity_gradient_librates_about_the_local_vertical():
    scene = library('gravity_gradient')
    (effect,) = scene.effects
    n = effect.mean_motion
    times = np.linspace(0.0, 2 * np.pi / n, 401)  # one orbit
    _, q = scene.propagator()(times)
    # the nadir axis (body z) stays within the 0.1 rad pitch amplitude of the local vertical -r_N
    nadir_B = quaternion.rotate(q, np.array([0.0, 0.0, 1.0]))
    down = -np.column_stack([np.cos(n * times), np.sin(n * times), np.zeros_like(times)])
    tilt = np.arccos(np.clip(np.sum(nadir_B * down, axis=1), -1.0, 1.0))
    assert tilt[0] == pytest.approx(0.1, rel=1e-9)
    assert tilt.max() <= 0.1 * (1 + 1e-6) and tilt.min() < 0.01  # it swings through the vertical


def test_gyrostat_keeps_its_intermediate_axis_spin():
    scene = library('gyrostat')
    p = scene.propagator()
    times = np.linspace(0.0, 120.0, 1201)
    omega, q, x = p.states(times)
    H_N = quaternion.rotate(q, p.momentum_B(omega, x))
    np.testing.assert_allclose(
        H_N, np.broadcast_to(H_N[0], H_N.shape), atol=1e-8 * np.linalg.norm(H_N[0])
    )
    assert omega[:, 1].min() > 0.99


def test_imu_scene_is_torque_free_with_two_outputs():
    scene = library('imu')
    assert scene.torque_free and scene.propagator().name == 'analytic'
    assert [(o.name, o.topic, o.message_type) for o in scene.outputs] == [
        ('imu', 'imu', 'sensor_msgs/msg/Imu'),
        ('euler_angles', 'euler_angles', 'geometry_msgs/msg/Vector3Stamped'),
    ]


def test_energy_sweep_spans_minimum_to_maximum_energy_at_constant_momentum():
    scene = library('energy_sweep')
    members = scene.members()
    assert len(members) == 9
    moments = np.array(scene.inertia)
    H0 = np.linalg.norm(moments * scene.angular_velocity)
    omegas = np.array([m.angular_velocity for m in members])
    np.testing.assert_allclose(np.linalg.norm(moments * omegas, axis=1), H0, rtol=1e-14)
    two_T = np.sum(moments * omegas**2, axis=1)
    np.testing.assert_allclose(
        two_T, np.linspace(H0**2 / moments.max(), H0**2 / moments.min(), 9), rtol=1e-14
    )


def test_wheel_slew_starts_at_rest_60_degrees_off_with_an_isotropic_biased_pyramid():
    """
    The slew's scene: at rest, 60 deg from the inertial frame, wheels taking motor torques.

    The pyramid's ``sum Js g g^T`` is ``(4/3) Js I`` (every axis 54.7 deg from z); the wheels'
    bias is in its null space, so the whole momentum is zero; left alone (no command: no motor
    torque) the body stays at rest while friction slows the wheels (its torques cancel on the
    body) to rounding.
    """
    scene = library('wheel_slew')
    (wheels,) = scene.effects
    assert wheels.mode == 'torque' and wheels.topic == 'wheel_command'
    assert [o.name for o in scene.outputs] == ['wheel_states', 'markers']
    np.testing.assert_allclose(
        wheels.spin_inertia_B(), 4.0 / 3.0 * 0.01 * np.eye(3), rtol=0, atol=1e-17
    )
    q0 = np.array(scene.orientation)
    assert 2.0 * np.degrees(np.arccos(q0[3])) == pytest.approx(60.0, rel=1e-14)
    p = scene.propagator()
    np.testing.assert_allclose(p.momentum_B(p.omega0_B, p.x0), 0.0, atol=1e-15)
    omega, _, x = p.states(np.array([0.0, 30.0]))
    np.testing.assert_allclose(omega, 0.0, atol=1e-15)
    speeds = wheels.wheel_speeds(omega, x)
    assert np.all(np.abs(speeds[1]) < 100.0) and np.all(np.abs(speeds[1]) > 98.0)


def test_bdot_detumble_tumbles_at_10_deg_s_in_a_500_km_orbit_with_three_rods_and_a_magnetometer():
    scene = library('bdot_detumble')
    rate = np.degrees(np.linalg.norm(scene.angular_velocity))
    assert rate == pytest.approx(10.0, rel=1e-12)
    assert 0.005 <= min(scene.inertia) and max(scene.inertia) <= 0.06  # 3U-class, kg m^2
    times = np.linspace(0.0, 6000.0, 61)
    radius = np.linalg.norm(scene.orbit.state(times)[0], axis=1)
    np.testing.assert_allclose(radius - 6378137.0, 500e3, rtol=0, atol=1e-6)  # circular, 500 km
    (rods,) = [e for e in scene.effects if e.name == 'magnetorquers']
    np.testing.assert_array_equal(rods.axes, np.eye(3))
    assert rods.max_dipoles.tolist() == [0.2] * 3
    assert {o.name for o in scene.outputs} >= {'magnetometer', 'magnetorquer_dipole'}


def test_sun_pointing_starts_120_degrees_off_the_sun_on_a_noon_midnight_orbit_with_eclipses():
    """
    The sun-pointing scene: a 6U-class body, a biased wheel pyramid, a whole-sky sun sensor.

    The panel normal (+x, the sensor's boresight) starts 120 deg about z from the inertial x axis,
    where the Sun is at the scene's start (the March equinox, 2.8 h before it: 0.1 deg short of
    it, and 26 years of precession from J2000's axes, 0.36 deg): between 119.5 and 120.5 deg off.
    The wheels' bias is in the pyramid's null space, so the whole momentum is the body's. The
    eclipse of a circular orbit whose plane holds the Sun lasts ``2 asin(R / r) / n`` (a
    cylindrical shadow, ``beta = 0``): the time the sensor's half-disc threshold is passed over
    one orbit agrees within 0.5 % (measured 0.04 %: the half-shadow cone is nearly the cylinder,
    ``beta`` is 0.5 deg, 2 s steps).
    """
    from torquefree_ros.core.environment import sun

    scene = library('sun_pointing')
    (wheels,) = scene.effects
    assert wheels.mode == 'torque' and wheels.topic == 'wheel_command'
    assert [o.name for o in scene.outputs] == ['sun_sensor', 'wheel_states']
    (sensor, _) = scene.outputs
    assert sensor.values['field_of_view'] is None  # the whole sky
    js = 0.015 / (6000.0 * np.pi / 30.0)  # RWP015: 0.015 N m s at 6000 rpm
    np.testing.assert_allclose(wheels.spin_inertias, js, rtol=1e-15)
    np.testing.assert_allclose(wheels.spin_inertia_B(), 4.0 / 3.0 * js * np.eye(3), atol=1e-20)
    p = scene.propagator()
    inertia = np.diag(scene.inertia)
    np.testing.assert_allclose(
        p.momentum_B(p.omega0_B, p.x0), inertia @ p.omega0_B, rtol=0, atol=1e-17
    )
    place = scene.orbit
    period = 2.0 * np.pi / np.sqrt(3.986004418e14 / 6878137.0**3)
    times = np.arange(0.0, period, 2.0)
    position = place.state(times)[0]
    np.testing.assert_allclose(np.linalg.norm(position, axis=1) - 6378137.0, 500e3, atol=1e-6)
    to_sun = place.sun_N(times[:1])[0] - position[0]
    normal_N = quaternion.rotate(np.array(scene.orientation), np.array([1.0, 0.0, 0.0]))
    off = np.degrees(np.arccos(normal_N @ to_sun / np.linalg.norm(to_sun)))
    assert 119.5 < off < 120.5, off
    dark = sun.shadow_fraction(position, place.sun_N(times)) >= 0.5
    assert not dark[0]  # it starts in sunlight
    expected = 2.0 * np.arcsin(6378137.0 / 6878137.0) * period / (2.0 * np.pi)
    assert dark.sum() * 2.0 == pytest.approx(expected, rel=5e-3)
