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
Benchmark of the reaction wheels: what a wheel array costs beside a constant body torque.

A script, not a test: it prints (and with ``--output`` writes) what it measured and the machine.

- CPU per simulated second, compiled DOP853 at the scene's accuracy 1e-10, 100 Hz samples over
  100 s (the case the issue measured Basilisk on): a body under a constant body torque, the same
  body with three orthogonal frictionless wheels under constant motor torques, and with viscous and
  Coulomb friction; the ratios are taken within each round;
- the plant: one ``step`` (10 Hz) of a body with a four-wheel pyramid taking motor torques, beside
  the same body taking a commanded body torque; a batched step of 1 000 dispersed such bodies, per
  body; the batch's peak memory (tracemalloc) per body;
- the node in lock-step on the library ``wheel_slew`` scene, a controller in another process
  answering every angular_velocity sample with a JointState of motor torques, against rclpy's
  ping-pong floor with the same controller (``bench_lockstep``'s measures; wall time, interleaved).

Each figure is CPU time (``process_time``: on a shared machine, what the work costs rather than
how long it waited), median (min–max) over ``--rounds`` rounds of the fastest of ``--calls`` calls.
"""

from __future__ import annotations

import argparse
from pathlib import Path
import statistics
import sys
import time
import tracemalloc

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_lockstep import ping_pong, round_trips  # noqa: E402
from bench_node import _isolate_dds  # noqa: E402
from bench_report import fastest, Report, spread  # noqa: E402

INERTIA = [12.0, 10.0, 8.0]  # kg m^2, the library wheel_slew body
OMEGA0 = [0.02, -0.01, 0.015]  # rad/s
SPAN = 100.0  # s simulated per propagation
SAMPLE_RATE = 100.0  # Hz: dt 0.01 s, as the Basilisk run
PLANT_RATE = 10.0  # Hz
BODIES = 1_000
STEPS = 200  # one-body plant steps timed per call
BATCH_STEPS = 10
ORTHOGONAL = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0])
PYRAMID = (
    [1.4142135623730951, 0.0, 1.0],
    [0.0, 1.4142135623730951, 1.0],
    [-1.4142135623730951, 0.0, 1.0],
    [0.0, -1.4142135623730951, 1.0],
)

WHEEL_CONTROLLER = r"""
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from geometry_msgs.msg import Vector3Stamped
from sensor_msgs.msg import JointState
rclpy.init()
node = rclpy.create_node("bench_wheel_controller")
qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
publisher = node.create_publisher(JointState, "wheel_command", qos)
command = JointState()
command.name = ["rw1", "rw2", "rw3", "rw4"]
def answer(sample):
    command.header.stamp = sample.header.stamp
    v = sample.vector
    command.effort = [0.01 * v.x, 0.01 * v.y, -0.01 * v.x, -0.01 * v.y]
    publisher.publish(command)
node.create_subscription(Vector3Stamped, "angular_velocity", answer, qos)
print("ready", flush=True)
try:
    rclpy.spin(node)
except BaseException:
    pass
"""


def _wheel(axis, friction: bool, speed: float = 0.0) -> dict:
    wheel = {
        'axis': list(axis),
        'spin_inertia': 0.01,
        'max_torque': 0.02,
        'max_speed': 600.0,
        'speed': speed,
    }
    if friction:
        wheel.update(viscous=1.0e-6, coulomb=5.0e-4)
    return wheel


def _scene(effects, inertia=INERTIA, omega=OMEGA0):
    from torquefree_ros.core.scene.loader import scene_from_mapping

    return scene_from_mapping(
        {
            'body': {'inertia': list(inertia)},
            'initial': {'angular_velocity': list(omega)},
            'effects': effects,
            'accuracy': 1e-10,
        },
        '<bench: wheels>',
    )


def propagation_scenes() -> dict:
    """Return the three propagation cases: constant torque, wheels, wheels with friction."""
    motor = [0.01, -0.005, 0.008]  # N m on each wheel; the body feels minus them
    return {
        'torque': _scene([{'external_torque': {'torque': [-u for u in motor]}}]),
        'wheels': _scene(
            [{'reaction_wheels': {
                'wheels': [_wheel(g, False, 50.0) for g in ORTHOGONAL], 'torque': motor}}]
        ),
        'friction': _scene(
            [{'reaction_wheels': {
                'wheels': [_wheel(g, True, 50.0) for g in ORTHOGONAL], 'torque': motor}}]
        ),
    }


def plant_scene(inertia, omega, wheels: bool):
    command = (
        {'reaction_wheels': {
            'mode': 'torque',
            'wheels': [_wheel(g, True, (100.0, -100.0)[i % 2]) for i, g in enumerate(PYRAMID)],
        }}
        if wheels
        else {'torque_command': {'max_torque': 1.0}}
    )
    return _scene([command], inertia, omega)


def measure_round(calls: int) -> dict:
    import numpy as np
    from torquefree_ros import Plant

    times = np.arange(int(round(SPAN * SAMPLE_RATE)) + 1) / SAMPLE_RATE
    cpu = {}
    for name, scene in propagation_scenes().items():
        scene.propagator().states(times[:2])  # compile or load the kernels outside the timing
        cpu[name] = fastest(
            lambda scene=scene: scene.propagator().states(times), calls, clock=time.process_time
        ) / SPAN

    rng = np.random.default_rng(1)
    inertia = np.array(INERTIA) * (1 + 0.02 * rng.standard_normal((BODIES, 3)))
    omega = np.array(OMEGA0) + 0.01 * rng.standard_normal((BODIES, 3))
    motor = 0.01 * rng.standard_normal((BODIES, 4))
    torques = 0.01 * rng.standard_normal((BODIES, 3))

    def per_step(plant, **command):
        plant.step(**command)  # compile or load the kernels outside the timing

        def steps():
            for _ in range(STEPS):
                plant.step(**command)

        return fastest(steps, calls, clock=time.process_time) / STEPS

    step_wheels = per_step(Plant(plant_scene(inertia[0], omega[0], True), PLANT_RATE),
                           wheels=motor[0])
    step_torque = per_step(Plant(plant_scene(inertia[0], omega[0], False), PLANT_RATE),
                           torque=torques[0])

    tracemalloc.start()
    batch = Plant(
        [plant_scene(i, w, True) for i, w in zip(inertia, omega)], PLANT_RATE
    )
    batch.step(wheels=motor)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()

    def batched():
        for _ in range(BATCH_STEPS):
            batch.step(wheels=motor)

    step_batch = fastest(batched, calls, clock=time.process_time) / BATCH_STEPS / BODIES
    return {
        'torque_us': cpu['torque'] * 1e6,
        'wheels_us': cpu['wheels'] * 1e6,
        'friction_us': cpu['friction'] * 1e6,
        'wheels_ratio': cpu['wheels'] / cpu['torque'],
        'friction_ratio': cpu['friction'] / cpu['torque'],
        'step_wheels_us': step_wheels * 1e6,
        'step_torque_us': step_torque * 1e6,
        'step_ratio': step_wheels / step_torque,
        'batch_us': step_batch * 1e6,
        'batch_kib': peak / BODIES / 1024,
    }


def _met(value: float, target: float) -> str:
    return 'yes' if value <= target else '**no**'


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--output', help='write the report here (Markdown)')
    parser.add_argument('--rounds', type=int, default=3)
    parser.add_argument('--calls', type=int, default=3)
    parser.add_argument(
        '--seconds', type=float, default=5.0, help='duration of each lock-step run (default: 5)'
    )
    args = parser.parse_args(argv)
    _isolate_dds()

    import numba
    import numpy

    report = Report('Reaction wheels: cost beside a constant torque', 'make bench-wheels')
    report.add(f'- versions: numpy {numpy.__version__}, numba {numba.__version__}')
    report.add('')
    report.add(
        f'{args.rounds} rounds; each figure is median (min–max) over the rounds of the fastest of '
        f'{args.calls} calls, CPU time; ratios are taken within each round. Body: inertia '
        f'{INERTIA} kg m², ω0 {OMEGA0} rad/s; wheels Js 0.01 kg m², 0.02 N m, 600 rad/s; '
        'friction (where named) viscous 1e-6 N m s, Coulomb 5e-4 N m; compiled DOP853 at 1e-10.'
    )
    report.add('')
    rounds = [measure_round(args.calls) for _ in range(args.rounds)]

    def column(key):
        return spread([r[key] for r in rounds])

    def median(key):
        return statistics.median(r[key] for r in rounds)

    report.add('| measure | value | target (issue 40) | met |')
    report.add('|---|---|---|---|')
    report.add(
        f'| propagation, {SAMPLE_RATE:g} Hz samples over {SPAN:g} s: constant body torque, CPU '
        f'per simulated second | {column("torque_us")} µs | | |'
    )
    report.add(
        '| the same body with 3 orthogonal frictionless wheels under constant motor torques | '
        f'{column("wheels_us")} µs, {column("wheels_ratio")} x the torque | ≤ 2x | '
        f'{_met(median("wheels_ratio"), 2.0)} |'
    )
    report.add(
        '| the same wheels with viscous and Coulomb friction | '
        f'{column("friction_us")} µs, {column("friction_ratio")} x the torque | ≤ 2x | '
        f'{_met(median("friction_ratio"), 2.0)} |'
    )
    report.add(
        f'| plant: one `step` ({PLANT_RATE:g} Hz), 4-wheel pyramid with friction, motor torques '
        f'commanded | {column("step_wheels_us")} µs ({column("step_ratio")} x a commanded body '
        f'torque\'s {column("step_torque_us")} µs) | ≤ 20 µs | '
        f'{_met(median("step_wheels_us"), 20.0)} |'
    )
    report.add(
        f'| plant: a batched `step` of {BODIES:,} such bodies (dispersed 2 %), per body | '
        f'{column("batch_us")} µs | ≤ 5 µs | {_met(median("batch_us"), 5.0)} |'
    )
    report.add(
        "| the batch's peak memory (construction and a step, tracemalloc), per body | "
        f'{column("batch_kib")} KiB | | |'
    )
    report.add('')
    command = ('wheel_command', 'sensor_msgs.msg.JointState')
    runs, floors = [], []
    for _ in range(args.rounds):  # interleaved, so that a noisy moment hits both alike
        floors.append(ping_pong(args.seconds, False, WHEEL_CONTROLLER, command))
        runs.append(round_trips(args.seconds, 'wheel_slew', WHEEL_CONTROLLER, command[0]))
    ratios = [r['rate'] / f for r, f in zip(runs, floors)]
    report.add(
        f'Lock-step on `wheel_slew` (4 wheels commanded by JointState, {args.seconds:g} s per '
        f'run, wall time): {spread([r["rate"] for r in runs])} round trips per second, missed '
        f"steps {spread([r['missed'] for r in runs])}; rclpy's floor with the same controller "
        f'{spread(floors)}; the node / the floor, run by run: {spread(ratios)} (target ≥ 0.6: '
        f'{"met" if statistics.median(ratios) >= 0.6 else "**not met**"}).'
    )
    report.save(args.output)
    return 0


if __name__ == '__main__':
    sys.exit(main())
