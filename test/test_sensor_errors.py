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
The gyro's datasheet error model and the star tracker's outages (issue 42).

The references are independent of the code under test: allantools' overlapping Allan deviation (a
library nobody here wrote) read against IEEE Std 952-1997's Allan variance of each noise term; the
datasheet units converted here from their definitions; least squares (numpy) over a rate table;
the draws re-made here from the documented seeds with plain recursions; ``|w|`` summed here from
the propagator's truth.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping, SceneError

# the datasheet units, from their definitions (not from the code's table)
DEG = math.pi / 180.0
DEG_PER_SQRT_HOUR = DEG / 60.0  # deg/sqrt(h) = deg / sqrt(3600 s): rad/s/sqrt(Hz)
DEG_PER_HOUR_SQRT_HOUR = DEG / 3600.0 / 60.0  # deg/h/sqrt(h): rad/s/sqrt(s)
DEG_PER_HOUR = DEG / 3600.0
ARCSEC = DEG / 3600.0
PPM = 1e-6
FLICKER = math.sqrt(2.0 * math.log(2.0) / math.pi)  # IEEE 952: a flicker floor is 0.664 B


def _scene(effects, inertia=(3.0, 2.0, 1.0), angular_velocity=(0.3, 0.2, 1.0)):
    return scene_from_mapping(
        {
            'body': {'inertia': list(inertia)},
            'initial': {'angular_velocity': list(angular_velocity)},
            'effects': list(effects),
        }
    )


def _simulation(scene, rate):
    return Simulation(scene.propagator(), rate, outputs=scene.outputs)


def _gauss_markov_allan_variance(tau, sigma, T):
    """IEEE 952 (C.16): the Allan variance of a first-order Gauss-Markov process."""
    x = tau / T
    with np.errstate(under='ignore'):  # exp(-x) of x >> 1 is 0, as it should be
        decay = 3.0 - 4.0 * np.exp(-x) + np.exp(-2.0 * x)
    return sigma**2 * (2.0 / x) * (1.0 - decay / (2.0 * x))


def _gauss_markov_peak():
    """Return ``(x, ADEV / sigma)`` at the maximum of (C.16) over ``x = tau / T``."""
    from scipy.optimize import minimize_scalar

    best = minimize_scalar(
        lambda x: -_gauss_markov_allan_variance(x, 1.0, 1.0),
        bounds=(0.5, 5.0),
        method='bounded',
        options={'xatol': 1e-10},
    )
    return best.x, math.sqrt(-best.fun)


def _static_record(effect, rate, count, block=1 << 16):
    """Return ``count`` samples of the angular velocity ``effect`` reads on a body at rest."""
    simulation = _simulation(_scene([effect], angular_velocity=(0.0, 0.0, 0.0)), rate)
    record = np.empty((count, 3))
    for first in range(0, count, block):
        size = min(block, count - first)
        record[first: first + size] = simulation.samples(first, size).outputs[0][:, 13:16]
    return record


def _allan(record, rate, taus):
    """Return allantools' overlapping Allan deviation: ``(taus used, mean over the axes)``."""
    import allantools

    results = [
        allantools.oadev(record[:, axis], rate=rate, data_type='freq', taus=taus)
        for axis in range(3)
    ]
    return results[0][0], np.mean([deviation for _, deviation, _, _ in results], axis=0)


# a tactical-grade gyro's datasheet, scaled so that every term has its own decade of tau
ARW, RRW, B, T = 0.17, 16.0, 10.0, 50.0  # deg/sqrt(h), deg/h/sqrt(h), deg/h, s
DATASHEET = {
    'angle_random_walk': ARW,
    'rate_random_walk': RRW,
    'bias_instability': B,
    'bias_correlation_time': T,
    'seed': 2026,
}


def test_the_allan_deviation_of_a_static_gyro_reads_its_datasheet():
    """
    ARW at 1 s, the -1/2 and +1/2 slopes, the bias-instability floor (allantools, IEEE 952).

    N = 0.17 deg/sqrt(h) = 4.95e-5 rad/s/sqrt(Hz), K = 16 deg/h/sqrt(h) = 1.29e-6 rad/s/sqrt(s),
    the floor F = 0.664 B = 3.22e-5 rad/s. By IEEE 952 the terms' Allan variances add: N^2 / tau,
    the Gauss-Markov's (C.16) with its peak F at tau = 1.89 T = 94.6 s, K^2 tau / 3. Each is read
    where it holds the curve:

    * record A, 20 Hz for 20 000 s (400 000 samples): at tau = 1 s the other terms add 1.5 % of
      N^2 (ADEV 0.7 % high), an estimate over 20 000 intervals on 3 axes scatters 0.4 %: 5 % is
      the tolerance the issue asks. From 0.05 s to 0.5 s the fitted slope is -0.499 by IEEE 952,
      scattering < 0.002: within 0.02 of -1/2;
    * record B, 0.5 Hz for 8e6 s (4 million samples): at 1.89 T, ARW and RRW add 2.5 % and 5 % of
      F^2 (the reading is 3.7 % high), scattering 0.15 % (84 000 intervals): the issue's 10 %.
      From 5 000 s to 80 000 s the rate random walk holds >= 98 % of the Allan variance (100 to
      1 600 intervals of tau); the fitted slope is 0.497 by IEEE 952, and its estimates were
      0.487 +- 0.013 over 12 seeds (the log of a scattered estimate leans low): within 0.075 of
      +1/2 (their 0.013 below it plus 4.7 of that scatter).

    About 3 s of CPU, most of it record B's 4 million samples (a static body's analytic
    propagation, the gyro model, then allantools).
    """
    imu = {'imu': DATASHEET}
    N = ARW * DEG_PER_SQRT_HOUR
    K = RRW * DEG_PER_HOUR_SQRT_HOUR
    floor = FLICKER * B * DEG_PER_HOUR
    peak_x, peak = _gauss_markov_peak()
    sigma = floor / peak  # the Gauss-Markov whose Allan deviation peaks at the floor

    def expected(tau):  # IEEE 952: the Allan variances of independent terms add
        tau = np.asarray(tau, float)
        return np.sqrt(N**2 / tau + _gauss_markov_allan_variance(tau, sigma, T) + K**2 * tau / 3)

    fast = 20.0
    taus, adev = _allan(_static_record(imu, fast, 400_000), fast, [0.05, 0.1, 0.2, 0.3, 0.5, 1.0])
    assert taus[-1] == 1.0
    assert expected(1.0) / N == pytest.approx(1.0074, abs=5e-4)  # the bias the note above names
    assert adev[-1] == pytest.approx(N, rel=0.05)
    short = np.polyfit(np.log(taus[:-1]), np.log(adev[:-1]), 1)[0]
    assert np.polyfit(np.log(taus[:-1]), np.log(expected(taus[:-1])), 1)[0] == pytest.approx(
        -0.499, abs=1e-3
    )
    assert short == pytest.approx(-0.5, abs=0.02)

    slow = 0.5
    long_taus = np.geomspace(5_000.0, 80_000.0, 7)
    taus, adev = _allan(
        _static_record(imu, slow, 4_000_000), slow, np.concatenate([[peak_x * T], long_taus])
    )
    at_peak = taus[0]  # 94 s: the nearest whole number of 2 s samples to 94.6 s
    assert at_peak == pytest.approx(peak_x * T, abs=1.0)
    assert expected(at_peak) / floor == pytest.approx(1.037, abs=2e-3)  # the bias named above
    assert adev[0] == pytest.approx(floor, rel=0.10)
    share = (K**2 * taus[1:] / 3) / expected(taus[1:]) ** 2
    assert share.min() >= 0.98  # where the rate random walk must show its slope
    long = np.polyfit(np.log(taus[1:]), np.log(adev[1:]), 1)[0]
    assert np.polyfit(np.log(taus[1:]), np.log(expected(taus[1:])), 1)[0] == pytest.approx(
        0.497, abs=1e-3
    )
    assert long == pytest.approx(0.5, abs=0.075)


def test_the_flicker_constants_are_ieee_952s():
    """Check 0.664 = sqrt(2 ln 2 / pi) and the Gauss-Markov peak, (C.16)'s maximum found here."""
    from torquefree_ros.core.effects.sensors import FLICKER_FLOOR, GM_PEAK, GM_PEAK_TAU

    peak_x, peak = _gauss_markov_peak()
    assert FLICKER_FLOOR == pytest.approx(0.6643, abs=1e-4)
    assert GM_PEAK == pytest.approx(peak, rel=1e-9)  # the optimiser's xatol leaves ~1e-20 here
    assert GM_PEAK_TAU == pytest.approx(peak_x, rel=1e-6)  # and ~1e-10 here


@pytest.mark.parametrize('per_correlation_time', [1, 4])
def test_the_gauss_markov_bias_is_exact_at_the_output_period(per_correlation_time):
    """
    beta_k: variance sigma^2 and lag-1 correlation exp(-dt / T) at dt = T and T / 4.

    An Euler step (phi = 1 - dt / T, drive sigma sqrt(2 dt / T)) would give 0 and 2 sigma^2 at
    dt = T. 200 000 samples on 3 axes: the variance's relative scatter is sqrt(2 (1 + phi^2) /
    (n (1 - phi^2))) <= 0.5 % (phi = 0.78 at T / 4), the correlation's sqrt((1 - phi^2) / n)
    <= 0.2 %; tolerances 3 % and 0.01.
    """
    B_, T_ = 20.0, 2.0  # deg/h, s
    rate = per_correlation_time / T_
    record = _static_record(
        {'imu': {'bias_instability': B_, 'bias_correlation_time': T_, 'seed': 4}},
        rate,
        200_000,
    )
    _, peak = _gauss_markov_peak()
    sigma = FLICKER * B_ * DEG_PER_HOUR / peak
    phi = math.exp(-1.0 / per_correlation_time)
    assert record.var(axis=0).mean() == pytest.approx(sigma**2, rel=0.03)
    correlation = np.mean(
        [np.corrcoef(record[:-1, axis], record[1:, axis])[0, 1] for axis in range(3)]
    )
    assert correlation == pytest.approx(phi, abs=0.01)


def test_the_rate_random_walk_is_exact_at_the_output_period():
    """Check increments of variance K^2 dt at 0.1 Hz: 200 000 x 3 of them, 0.2 % scatter."""
    rate = 0.1
    record = _static_record({'imu': {'rate_random_walk': RRW, 'seed': 8}}, rate, 200_000)
    K = RRW * DEG_PER_HOUR_SQRT_HOUR
    assert np.diff(record, axis=0).var(axis=0).mean() == pytest.approx(K**2 / rate, rel=0.02)


def test_the_draws_are_the_documented_ones_and_old_scenes_give_the_same_numbers():
    """
    The gyro's rows re-made here from the documented seeds with plain recursions, bit for bit.

    White noise and walk: 6 normals a sample from PCG64(seed), as the first imu drew them (so the
    library's ``imu`` scene, SI keys only, gives the numbers it always gave); the Gauss-Markov bias
    from SeedSequence(seed, spawn_key=(1,)), the turn-on bias from spawn_key=(2,).
    """
    rate, count, seed = 50.0, 400, 42
    N, K, initial = 1e-4, 1e-5, [0.002, -0.001, 0.0005]
    sigma_on = 50.0 * DEG_PER_HOUR
    # the code's constant (checked against IEEE 952 above): the same floats are the point here
    sigma = FLICKER * 8.0 * DEG_PER_HOUR / 0.6173642831
    ratio = (1.0 / rate) / 30.0  # dt / T
    phi = math.exp(-ratio)
    imu = {
        'gyro_noise_density': N,
        'gyro_bias_random_walk': K,
        'initial_bias': initial,
        'bias_instability': 8.0,
        'bias_correlation_time': 30.0,
        'turn_on_bias': 50.0,
        'seed': seed,
    }
    block = _simulation(_scene([{'imu': imu}]), rate).samples(0, count)
    legacy = np.random.Generator(np.random.PCG64(seed)).standard_normal((count, 6))

    def spawned(key):
        sequence = np.random.SeedSequence(seed, spawn_key=(key,))
        return np.random.Generator(np.random.PCG64(sequence))

    markov = spawned(1).standard_normal((count, 3))
    walk = np.array(initial) + sigma_on * spawned(2).standard_normal(3)
    drive = sigma * math.sqrt(-math.expm1(-2.0 * ratio))  # sigma sqrt(1 - phi^2)
    expected = np.empty((count, 3))
    beta = sigma * markov[0]
    for k in range(count):
        if k:
            walk = walk + K * math.sqrt(1.0 / rate) * legacy[k, 3:]
            beta = phi * beta + drive * markov[k]
        expected[k] = block.omega_B[k] + (walk + beta) + N * math.sqrt(rate) * legacy[k, :3]
    np.testing.assert_array_equal(block.outputs[0][:, 13:16], expected)

    from torquefree_ros import load_scene

    scene = load_scene('imu')  # SI keys only: white noise, walk, initial bias
    (old,) = [effect.values for effect in scene.outputs if effect.name == 'imu']
    block = Simulation(scene.propagator(), rate, outputs=scene.outputs).samples(0, count)
    legacy = np.random.Generator(np.random.PCG64(old['seed'])).standard_normal((count, 6))
    walk = np.array(old['initial_bias'])
    for k in range(count):
        if k:
            walk = walk + old['gyro_bias_random_walk'] * math.sqrt(1.0 / rate) * legacy[k, 3:]
        expected[k] = (
            block.omega_B[k] + walk + old['gyro_noise_density'] * math.sqrt(rate) * legacy[k, :3]
        )
    np.testing.assert_array_equal(block.outputs[0][:, 13:16], expected)


def test_scale_factor_and_misalignment_are_recovered_from_a_rate_table():
    """
    A sphere (every axis principal: a spin stays put) at 14 known rates, noise off.

    Least squares of the readings on the rates gives ``I + S + M``: the scene's ppm and arcsec
    within rounding (1e-12 of unity, 1e-6 ppm or 2e-7 arcsec).
    """
    scale = [120.0, -80.0, 300.0]  # ppm
    misalignment = [[0.0, 20.0, -15.0], [35.0, 0.0, 8.0], [-40.0, 12.0, 0.0]]  # arcsec
    imu = {'imu': {'scale_factor': scale, 'misalignment': misalignment}}
    table = 30.0 * DEG * np.array(
        [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]
        + [[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (1,)]
        + [[1, 1, 0], [0, 1, -1], [1, 0, 1], [-1, 2, 1]]
    )
    rates, readings = [], []
    for w in table:
        block = _simulation(_scene([imu], (2.0, 2.0, 2.0), w), 10.0).samples(0, 5)
        np.testing.assert_allclose(block.omega_B, np.tile(w, (5, 1)), rtol=1e-12, atol=1e-15)
        rates.append(block.omega_B)
        readings.append(block.outputs[0][:, 13:16])
    solution, *_ = np.linalg.lstsq(np.vstack(rates), np.vstack(readings), rcond=None)
    C = solution.T  # readings = rates @ C^T
    np.testing.assert_allclose((np.diag(C) - 1.0) / PPM, scale, rtol=0, atol=1e-6)
    off = C - np.diag(np.diag(C))
    np.testing.assert_allclose(off / ARCSEC, misalignment, rtol=0, atol=2e-7)


# a sphere (I = 2 kg m^2) spun up about z from -3 deg/s to +3 deg/s in 60 s: 0.002 deg/s a sample
# at 50 Hz, a fifth of a 0.01 deg/s LSB
RAMP = {'inertia': (2.0, 2.0, 2.0), 'angular_velocity': (0.0, 0.0, -3.0 * DEG)}
RAMP_TORQUE = {'external_torque': {'torque': [0.0, 0.0, 2.0 * 0.1 * DEG], 'frame': 'body'}}


def test_quantization_steps_exactly_one_lsb_and_saturation_clips():
    lsb, saturation = 0.01, 2.0  # deg/s
    quantized = _scene(
        [RAMP_TORQUE, {'imu': {'quantization': lsb, 'saturation': saturation}}], **RAMP
    )
    block = _simulation(quantized, 50.0).samples(0, 3001)
    quantized_rows = block.outputs[0]
    w = block.omega_B[:, 2]
    assert w[0] == -3.0 * DEG and w[-1] == pytest.approx(3.0 * DEG, rel=1e-9)
    z = block.outputs[0][:, 15]
    codes = np.round(z / (lsb * DEG))
    # every reading a whole number of LSBs (to the rounding of LSB's own product, 1e-15), the
    # codes +-200 at the rails (2 deg/s / 0.01 deg/s)
    np.testing.assert_allclose(z, codes * lsb * DEG, rtol=1e-15, atol=0)
    assert codes.min() == -200 and codes.max() == 200
    steps = np.diff(codes)
    assert set(steps.tolist()) == {0.0, 1.0}  # a rising ramp: steps of exactly one LSB
    assert np.array_equal(np.unique(codes), np.arange(-200, 201))  # no code skipped
    inside = np.abs(w) < (saturation - lsb) * DEG
    # within half an LSB of the rate (rounding to the nearest), the rails beyond the saturation
    assert np.all(np.abs(z[inside] - w[inside]) <= 0.5 * lsb * DEG * (1 + 1e-9))
    np.testing.assert_array_equal(codes[w > (saturation + lsb) * DEG], 200)
    np.testing.assert_array_equal(codes[w < -(saturation + lsb) * DEG], -200)
    np.testing.assert_array_equal(block.outputs[0][:, 13:15], 0.0)
    # REP 145: the rounding error, uniform over one LSB, is the reading's variance (no noise)
    np.testing.assert_allclose(
        block.outputs[0][0, 16:25].reshape(3, 3), np.eye(3) * (lsb * DEG) ** 2 / 12, rtol=1e-14
    )

    clip = _scene([RAMP_TORQUE, {'imu': {'saturation': saturation}}], **RAMP)
    block = _simulation(clip, 50.0).samples(0, 3001)
    w, z = block.omega_B[:, 2], block.outputs[0][:, 15]
    limit = saturation * DEG
    np.testing.assert_array_equal(z, np.where(w > limit, limit, np.where(w < -limit, -limit, w)))
    assert (w > limit).sum() > 100 and (w < -limit).sum() > 100
    # one sample at a time (a closed loop's lock-step takes another path): the same floats
    for scene, rows in ((quantized, quantized_rows), (clip, block.outputs[0])):
        single = _simulation(scene, 50.0)
        for k in (0, 1, 2, 1000, 1500, 2999):
            np.testing.assert_array_equal(single.samples(k, 1).outputs[0][0], rows[k])


def test_the_turn_on_bias_is_constant_within_a_run_and_drawn_per_seed():
    """
    At rest the reading is the turn-on bias, the same every sample and after a restart.

    300 seeds x 3 axes: the draws' standard deviation scatters sqrt(1 / 1800) = 2.4 %; 10 %.
    """
    sigma_on = 200.0  # deg/h
    biases = []
    for seed in range(300):
        imu = {'imu': {'turn_on_bias': sigma_on, 'seed': seed}}
        scene = _scene([imu], angular_velocity=(0.0, 0.0, 0.0))
        readings = _simulation(scene, 10.0).samples(0, 50).outputs[0][:, 13:16]
        assert np.all(readings == readings[0])
        if seed < 3:  # a new run of the same scene (a reset): the same draw
            again = _simulation(scene, 10.0)
            np.testing.assert_array_equal(again.samples(20, 5).outputs[0][:, 13:16], readings[:5])
        biases.append(readings[0])
    biases = np.array(biases)
    assert len({tuple(b) for b in biases}) == 300
    assert biases.std() == pytest.approx(sigma_on * DEG_PER_HOUR, rel=0.10)
    assert abs(biases.mean()) < 4 * sigma_on * DEG_PER_HOUR / math.sqrt(biases.size)


FULL_GYRO = {
    **DATASHEET,
    'angle_random_walk': 0.5,
    'turn_on_bias': 30.0,
    'scale_factor': [100.0, -200.0, 50.0],
    'misalignment': [[0.0, 30.0, -20.0], [10.0, 0.0, 40.0], [-25.0, 5.0, 0.0]],
    'saturation': 50.0,
    'quantization': 0.002,
}
TRACKER = {'cross_boresight_noise': 5.0, 'about_boresight_noise': 40.0, 'seed': 7}


@pytest.mark.parametrize('name, parameters', [('imu', FULL_GYRO), ('star_tracker', TRACKER)])
def test_latency_shifts_the_samples_exactly(name, parameters):
    """Sample k carries sample k - L's measurement; the first L carry none (REP 145's -1)."""
    latency, count = 3, 400
    now = _simulation(_scene([{name: parameters}]), 50.0).samples(0, count).outputs[0]
    late_scene = _scene([{name: {**parameters, 'latency_samples': latency}}])
    late = _simulation(late_scene, 50.0).samples(0, count).outputs[0]
    np.testing.assert_array_equal(late[latency:], now[:-latency])
    at = 4 if name == 'star_tracker' else 16  # the measured quantity's covariance
    values = slice(0, 4) if name == 'star_tracker' else slice(13, 16)
    np.testing.assert_array_equal(late[:latency, at], -1.0)
    np.testing.assert_array_equal(late[:latency, at + 1: at + 9], 0.0)
    np.testing.assert_array_equal(late[:latency, values], 0.0)
    # asked out of order (a skip back, a skip forward, a block shorter than the latency): the same
    simulation = _simulation(late_scene, 50.0)
    for first, size in ((0, 100), (50, 2), (52, 1), (300, 100), (10, 5), (399, 1)):
        np.testing.assert_array_equal(
            simulation.samples(first, size).outputs[0], late[first: first + size]
        )


def test_the_star_tracker_has_no_solution_exactly_while_the_rate_exceeds_max_rate():
    """
    The default body's |w| swings between 58.4 and 61.3 deg/s; max_rate is its median.

    No sample's |w| lies within 1e-6 of max_rate, so the comparison is not a question of rounding.
    """
    count, latency = 2000, 2
    truth = _simulation(_scene([{'star_tracker': TRACKER}]), 50.0).samples(0, count)
    speed = np.array([math.sqrt(x * x + y * y + z * z) for x, y, z in truth.omega_B.tolist()])
    max_rate = float(np.median(speed) / DEG)  # deg/s
    assert np.min(np.abs(speed / DEG - max_rate)) > 1e-6 * max_rate
    over = speed / DEG > max_rate
    assert 500 < over.sum() < 1500
    for delay in (0, latency):
        tracker = {**TRACKER, 'max_rate': max_rate, 'latency_samples': delay}
        rows = _simulation(_scene([{'star_tracker': tracker}]), 50.0).samples(0, count).outputs[0]
        imaged = np.concatenate([np.ones(delay, bool), over[: count - delay]])  # before: none
        lost = rows[:, 4] == -1.0
        np.testing.assert_array_equal(lost, imaged)
        np.testing.assert_array_equal(rows[lost, 0:4], 0.0)
        np.testing.assert_array_equal(rows[lost, 5:13], 0.0)
        # with a solution: the rows of the tracker without max_rate, delayed (the draws go on
        # whether or not there is a solution)
        delayed = np.concatenate([np.zeros((delay, rows.shape[1])), truth.outputs[0]])[:count]
        np.testing.assert_array_equal(rows[~lost], delayed[~lost])


def test_the_about_boresight_error_is_the_stated_multiple_of_the_cross_boresight_one():
    """
    10 000 samples: the ratio of the standard deviations about and across the boresight is 8.

    The noise rotation ``n`` of each sample from the published quaternion, ``q_NB^-1 q_meas =
    exp(n / 2)`` (scipy). With zero-mean normal draws, ``sum(n_about^2) / sigma_about^2`` is
    chi-square with N = 10 000 degrees of freedom and the two cross-boresight components' sum
    chi-square with 2N, independent: the ratio of the variances, divided by the stated 8^2, is
    F(N, 2N)-distributed. The bounds are its 1e-6 and 1 - 1e-6 quantiles (about 0.92 and 1.09):
    a correct model fails one run in 500 000.
    """
    from scipy.spatial.transform import Rotation
    from scipy.stats import f

    count, boresight = 10_000, np.array([1.0, 2.0, -2.0]) / 3.0
    tracker = {**TRACKER, 'boresight': boresight.tolist()}
    block = _simulation(_scene([{'star_tracker': tracker}]), 50.0).samples(0, count)
    turn = Rotation.from_quat(block.q_NB).inv() * Rotation.from_quat(block.outputs[0][:, 0:4])
    n = turn.as_rotvec()
    about = n @ boresight
    across = n - np.outer(about, boresight)
    ratio = (about**2).mean() / ((across**2).sum(axis=1).mean() / 2)
    stated = TRACKER['about_boresight_noise'] / TRACKER['cross_boresight_noise']
    low, high = f.ppf([1e-6, 1.0 - 1e-6], count, 2 * count)
    assert low * stated**2 <= ratio <= high * stated**2


def test_a_consumer_reads_no_estimate_in_the_messages():
    """Decode the published bytes with rclpy: orientation_covariance[0] = -1, no quaternion."""
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import Imu
    from torquefree_ros.bag.cdr import encode_stamped_doubles

    scene = _scene(
        [
            {'star_tracker': {**TRACKER, 'max_rate': 1.0}},  # 1 deg/s: always over it
            {'imu': {**FULL_GYRO, 'latency_samples': 1}},
        ]
    )
    block = _simulation(scene, 50.0).samples(0, 2)
    tracker, gyro = (
        [
            deserialize_message(message, Imu)
            for message in encode_stamped_doubles(block.stamps_ns, 'body', rows)
        ]
        for rows in block.outputs
    )
    for message in tracker:
        assert list(message.orientation_covariance) == [-1.0] + [0.0] * 8
        assert (message.orientation.x, message.orientation.y) == (0.0, 0.0)
        assert (message.orientation.z, message.orientation.w) == (0.0, 0.0)
        assert message.angular_velocity_covariance[0] == -1.0
    assert list(gyro[0].angular_velocity_covariance) == [-1.0] + [0.0] * 8  # latency: none yet
    assert gyro[1].angular_velocity_covariance[0] > 0.0
    assert gyro[1].angular_velocity.z == block.outputs[1][1, 15] != 0.0


def test_blocks_of_any_size_give_the_same_bytes():
    """The full gyro and the star tracker with latency and max_rate, each also at its own rate."""
    tracker = {**TRACKER, 'max_rate': 60.0, 'latency_samples': 2}  # |w|: 58.4 to 61.3 deg/s
    gyro = {**FULL_GYRO, 'latency_samples': 3}
    effects = [
        {'imu': gyro},
        {'star_tracker': tracker},
        {'imu': {**gyro, 'rate': 25.0, 'topic': 'imu_slow'}},
        {'star_tracker': {**tracker, 'rate': 10.0, 'topic': 'tracker_slow'}},
    ]
    scene = _scene(effects)
    whole = _simulation(scene, 50.0).samples(0, 1001).outputs
    assert 0 < (whole[1][:, 4] == -1.0).sum() < 1001  # some samples over 60 deg/s
    cuts = [0, 1, 2, 3, 7, 64, 65, 66, 300, 301, 1001]
    simulation = _simulation(scene, 50.0)
    pieces = [simulation.samples(a, b - a).outputs for a, b in zip(cuts, cuts[1:])]
    for j in range(len(effects)):
        assert np.vstack([piece[j] for piece in pieces]).tobytes() == whole[j].tobytes()
    # a closed loop's one sample at a time, the states first
    single = _simulation(scene, 50.0)
    rows = [single.with_outputs(single.samples(k, 1, outputs=False)).outputs for k in range(60)]
    for j, every in enumerate((1, 1, 2, 5)):
        stacked = np.vstack([r[j] for r in rows])
        assert stacked.tobytes() == whole[j][: -(-60 // every)].tobytes()
    # single samples past the gyro's draws made ahead (64 samples a chunk), blocks taking the rest
    # of a chunk, single samples again
    mixed = _simulation(scene, 50.0)
    sizes = [1] * 100 + [7, 1, 1, 300, 1, 65] + [1] * 70 + [2, 1, 453]
    firsts = np.cumsum([0] + sizes[:-1])
    pieces = [mixed.samples(int(a), n).outputs for a, n in zip(firsts, sizes)]
    assert firsts[-1] + sizes[-1] == 1001
    for j in (0, 2):  # the gyros
        assert np.vstack([piece[j] for piece in pieces]).tobytes() == whole[j].tobytes()


@pytest.mark.parametrize(
    'effect, parameters, reason',
    [
        (
            'imu',
            {'angle_random_walk': 0.1, 'gyro_noise_density': 1e-4},
            r'effects\[0\]\.imu\.angle_random_walk: the same term as gyro_noise_density',
        ),
        (
            'imu',
            {'rate_random_walk': 1.0, 'gyro_bias_random_walk': 1e-5},
            r'effects\[0\]\.imu\.rate_random_walk: the same term as gyro_bias_random_walk',
        ),
        (
            'imu',
            {'bias_instability': 5.0},
            r'effects\[0\]\.imu\.bias_correlation_time: missing: bias_instability needs',
        ),
        (
            'imu',
            {'bias_correlation_time': 100.0},
            r'effects\[0\]\.imu\.bias_correlation_time: does nothing without bias_instability',
        ),
        (
            'imu',
            {'bias_instability': 5.0, 'bias_correlation_time': 0.0},
            r'effects\[0\]\.imu\.bias_correlation_time: must be > 0 s',
        ),
        (
            'imu',
            {'angle_random_walk': -0.1},
            r'effects\[0\]\.imu\.angle_random_walk: must be >= 0 deg/sqrt\(h\)',
        ),
        (
            'imu',
            {'turn_on_bias': float('inf')},
            r'effects\[0\]\.imu\.turn_on_bias: expected a finite number deg/h',
        ),
        (
            'imu',
            {'misalignment': [[0, 1, 2], [3, 4, 5], [6, 7, 0]]},
            r'effects\[0\]\.imu\.misalignment\[1\]\[1\]: the diagonal must be 0',
        ),
        (
            'imu',
            {'misalignment': [[0, 1, 2], [3, 0, 5]]},
            r'effects\[0\]\.imu\.misalignment: expected 3 rows of 3 numbers \(arcsec\), got 2',
        ),
        (
            'imu',
            {'misalignment': [[0, 1], [3, 0, 5], [1, 2, 0]]},
            r'effects\[0\]\.imu\.misalignment\[0\]: expected 3 numbers, got 2',
        ),
        (
            'imu',
            {'scale_factor': [100.0, -1e6, 0.0]},
            r'effects\[0\]\.imu\.scale_factor: every entry must be > -1e6 ppm',
        ),
        ('imu', {'saturation': 0.0}, r'effects\[0\]\.imu\.saturation: must be > 0 deg/s'),
        (
            'imu',
            {'quantization': 0.0},
            r'effects\[0\]\.imu\.quantization: must be >= 1e-09 deg/s',
        ),
        (
            'imu',
            {'quantization': 1.0, 'saturation': 0.5},
            r'effects\[0\]\.imu\.quantization: one LSB \(1 deg/s\) must not exceed the '
            r'saturation \(0\.5 deg/s\)',
        ),
        (
            'imu',
            {'latency_samples': -1},
            r'effects\[0\]\.imu\.latency_samples: must lie in \[0, 100000\]',
        ),
        (
            'imu',
            {'latency_samples': 0.5},
            r'effects\[0\]\.imu\.latency_samples: expected an integer',
        ),
        (
            'star_tracker',
            {'max_rate': 0.0},
            r'effects\[0\]\.star_tracker\.max_rate: must be > 0 deg/s',
        ),
        (
            'star_tracker',
            {'max_rate': 'fast'},
            r'effects\[0\]\.star_tracker\.max_rate: expected a finite number deg/s',
        ),
        (
            'star_tracker',
            {'latency_samples': 200000},
            r'effects\[0\]\.star_tracker\.latency_samples: must lie in \[0, 100000\]',
        ),
    ],
)
def test_bad_parameters_are_refused_with_the_field_path(effect, parameters, reason):
    with pytest.raises(SceneError, match=reason):
        _scene([{effect: parameters}])


def test_the_gyro_covariance_is_the_white_noise_and_the_rounding_variance():
    """
    REP 145: diag(N^2 rate + LSB^2 / 12); ARW in deg/sqrt(h) is gyro_noise_density's term.

    The same N in either unit gives the same readings of a body at rest within the conversion's
    rounding: a few ulps of the noise.
    """
    rate, arw, lsb = 40.0, 0.2, 0.001  # Hz, deg/sqrt(h), deg/s
    N = arw * DEG_PER_SQRT_HOUR
    datasheet = _simulation(
        _scene([{'imu': {'angle_random_walk': arw, 'quantization': lsb, 'seed': 3}}]), rate
    )
    rows = datasheet.samples(0, 100).outputs[0]
    expected = N**2 * rate + (lsb * DEG) ** 2 / 12
    np.testing.assert_allclose(
        rows[:, 16:25], np.tile(np.eye(3).ravel() * expected, (100, 1)), rtol=1e-14
    )
    np.testing.assert_array_equal(rows[:, 4], -1.0)  # orientation not provided
    np.testing.assert_array_equal(rows[:, 28], -1.0)  # linear acceleration not provided
    at_rest = (0.0, 0.0, 0.0)
    si = _simulation(
        _scene([{'imu': {'gyro_noise_density': N, 'seed': 3}}], (1, 1, 1), at_rest), rate
    )
    in_degrees = _simulation(
        _scene([{'imu': {'angle_random_walk': arw, 'seed': 3}}], (1, 1, 1), at_rest), rate
    )
    np.testing.assert_allclose(
        in_degrees.samples(0, 100).outputs[0], si.samples(0, 100).outputs[0], rtol=1e-14, atol=0
    )
