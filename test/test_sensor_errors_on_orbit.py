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
The error models of the sensors on an orbit (issue 42): magnetometer, sun sensor, star tracker.

The references are independent of the error code under test: least squares (numpy) of the
readings on the error-free field a second, error-free magnetometer of the same scene reads (the
field itself is held to ppigrf in ``test_orbit_effects``); rotations by scipy; the sun sensor's
two angles from their definition with the basis built here; the star tracker's exclusion angles
from the Sun's position (``environment.sun``, held to astropy in ``test_sun``), Kepler's equation
solved by bisection (``test_orbit_effects.kepler_position``) and the boresight turned by scipy.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from test_orbit_effects import kepler_position, LEO
from torquefree_ros.core.environment import sun
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping, SceneError

DEG = math.pi / 180.0
ARCSEC = DEG / 3600.0
PPM = 1e-6
NT = 1e-9
EARTH_RADIUS = 6378137.0  # m, WGS 84's equatorial radius (the sphere the exclusion uses)
LIT = {**LEO, 'mean_anomaly': 5.0}  # in sunlight for the first ~1500 s


def _scene(effects, orbit=LIT, omega=(0.05, -0.08, 0.06), inertia=(0.03, 0.035, 0.01)):
    data = {
        'body': {'inertia': list(inertia)},
        'initial': {'angular_velocity': list(omega)},
        'effects': effects,
    }
    if orbit is not None:
        data['orbit'] = orbit
    return scene_from_mapping(data, source='s.yaml')


def _block(scene, count, rate=2.0):
    return Simulation(scene.propagator(), rate, outputs=scene.outputs).samples(0, count)


# -- magnetometer ---------------------------------------------------------------------------------


def test_magnetometer_scale_factor_misalignment_and_bias_are_recovered_by_least_squares():
    """
    Readings against the error-free field of the same samples, noise off: ``y = C B + b``.

    The tumbling body turns the field through every body direction over 600 samples. Affine least
    squares gives ``C = I + S + M`` and ``b``: the scene's ppm within 1e-7 ppm, arcsec within 2e-8
    arcsec and the bias within 1e-18 T (float64's rounding of 5e-5 T readings is 7e-21 T, the
    design's condition number 3; measured 1.4e-9 ppm, 9e-10 arcsec, 2e-20 T).
    """
    scale = [150.0, -90.0, 400.0]  # ppm
    misalignment = [[0.0, 25.0, -40.0], [60.0, 0.0, 15.0], [-30.0, 8.0, 0.0]]  # arcsec
    bias = [120 * NT, -300 * NT, 45 * NT]
    sensor = {'scale_factor': scale, 'misalignment': misalignment, 'bias': bias}
    block = _block(
        _scene([{'magnetometer': sensor}, {'magnetometer': {'topic': 'truth'}}]), 600
    )
    readings, truth = block.outputs[0][:, :3], block.outputs[1][:, :3]
    design = np.column_stack([truth / 3e-5, np.ones(len(truth))])  # scaled columns
    solution, *_ = np.linalg.lstsq(design, readings, rcond=None)
    C, b = solution[:3].T / 3e-5, solution[3]
    np.testing.assert_allclose((np.diag(C) - 1.0) / PPM, scale, rtol=0, atol=1e-7)
    np.testing.assert_allclose((C - np.diag(np.diag(C))) / ARCSEC, misalignment, rtol=0, atol=2e-8)
    np.testing.assert_allclose(b, bias, rtol=0, atol=1e-18)
    # the covariance is the white noise's (none here): "unknown", as the message says
    np.testing.assert_array_equal(block.outputs[0][:, 3:], 0.0)


def test_magnetometer_quantization_steps_exactly_one_lsb_and_saturation_clips():
    """
    Read a slow turn with a 100 nT LSB and a 20 000 nT range, and with the range alone.

    0.005 rad/s at 5 Hz: the field changes under 50 nT a sample, the orbit's own change included.
    Every reading is a whole number of LSBs (to the rounding of the product, 1e-15), consecutive
    codes differ by at most one, within half an LSB of the truth inside the range; the rails are
    +-200 codes; without quantization the reading is the truth clipped, exactly.
    """
    lsb, limit = 100 * NT, 20_000 * NT
    effects = [
        {'magnetometer': {'quantization': lsb, 'saturation': limit, 'topic': 'q'}},
        {'magnetometer': {'saturation': limit, 'topic': 'clip'}},
        {'magnetometer': {'topic': 'truth'}},
    ]
    block = _block(_scene(effects, omega=(0.002, -0.003, 0.0035)), 3000, rate=5.0)
    quantized, clipped, truth = (rows[:, :3] for rows in block.outputs)
    assert np.abs(np.diff(truth, axis=0)).max() < 0.5 * lsb  # the premise: slower than an LSB
    codes = np.round(quantized / lsb)
    np.testing.assert_allclose(quantized, codes * lsb, rtol=1e-15, atol=0)
    steps = np.diff(codes, axis=0)
    assert set(np.unique(steps).tolist()) == {-1.0, 0.0, 1.0}
    for axis in range(3):  # no code skipped between an axis's extremes
        seen = np.unique(codes[:, axis])
        np.testing.assert_array_equal(seen, np.arange(seen[0], seen[-1] + 1))
    assert codes.max() == 200 and codes.min() == -200  # 20 000 nT / 100 nT
    inside = np.abs(truth) < limit - lsb
    assert np.all(np.abs(quantized - truth)[inside] <= 0.5 * lsb * (1 + 1e-9))
    np.testing.assert_array_equal(codes[truth > limit + lsb], 200)
    np.testing.assert_array_equal(codes[truth < -(limit + lsb)], -200)
    np.testing.assert_array_equal(clipped, np.clip(truth, -limit, limit))
    assert (truth > limit).sum() > 50 and (truth < -limit).sum() > 50
    # REP 145's reading of the covariance: the rounding error, uniform over one LSB
    np.testing.assert_allclose(
        block.outputs[0][0, 3:].reshape(3, 3), np.eye(3) * lsb**2 / 12, rtol=1e-14
    )


FULL_MAGNETOMETER = {
    'noise': 40 * NT,
    'bias': [100 * NT, -50 * NT, 20 * NT],
    'scale_factor': [200.0, -100.0, 50.0],
    'misalignment': [[0.0, 30.0, -20.0], [10.0, 0.0, 40.0], [-25.0, 5.0, 0.0]],
    'saturation': 60_000 * NT,
    'quantization': 10 * NT,
    'seed': 11,
}
FULL_SUN_SENSOR = {
    'noise': 0.05,
    'bias': [0.3, -0.2, 0.1],
    'misalignment': [600.0, -300.0, 900.0],
    'field_of_view': 70.0,
    'quantization': 0.02,
    'boresight': [1.0, 0.0, 1.0],
    'seed': 5,
}


@pytest.mark.parametrize(
    'name, parameters', [('magnetometer', FULL_MAGNETOMETER), ('sun_sensor', FULL_SUN_SENSOR)]
)
def test_the_full_models_are_seeded_and_give_the_same_bytes_however_blocks_are_cut(
    name, parameters
):
    scene = _scene([{name: parameters}])
    whole = _block(scene, 300).outputs[0]
    assert np.count_nonzero(whole.any(axis=1)) > 50  # readings to compare, not only "no Sun"
    simulation = Simulation(scene.propagator(), 2.0, outputs=scene.outputs)
    cuts = [0, 1, 2, 7, 64, 65, 200, 300]
    pieces = [simulation.samples(a, b - a).outputs[0] for a, b in zip(cuts, cuts[1:])]
    assert np.vstack(pieces).tobytes() == whole.tobytes()
    assert simulation.samples(100, 20).outputs[0].tobytes() == whole[100:120].tobytes()  # back
    assert _block(_scene([{name: parameters}]), 300).outputs[0].tobytes() == whole.tobytes()
    other = _block(_scene([{name: {**parameters, 'seed': 12}}]), 300).outputs[0]
    assert not np.array_equal(other, whole)


# -- sun sensor -----------------------------------------------------------------------------------


def _sensor_basis(boresight):
    """``e1, e2, b`` as documented: e1 across b and the body axis least aligned with it."""
    b = np.asarray(boresight, float) / np.linalg.norm(boresight)
    e1 = np.cross(b, np.eye(3)[np.argmin(np.abs(b))])
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(b, e1), b


def test_the_sun_sensor_turns_the_direction_by_its_misalignment_and_bias():
    """
    ``exp(c) exp(-m) s_B`` by scipy, to 1e-15; the field of view moves with the sensor frame.

    A 2 deg misalignment about the x axis moves the cone's edge by up to 2 deg: the samples it
    moves across are counted, and the mask is the angle of the sensor-frame direction from the
    boresight (scipy) against the half-angle, no sample within 1e-9 rad of the edge.
    """
    m = np.array([7200.0, 0.0, 0.0])  # arcsec
    c = np.array([0.4, -0.3, 0.2])  # deg
    fov, boresight = 50.0, np.array([0.0, 1.0, 1.0]) / math.sqrt(2.0)
    sensors = [
        {'sun_sensor': {'misalignment': m.tolist(), 'topic': 'm'}},
        {'sun_sensor': {'bias': c.tolist(), 'misalignment': m.tolist(), 'topic': 'mc'}},
        {'sun_sensor': {'field_of_view': fov, 'boresight': [0, 2, 2], 'misalignment': m.tolist(),
                        'topic': 'fov'}},
        {'sun_sensor': {'topic': 'truth'}},
    ]
    block = _block(_scene(sensors), 600)
    mounted, biased, limited, truth = block.outputs
    assert (np.linalg.norm(truth, axis=1) > 0.5).all()  # lit throughout
    unmount = Rotation.from_rotvec(m * ARCSEC).inv()
    in_sensor = unmount.apply(truth)
    np.testing.assert_allclose(mounted, in_sensor, rtol=0, atol=1e-15)
    np.testing.assert_allclose(
        biased, Rotation.from_rotvec(c * DEG).apply(in_sensor), rtol=0, atol=1e-15
    )
    angle = np.arccos(np.clip(in_sensor @ boresight, -1.0, 1.0))
    assert np.abs(angle - fov * DEG).min() > 1e-9
    inside = angle <= fov * DEG
    np.testing.assert_array_equal(limited[inside], mounted[inside])
    np.testing.assert_array_equal(limited[~inside], 0.0)
    unmounted_inside = np.arccos(np.clip(truth @ boresight, -1.0, 1.0)) <= fov * DEG
    assert (inside != unmounted_inside).sum() >= 3  # the misalignment moved the edge


def test_the_sun_sensor_quantizes_its_two_angles_to_whole_lsbs():
    """
    Read whole LSBs in the two angles, within half an LSB of the unquantized reading's.

    Each reading's ``atan2(s . e1, s . b)`` and ``atan2(s . e2, s . b)`` (basis built here) are
    whole LSBs (to 1e-12 of an LSB: the tangent and its inverse round at 1e-16 rad), and the
    reading is a unit vector (to 4e-16).
    """
    lsb, fov = 0.05, 80.0
    common = {'field_of_view': fov, 'boresight': [1.0, 1.0, 1.0], 'bias': [0.2, 0.0, -0.1]}
    sensors = [
        {'sun_sensor': {**common, 'quantization': lsb, 'topic': 'q'}},
        {'sun_sensor': {**common, 'topic': 'exact'}},
    ]
    block = _block(_scene(sensors), 600)
    quantized, exact = block.outputs
    seen = np.linalg.norm(exact, axis=1) > 0.5
    assert 100 < seen.sum() < 500
    np.testing.assert_array_equal(quantized[~seen], 0.0)
    e1, e2, b = _sensor_basis([1.0, 1.0, 1.0])
    for axis in (e1, e2):
        codes = np.arctan2(quantized[seen] @ axis, quantized[seen] @ b) / (lsb * DEG)
        np.testing.assert_allclose(codes, np.round(codes), rtol=0, atol=1e-12)
        true = np.arctan2(exact[seen] @ axis, exact[seen] @ b) / (lsb * DEG)
        assert np.abs(codes - true).max() <= 0.5 + 1e-9
        assert len(np.unique(np.round(codes))) > 20  # many codes crossed
    np.testing.assert_allclose(np.linalg.norm(quantized[seen], axis=1), 1.0, atol=4e-16)


def test_a_quantized_reading_turned_behind_the_sensor_is_no_sun():
    """
    Send the zero vector, as in an eclipse, for readings turned behind the sensor.

    A 60 deg bias turns readings near the 80 deg edge behind the sensor (``s . b <= 0``); the
    others carry a unit vector.
    """
    common = {'field_of_view': 80.0, 'boresight': [0.0, 0.0, 1.0], 'bias': [60.0, 0.0, 0.0]}
    sensors = [
        {'sun_sensor': {**common, 'quantization': 0.1, 'topic': 'q'}},
        {'sun_sensor': {**common, 'topic': 'exact'}},
    ]
    quantized, exact = _block(_scene(sensors), 600).outputs
    behind = (np.linalg.norm(exact, axis=1) > 0.5) & (exact[:, 2] <= 0.0)
    assert behind.sum() > 5
    np.testing.assert_array_equal(quantized[behind], 0.0)
    seen = (np.linalg.norm(exact, axis=1) > 0.5) & ~behind
    np.testing.assert_allclose(np.linalg.norm(quantized[seen], axis=1), 1.0, atol=4e-16)


# -- star tracker's exclusion angles -----------------------------------------------------------


TRACKER = {'cross_boresight_noise': 5.0, 'about_boresight_noise': 40.0, 'seed': 7}


def _truth_angles(block, scene, boresight):
    """
    Return the boresight's angles (rad) from the Sun's centre and the nadir, and the limb's.

    The Sun from ``environment.sun``, the orbit by bisection, the attitude turned by scipy.
    """
    position = kepler_position(LIT, block.times)
    pointing = Rotation.from_quat(block.q_NB).apply(boresight)
    towards = sun.sun_position(scene.orbit.start + block.times) - position

    def angle(a, b):
        cosine = (a * b).sum(axis=1) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
        return np.arccos(np.clip(cosine, -1.0, 1.0))

    limb = np.arcsin(EARTH_RADIUS / np.linalg.norm(position, axis=1))
    return angle(pointing, towards), angle(pointing, -position), limb


@pytest.mark.parametrize('which', ['sun', 'earth'])
def test_the_star_tracker_has_no_solution_exactly_while_the_sun_or_the_earth_is_in_its_cone(which):
    """
    The exclusion half-angle is the median of the run's angles: about half the samples are lost.

    Sun: the angle between the boresight (turned by the true attitude, scipy) and the direction
    from the body to the Sun's centre under ``sun_exclusion``; Earth: the angle to the nadir under
    ``earth_exclusion`` plus the Earth's angular radius (its limb). No sample lies within 1e-7 rad
    of the threshold (the ephemeris and the orbit agree to 1e-12 rad here, the threshold's
    arccos to 1e-8 rad), so the comparison is not one of rounding. With a latency of 2 samples,
    the mask of the sample imaged.
    """
    count, boresight = 1200, np.array([1.0, -1.0, 2.0]) / math.sqrt(6.0)
    base = {**TRACKER, 'boresight': boresight.tolist()}
    plain = _scene([{'star_tracker': base}])
    truth = _block(plain, count)
    sun_angle, nadir_angle, limb = _truth_angles(truth, plain, boresight)
    if which == 'sun':
        threshold = float(np.median(sun_angle))
        margin = sun_angle - threshold
    else:
        threshold = float(np.median(nadir_angle - limb))
        margin = nadir_angle - limb - threshold
    assert np.abs(margin).min() > 1e-7
    inside = margin < 0.0
    assert 400 < inside.sum() < 800
    for delay in (0, 2):
        tracker = {**base, f'{which}_exclusion': threshold / DEG, 'latency_samples': delay}
        rows = _block(_scene([{'star_tracker': tracker}]), count).outputs[0]
        imaged = np.concatenate([np.ones(delay, bool), inside[: count - delay]])
        lost = rows[:, 4] == -1.0
        np.testing.assert_array_equal(lost, imaged)
        np.testing.assert_array_equal(rows[lost, 0:4], 0.0)  # as the max_rate outage
        np.testing.assert_array_equal(rows[lost, 5:13], 0.0)
        delayed = np.concatenate([np.zeros((delay, rows.shape[1])), truth.outputs[0]])[:count]
        np.testing.assert_array_equal(rows[~lost], delayed[~lost])  # the draws go on


def test_the_exclusions_and_max_rate_add_up():
    """Lost exactly where any of the three says so (each tracker alone gives its own mask)."""
    effects = [
        {'star_tracker': {**TRACKER, 'sun_exclusion': 60.0, 'topic': 'a'}},
        {'star_tracker': {**TRACKER, 'earth_exclusion': 20.0, 'topic': 'b'}},
        {'star_tracker': {**TRACKER, 'max_rate': 7.2, 'topic': 'c'}},
        {'star_tracker': {
            **TRACKER, 'sun_exclusion': 60.0, 'earth_exclusion': 20.0, 'max_rate': 7.2,
            'topic': 'd',
        }},
    ]
    block = _block(_scene(effects, omega=(0.05, -0.08, 0.09)), 1000)  # |w| 6.86-7.63 deg/s
    a, b, c, d = ((rows[:, 4] == -1.0) for rows in block.outputs)
    for mask in (a, b, c):
        assert 0 < mask.sum() < 1000
    np.testing.assert_array_equal(d, a | b | c)


@pytest.mark.parametrize(
    'orbit, effect, where, reason',
    [
        (None, {'star_tracker': {'sun_exclusion': 30.0}}, 'star_tracker.sun_exclusion',
         "needs the scene's orbit"),
        (None, {'star_tracker': {'earth_exclusion': 30.0, 'max_rate': 2.0}},
         'star_tracker.earth_exclusion', "needs the scene's orbit"),
        (LIT, {'star_tracker': {'sun_exclusion': 0.0}}, 'star_tracker.sun_exclusion',
         'must be > 0 deg'),
        (LIT, {'star_tracker': {'earth_exclusion': 200.0}}, 'star_tracker.earth_exclusion',
         'must be <= 180 deg'),
        (LIT, {'magnetometer': {'misalignment': [[0, 1, 2], [3, 4, 5], [6, 7, 0]]}},
         'magnetometer.misalignment[1][1]', 'the diagonal must be 0'),
        (LIT, {'magnetometer': {'misalignment': [[0, 1, 2]]}}, 'magnetometer.misalignment',
         'expected 3 rows of 3 numbers (arcsec), got 1'),
        (LIT, {'magnetometer': {'scale_factor': [0.0, -1e6, 0.0]}}, 'magnetometer.scale_factor',
         'every entry must be > -1e6 ppm'),
        (LIT, {'magnetometer': {'quantization': 0.0}}, 'magnetometer.quantization',
         'must be >= 1e-15 T'),
        (LIT, {'magnetometer': {'saturation': -1e-5}}, 'magnetometer.saturation',
         'must be > 0 T'),
        (LIT, {'magnetometer': {'quantization': 1e-5, 'saturation': 5e-6}},
         'magnetometer.quantization',
         'one LSB (1e-05 T) must not exceed the saturation (5e-06 T)'),
        (LIT, {'sun_sensor': {'quantization': 0.1}}, 'sun_sensor.quantization',
         'need a field_of_view under 90 deg (a two-axis sensor sees less than a hemisphere), '
         'got none'),
        (LIT, {'sun_sensor': {'quantization': 0.1, 'field_of_view': 90.0}},
         'sun_sensor.quantization', 'got 90 deg'),
        (LIT, {'sun_sensor': {'quantization': 0.0, 'field_of_view': 60.0}},
         'sun_sensor.quantization', 'must be > 0 deg'),
        (LIT, {'sun_sensor': {'bias': [1.0, 2.0]}}, 'sun_sensor.bias', 'expected 3 numbers'),
        (LIT, {'sun_sensor': {'misalignment': [float('inf'), 0.0, 0.0]}},
         'sun_sensor.misalignment', 'finite'),
    ],
)
def test_bad_sensor_parameters_are_refused_with_the_field_path(orbit, effect, where, reason):
    with pytest.raises(SceneError) as refused:
        _scene([{'imu': {}}, effect], orbit=orbit)
    assert f's.yaml: effects[1].{where}: ' in str(refused.value)
    assert reason in str(refused.value)
