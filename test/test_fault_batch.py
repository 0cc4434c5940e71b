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
The sensor faults of a batch applied at once (``core.faults.batch``) and the draws behind them.

References: each body's own ``FaultInjector`` applied to its row alone, one body after another
(the node's and the offline bag's path), which must agree bit for bit; numpy's own ``Philox``,
which the faults' vectorised rounds (``core.faults.draws.uniforms_at``) must reproduce bit for bit.
"""

from __future__ import annotations

import numpy as np
from torquefree_ros.core.faults.batch import FaultBatch
from torquefree_ros.core.faults.draws import fault_key, uniforms, uniforms_at
from torquefree_ros.core.faults.injector import FaultInjector
from torquefree_ros.core.faults.schedule import parse_faults
from torquefree_ros.core.scene.loader import scene_from_mapping

RATE = 10.0
EVERY = (1, 2, 1, 1)  # the star tracker at a rate of its own: its grid is every other sample
SAMPLES = 40  # samples of each output's own grid
BODIES = 200
SENSORS = ('imu', 'star_tracker', 'magnetometer', 'sun_sensor')


def _outputs(seed: int):
    effects = [{'imu': {'gyro_noise_density': 1e-4, 'seed': seed}},
               {'star_tracker': {'cross_boresight_noise': 5.0, 'seed': seed + 1,
                                 'rate': RATE / EVERY[1]}},
               {'magnetometer': {'noise': 1e-8, 'seed': seed + 2}},
               {'sun_sensor': {'noise': 0.01, 'seed': seed + 3}}]
    orbit = {'epoch': '2026-03-20T12:00:00Z', 'semi_major_axis': 6878137.0,
             'eccentricity': 0.001, 'inclination': 1.7, 'raan': 0.3,
             'argument_of_perigee': 0.5, 'mean_anomaly': 5.0}
    scene = scene_from_mapping({'body': {'inertia': [1.0, 2.0, 3.0]},
                                'initial': {'angular_velocity': [0.0, 0.0, 0.0]},
                                'orbit': orbit, 'effects': effects})
    return scene.outputs


def _random_faults(rng) -> list:
    """Return up to six faults of random kinds, outputs and windows (on a 0.1 s grid)."""
    faults = []
    for _ in range(int(rng.integers(0, 7))):
        output = SENSORS[int(rng.integers(4))]
        start = 0.1 * int(rng.integers(0, 30))
        window = {'output': output, 'start': start}
        if rng.random() < 0.7:
            window['end'] = start + 0.1 * int(rng.integers(1, 15))
        kind = ('stuck', 'stuck_value', 'bias', 'noise', 'spikes', 'spikes_period',
                'dropout')[int(rng.integers(7))]
        if kind == 'stuck_value':
            value = [0.0, 0.6, 0.0, 0.8] if output == 'star_tracker' else [1e-3, -2e-3, 3e-3]
            faults.append({'stuck': {**window, 'value': value}})
        elif kind == 'bias':
            faults.append({'bias': {**window, 'step': rng.normal(0.0, 1e-3, 3).tolist()}})
        elif kind == 'noise':
            faults.append({'noise': {**window, 'sigma': float(rng.uniform(1e-4, 1e-2))}})
        elif kind == 'spikes':
            faults.append({'spikes': {**window, 'magnitude': 0.01, 'probability': 0.4}})
        elif kind == 'spikes_period':
            faults.append({'spikes': {**window, 'magnitude': 0.02, 'period': 0.3}})
        else:
            faults.append({kind: window})
    return faults


def _raw_rows(rng, name: str) -> np.ndarray:
    """Return ``(SAMPLES, BODIES, width)`` sensor rows, some of them without a measurement."""
    shape = (SAMPLES, BODIES)
    if name in ('imu', 'star_tracker'):
        rows = rng.normal(0.0, 1.0, shape + (37,))
        if name == 'star_tracker':
            q = rng.normal(0.0, 1.0, shape + (4,))
            rows[..., 0:4] = q / np.linalg.norm(q, axis=-1, keepdims=True)
        column = 16 if name == 'imu' else 4
        rows[..., column] = np.where(rng.random(shape) < 0.1, -1.0, 1e-6)
        return rows
    if name == 'magnetometer':
        return rng.normal(0.0, 3e-5, shape + (12,))
    v = rng.normal(0.0, 1.0, shape + (3,))
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where((rng.random(shape) < 0.15)[..., None], 0.0, v)  # no Sun on some samples


def test_a_batch_of_200_bodies_is_each_body_s_injector_alone_bit_for_bit():
    rng = np.random.default_rng(42)
    injectors, acted = {}, set()
    for body in range(BODIES):
        outputs = _outputs(seed=10 * body)  # each body its own seeds: its own draws
        faults = parse_faults(_random_faults(rng), 'faults', outputs)
        if faults:
            injectors[body] = FaultInjector(faults, outputs, RATE, EVERY, None)
    batch = FaultBatch(injectors, BODIES)
    for position, name in enumerate(SENSORS):
        raw = _raw_rows(rng, name)
        for j in range(SAMPLES):
            previous = raw[j - 1] if j else None
            out, sent = batch.apply(position, j, raw[j], previous)
            for body in range(BODIES):
                injector = injectors.get(body)
                if injector is None:
                    expected, keep = raw[j, body: body + 1], None
                else:
                    before = None if previous is None else previous[body]
                    expected, keep = injector.apply(position, j, raw[j, body: body + 1], before)
                    acted |= {fault.kind for fault in injector.active(position, j)}
                np.testing.assert_array_equal(out[body], expected[0], err_msg=f'{name} {j}')
                assert sent[body] == (keep is None or bool(keep[0])), (name, j, body)
    # the comparison met every kind (the random schedule is seeded: this holds, and must)
    assert acted == {'stuck', 'bias', 'noise', 'spikes', 'dropout'}


def test_the_vectorised_philox_rounds_are_numpy_s_bit_for_bit():
    rng = np.random.default_rng(7)
    seeds = rng.integers(0, 2**63 - 1, 64).tolist()
    indices = rng.integers(0, 100, 64).tolist()
    # counters from 0 to past 2**32 samples: the rounds' 64-bit carries in every word
    samples = np.concatenate([np.arange(32), rng.integers(2**32, 2**50, 32)])
    keys = np.array([fault_key(s, i) for s, i in zip(seeds, indices)])
    drawn = uniforms_at(keys, samples)
    for row, (seed, index, j) in enumerate(zip(seeds, indices, samples.tolist())):
        np.testing.assert_array_equal(drawn[row], uniforms(seed, index, j, j + 1)[0])
