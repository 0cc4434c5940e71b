#!/usr/bin/env python3
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
Benchmark of the sensor models (issue 42).

A script, not a test: it prints what it measured and the machine.

- the gyro (``imu``) per sample: the full datasheet model (angle and rate random walk, Gauss-Markov
  bias instability, turn-on bias, scale factor, misalignment, saturation, quantization, latency)
  against the white-noise imu (``gyro_noise_density`` alone), in blocks and one sample at a time
  (a closed loop's lock-step), on the same precomputed states; beside them the floor of a seeded
  sensor's sample: its PCG64 normals and the copy of its row;
- a batch of 1 000 bodies on one orbit in one ``Plant`` (10 Hz, a damper and a commanded torque),
  each with the four sensors at their full models (the gyro above; the star tracker with noise,
  ``max_rate``, Sun and Earth exclusion and latency; the magnetometer with noise, bias, scale
  factor, misalignment, saturation and quantization; the sun sensor with noise, bias,
  misalignment, field of view and quantized angles), per body-step: the plant's own step alone
  (the floor the sensors add to), the plant with the sensors' rows one sample at a time (lock-step:
  ``step`` then ``Plant.sensors().read()``, every body's sensors at once), and the open-loop
  ``run`` of a block with the sensors' rows of the block (each body's streams);
- the same batch with a fault on every sensor of every body (windows and values differing from
  body to body): the lock-step with them, and the faults alone on the same sensor rows, applied
  to every body's row at once (``core.faults.batch.FaultBatch``, the plant's path) against each
  body's ``FaultInjector`` one body after another (the node's path, one Python call per body).

Wall time (``perf_counter``) of the fastest of several calls (the two gyros' calls alternating,
ten times as many), the faulted batch's in CPU time (``process_time``); ``--rounds`` rounds give
median (min–max), ratios taken within each round (the primary figures on a loaded machine).
"""

from __future__ import annotations

import argparse
from pathlib import Path
import statistics
import sys
import time

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_report import commanded_scene, dispersed_bodies, fastest, Report, spread  # noqa: E402

CPU = time.process_time  # the faulted batch's clock: this process's CPU time
GYRO_CALLS = 10  # per round, each gyro's calls alternating with the other's (the same load)

GYRO_RATE = 100.0
GYRO_SAMPLES = 20_000
GYRO_BLOCK = 1_000
GYRO_ONE = 2_000  # samples timed one at a time
BODIES = 1_000
RATE = 10.0
LOCKSTEP_STEPS = 64  # a whole period of the batched sensors' normals drawn ahead
RUN_SECONDS = 120.0

LEO = {
    'epoch': '2026-03-20T12:00:00Z',
    'semi_major_axis': 6878137.0,
    'eccentricity': 0.001,
    'inclination': 1.7,
    'raan': 0.3,
    'argument_of_perigee': 0.5,
    'mean_anomaly': 5.0,
}
WHITE_GYRO = {'gyro_noise_density': 1e-4, 'seed': 1}
FULL_GYRO = {
    'angle_random_walk': 0.17,
    'rate_random_walk': 16.0,
    'bias_instability': 10.0,
    'bias_correlation_time': 50.0,
    'turn_on_bias': 30.0,
    'scale_factor': [100.0, -200.0, 50.0],
    'misalignment': [[0.0, 30.0, -20.0], [10.0, 0.0, 40.0], [-25.0, 5.0, 0.0]],
    'saturation': 50.0,
    'quantization': 0.002,
    'latency_samples': 2,
    'seed': 1,
}
FULL_SENSORS = [
    {'imu': FULL_GYRO},
    {'star_tracker': {
        'cross_boresight_noise': 5.0, 'about_boresight_noise': 40.0, 'max_rate': 8.0,
        'sun_exclusion': 30.0, 'earth_exclusion': 20.0, 'latency_samples': 1, 'seed': 2,
    }},
    {'magnetometer': {
        'noise': 40e-9, 'bias': [1e-7, -5e-8, 2e-8], 'scale_factor': [200.0, -100.0, 50.0],
        'misalignment': [[0.0, 30.0, -20.0], [10.0, 0.0, 40.0], [-25.0, 5.0, 0.0]],
        'saturation': 6e-5, 'quantization': 1e-8, 'seed': 3,
    }},
    {'sun_sensor': {
        'noise': 0.05, 'bias': [0.3, -0.2, 0.1], 'misalignment': [600.0, -300.0, 900.0],
        'field_of_view': 70.0, 'quantization': 0.02, 'boresight': [1.0, 0.0, 1.0], 'seed': 4,
    }},
]


def _gyro_round(calls: int) -> dict:
    import numpy as np
    from torquefree_ros.core.effects.sensors import IMU_ROW
    from torquefree_ros.core.run.simulation import Simulation
    from torquefree_ros.core.scene.loader import scene_from_mapping

    def scene(imu):
        return scene_from_mapping(
            {
                'body': {'inertia': [3.0, 2.0, 1.0]},
                'initial': {'angular_velocity': [0.3, 0.2, 1.0]},
                'effects': [{'imu': imu}],
            }
        )

    truth = Simulation(scene(WHITE_GYRO).propagator(), GYRO_RATE).samples(0, GYRO_SAMPLES)
    internal = np.zeros((GYRO_SAMPLES, 0))

    def in_blocks(imu):
        """Return a call measuring the next GYRO_SAMPLES samples of one stream, in blocks."""
        s = scene(imu)
        stream = s.outputs[0].stream(GYRO_RATE, s.propagator())
        done = [0]  # samples measured: each call goes on where the last stopped

        def run():
            for start in range(0, GYRO_SAMPLES, GYRO_BLOCK):
                part = slice(start, start + GYRO_BLOCK)
                stream.rows(
                    done[0] + start, truth.times[part], truth.omega_B[part], truth.q_NB[part],
                    internal[part],
                )
            done[0] += GYRO_SAMPLES

        run()  # imports (scipy's lfilter) outside the timing
        return run

    def one_at_a_time(imu):
        """Return a call measuring the next GYRO_ONE samples of one stream, one at a time."""
        s = scene(imu)
        stream = s.outputs[0].stream(GYRO_RATE, s.propagator())
        done = [0]

        def run():
            for k in range(GYRO_ONE):
                stream.rows(
                    done[0] + k, truth.times[k: k + 1], truth.omega_B[k: k + 1],
                    truth.q_NB[k: k + 1], internal[k: k + 1],
                )
            done[0] += GYRO_ONE

        run()
        return run

    def alternating(white, full, samples):
        """Return the per-sample times of the fastest of their calls, the calls alternating."""
        best = [float('inf'), float('inf')]
        for _ in range(calls * GYRO_CALLS):
            for j, run in enumerate((white, full)):
                best[j] = min(best[j], fastest(run, 1))
        return best[0] / samples, best[1] / samples

    template = np.zeros(IMU_ROW)

    def floor_blocks():
        rng = np.random.Generator(np.random.PCG64(1))
        for _ in range(0, GYRO_SAMPLES, GYRO_BLOCK):
            rng.standard_normal((GYRO_BLOCK, 6))
            np.tile(template, (GYRO_BLOCK, 1))

    def floor_one():
        rng = np.random.Generator(np.random.PCG64(1))
        for _ in range(GYRO_ONE):
            rng.standard_normal(6)
            template.copy()

    white_block, full_block = alternating(
        in_blocks(WHITE_GYRO), in_blocks(FULL_GYRO), GYRO_SAMPLES
    )
    white_one, full_one = alternating(
        one_at_a_time(WHITE_GYRO), one_at_a_time(FULL_GYRO), GYRO_ONE
    )
    result = {
        'white_block_us': white_block * 1e6,
        'full_block_us': full_block * 1e6,
        'floor_block_us': fastest(floor_blocks, calls * GYRO_CALLS) / GYRO_SAMPLES * 1e6,
        'white_one_us': white_one * 1e6,
        'full_one_us': full_one * 1e6,
        'floor_one_us': fastest(floor_one, calls * GYRO_CALLS) / GYRO_ONE * 1e6,
    }
    result['block_ratio'] = result['full_block_us'] / result['white_block_us']
    result['one_ratio'] = result['full_one_us'] / result['white_one_us']
    return result


def _batch_scenes(sensors: bool):
    inertia, omega = dispersed_bodies(
        BODIES,
        seed=1,
        inertia=[0.03, 0.035, 0.01],
        angular_velocity=[0.05, -0.08, 0.06],
        inertia_spread=0.02,
        rate_spread=0.01,
        body_by_body=True,
    )
    damper = {'inertia': 0.001, 'damping': 0.0005}
    effects = FULL_SENSORS if sensors else []
    return [commanded_scene(i, w, damper, effects, orbit=LEO) for i, w in zip(inertia, omega)]


def _faults(body: int) -> list:
    """Return a fault on each sensor of body ``body``, its windows and values its own."""
    start = 0.1 * (body % 7)
    return [
        {'noise': {'output': 'imu', 'start': start, 'sigma': 1e-4 * (1 + body % 3)}},
        {'spikes': {'output': 'star_tracker', 'start': start, 'magnitude': 1e-3,
                    'probability': 0.2}},
        {'bias': {'output': 'magnetometer', 'start': 0.0, 'step': [1e-7 * (body % 5), 0.0, 0.0]}},
        {'stuck': {'output': 'sun_sensor', 'start': 0.5 + start, 'end': 2.0 + start}}
        if body % 2
        else {'dropout': {'output': 'sun_sensor', 'start': start, 'end': 1.0 + start}},
    ]


def _faulted_round(calls: int) -> dict:
    import dataclasses

    import numpy as np
    from torquefree_ros import Plant
    from torquefree_ros.core.faults import FaultInjector, parse_faults
    from torquefree_ros.core.faults.batch import FaultBatch

    plain = _batch_scenes(sensors=True)
    torques = 1e-6 * np.random.default_rng(2).standard_normal((BODIES, 3))

    def lockstep_of(scenes, rows=None):
        """Return a call stepping a plant of ``scenes`` in lock-step (its rows into ``rows``)."""
        plant = Plant(scenes, RATE)
        sensors = plant.sensors()
        sensors.read()

        def run():
            for _ in range(LOCKSTEP_STEPS):
                plant.step(torques)
                readings = sensors.read()
                if rows is not None:
                    rows.append(readings.rows)

        run()  # (the kernels and the draws ahead outside the timing)
        return run

    faulted = [
        dataclasses.replace(scene, faults=parse_faults(_faults(body), 'faults', scene.outputs))
        for body, scene in enumerate(plain)
    ]
    clean = fastest(lockstep_of(plain), calls, CPU) / LOCKSTEP_STEPS / BODIES
    with_faults = fastest(lockstep_of(faulted), calls, CPU) / LOCKSTEP_STEPS / BODIES

    # the faults alone, on the unfaulted rows of LOCKSTEP_STEPS samples
    raws = []
    lockstep_of(plain, raws)
    outputs = faulted[0].outputs
    every = [output.every(RATE) for output in outputs]

    def injectors():
        return {
            body: FaultInjector(scene.faults, scene.outputs, RATE, every, None)
            for body, scene in enumerate(faulted)
        }

    def batched():
        batch = FaultBatch(injectors(), BODIES)
        return lambda j, p, raw, before: batch.apply(p, j, raw, before)

    def per_body():
        each = injectors()

        def apply(j, p, raw, before):
            for body, injector in each.items():
                injector.apply(p, j, raw[body: body + 1], None if before is None else before[body])

        return apply

    def timed(make):
        apply = make()  # built outside the timing, as the plant builds it at its start

        def run():
            for j, rows in enumerate(raws, start=1):
                for p, output in enumerate(outputs):
                    before = raws[j - 2][output.topic] if j > 1 else None
                    apply(j, p, rows[output.topic], before)

        return run

    per_body_s = min(fastest(timed(per_body), 1, CPU) for _ in range(calls))
    batched_s = min(fastest(timed(batched), 1, CPU) for _ in range(calls))
    return {
        'clean_us': clean * 1e6,
        'faulted_us': with_faults * 1e6,
        'faulted_ratio': with_faults / clean,
        'per_body_us': per_body_s / LOCKSTEP_STEPS / BODIES * 1e6,
        'batched_us': batched_s / LOCKSTEP_STEPS / BODIES * 1e6,
        'faults_ratio': per_body_s / batched_s,
    }


def _batch_round(calls: int) -> dict:
    import numpy as np
    from torquefree_ros import Plant

    scenes = _batch_scenes(sensors=True)
    torques = 1e-6 * np.random.default_rng(2).standard_normal((BODIES, 3))

    def streams():
        return [[o.stream(RATE, None) for o in scene.outputs] for scene in scenes]

    def sensor_rows(bodies_streams, first, times, omega, q, internal):
        for b, body in enumerate(bodies_streams):
            for stream in body:
                stream.rows(first, times, omega[b], q[b], internal[b])

    plant = Plant(scenes, RATE)
    plant.step(torques)  # compile or load the kernels outside the timing

    def plant_alone():
        for _ in range(LOCKSTEP_STEPS):
            plant.step(torques)

    alone = fastest(plant_alone, calls) / LOCKSTEP_STEPS / BODIES

    looped = Plant(scenes, RATE)
    sensors = looped.sensors()
    sensors.read()  # sample 0: the initial state

    def lockstep():
        for _ in range(LOCKSTEP_STEPS):
            looped.step(torques)
            sensors.read()

    lockstep()
    with_sensors = fastest(lockstep, calls) / LOCKSTEP_STEPS / BODIES

    count = int(RUN_SECONDS * RATE)
    times = np.arange(count + 1) / RATE

    def open_loop(sensors: bool):
        p = Plant(scenes, RATE)
        first = p.state
        states = p.run(RUN_SECONDS)
        if sensors:
            omega = np.concatenate([first.omega_B[:, None], states.omega_B], axis=1)
            q = np.concatenate([first.q_NB[:, None], states.q_NB], axis=1)
            internal = np.concatenate([first.internal[:, None], states.internal], axis=1)
            sensor_rows(streams(), 0, times, omega, q, internal)

    open_loop(True)
    run_alone = fastest(lambda: open_loop(False), calls) / count / BODIES
    run_sensors = fastest(lambda: open_loop(True), calls) / count / BODIES
    return {
        'step_alone_us': alone * 1e6,
        'step_sensors_us': with_sensors * 1e6,
        'step_ratio': with_sensors / alone,
        'run_alone_us': run_alone * 1e6,
        'run_sensors_us': run_sensors * 1e6,
        'run_ratio': run_sensors / run_alone,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--output', help='write the report here (Markdown)')
    parser.add_argument('--rounds', type=int, default=3)
    parser.add_argument('--calls', type=int, default=3)
    parser.add_argument(
        '--faults-only', action='store_true', help='measure the faulted batch alone (no report)'
    )
    args = parser.parse_args(argv)
    if args.faults_only:
        for faulted in (_faulted_round(args.calls) for _ in range(args.rounds)):
            print(', '.join(f'{key} {value:.3g}' for key, value in faulted.items()))
        return 0

    import numba
    import numpy
    import scipy

    report = Report('The sensor models: the gyro per sample, a batch with every sensor',
                    'make bench-sensors')
    report.add(
        f'- versions: numpy {numpy.__version__}, scipy {scipy.__version__}, '
        f'numba {numba.__version__}'
    )
    report.add(
        '- the machine was shared with other jobs while this ran: the ratios, taken within each '
        "round, are the figures to read; the absolute times are this load's"
    )
    report.add('')
    report.add(
        f'{args.rounds} rounds; each figure is median (min–max) over the rounds of the fastest of '
        f'{args.calls} calls (wall time).'
    )
    report.add('')
    gyro = [_gyro_round(args.calls) for _ in range(args.rounds)]
    batch = [_batch_round(args.calls) for _ in range(args.rounds)]
    faulted = [_faulted_round(args.calls) for _ in range(args.rounds)]

    def column(rounds, key):
        return spread([r[key] for r in rounds])

    def met(rounds, key, target):
        return 'yes' if statistics.median(r[key] for r in rounds) <= target else '**no**'

    report.add(f"## The gyro per sample ({GYRO_RATE:g} Hz, a tumbling body's precomputed states)")
    report.add('')
    report.add(
        '| path | white-noise imu, µs | full datasheet model, µs | full / white (target ≤ 2x) '
        '| met | floor: PCG64 normals + the row, µs |'
    )
    report.add('|---|---|---|---|---|---|')
    report.add(
        f'| blocks of {GYRO_BLOCK:,} samples | {column(gyro, "white_block_us")} | '
        f'{column(gyro, "full_block_us")} | {column(gyro, "block_ratio")} | '
        f'{met(gyro, "block_ratio", 2.0)} | {column(gyro, "floor_block_us")} |'
    )
    report.add(
        f'| one sample at a time (lock-step) | {column(gyro, "white_one_us")} | '
        f'{column(gyro, "full_one_us")} | {column(gyro, "one_ratio")} | '
        f'{met(gyro, "one_ratio", 2.0)} | {column(gyro, "floor_one_us")} |'
    )
    report.add('')
    report.add(
        f'## {BODIES:,} bodies on one orbit, four full sensor models each ({RATE:g} Hz, per '
        'body-step)'
    )
    report.add('')
    report.add(
        'Bodies: inertia (0.03, 0.035, 0.01) kg m² and ω0 (0.05, −0.08, 0.06) rad/s dispersed 2 % '
        'and 0.01 rad/s (seeded), a damper and a commanded torque, a 500 km orbit, DOP853 at '
        '1e-10. The plant alone is the floor the sensors add to.'
    )
    report.add('')
    report.add('| path | plant alone, µs | plant + sensors, µs | ratio | target ≤ 10 µs | met |')
    report.add('|---|---|---|---|---|---|')
    report.add(
        f'| lock-step: `step` then `sensors().read()`, one sample ({LOCKSTEP_STEPS} steps) | '
        f'{column(batch, "step_alone_us")} | {column(batch, "step_sensors_us")} | '
        f'{column(batch, "step_ratio")} | ≤ 10 | {met(batch, "step_sensors_us", 10.0)} |'
    )
    report.add(
        f"| open loop: `run` {RUN_SECONDS:g} s, then the block's sensor rows | "
        f'{column(batch, "run_alone_us")} | {column(batch, "run_sensors_us")} | '
        f'{column(batch, "run_ratio")} | ≤ 10 | {met(batch, "run_sensors_us", 10.0)} |'
    )
    report.add('')
    report.add(
        f'## The same {BODIES:,} bodies with a fault on every sensor (CPU per body-step)'
    )
    report.add('')
    report.add(
        'Each body: a noise on the gyro, spikes on the star tracker, a bias on the magnetometer, '
        'a stuck or a dropout sun sensor, their windows and values differing from body to body.'
    )
    report.add('')
    report.add('| path | without faults, µs | with faults, µs | ratio |')
    report.add('|---|---|---|---|')
    report.add(
        f'| lock-step: `step` then `sensors().read()` ({LOCKSTEP_STEPS} steps) | '
        f'{column(faulted, "clean_us")} | {column(faulted, "faulted_us")} | '
        f'{column(faulted, "faulted_ratio")} |'
    )
    report.add('')
    report.add(
        "| the faults alone on the same rows | each body's `FaultInjector` in turn, µs | "
        'every body at once (`FaultBatch`), µs | speed-up |'
    )
    report.add('|---|---|---|---|')
    report.add(
        f'| {LOCKSTEP_STEPS} samples, four outputs | {column(faulted, "per_body_us")} | '
        f'{column(faulted, "batched_us")} | {column(faulted, "faults_ratio")} |'
    )
    report.add('')
    report.add(
        'The sensors of one body, and the bodies of a batch on one orbit, evaluate the '
        'environment (orbit position, the Sun, its shadow, the field) of a block once '
        '(`sensors.environment_at`). In lock-step `Plant.sensors().read()` computes each sensor '
        'for every body of the batch in a few numpy calls (`core.effects.sensor_batch`: each '
        "body's seeded draws drawn ahead, its parameters as columns), bit for bit each body's "
        "own stream; the open loop runs each body's streams on the whole block."
    )
    report.save(args.output)
    return 0


if __name__ == '__main__':
    sys.exit(main())
