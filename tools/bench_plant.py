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
Benchmark of the plant (``torquefree_ros.Plant``).

A script, not a test: it prints what it measured and the machine.

- one ``step`` of a one-body plant with a damper and a commanded torque (10 Hz, an explorer1-like
  spin of 6 rad/s: a few DOP853 steps an interval, a new piece at every sample as the node's);
- a batched step of 1 000 dispersed bodies of that kind, per body, beside the one-body step;
- 1 000 dispersed explorer1 bodies (damper, no commands) over 900 s at 1 Hz in one plant, per body,
  beside the first 20 of them each run alone in a plant of its own (construction included in both).

Wall time (``perf_counter``) of the fastest of several calls; ``--rounds`` rounds give median
(min–max), the ratios taken within each round.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path
import statistics
import sys

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_report import commanded_scene, dispersed_bodies, fastest, Report, spread  # noqa: E402

BODIES = 1_000
RATE = 10.0
STEPS = 200  # one-body steps timed per call
BATCH_STEPS = 10
LONE = 20  # of the dispersed explorer1 bodies, each run alone: the per-body reference
DAMPER = {'inertia': 0.05, 'damping': 0.01}


def measure_round(calls: int) -> dict:
    import numpy as np
    from torquefree_ros import load_scene, Plant

    inertia, omega = dispersed_bodies(
        BODIES,
        seed=1,
        inertia=[2.0, 4.6, 4.95],
        angular_velocity=[6.0, 0.05, 0.0],
        inertia_spread=0.02,
        rate_spread=0.1,
    )
    torques = 0.01 * np.random.default_rng(2).standard_normal((BODIES, 3))

    one = Plant(commanded_scene(inertia[0], omega[0], DAMPER), RATE)
    one.step(torques[0])  # compile or load the kernels outside the timing

    def one_body():
        for _ in range(STEPS):
            one.step(torques[0])

    step_one = fastest(one_body, calls) / STEPS

    batch = Plant([commanded_scene(i, w, DAMPER) for i, w in zip(inertia, omega)], RATE)
    batch.step(torques)

    def batched():
        for _ in range(BATCH_STEPS):
            batch.step(torques)

    step_batch = fastest(batched, calls) / BATCH_STEPS / BODIES

    explorer = load_scene('explorer1')
    rng = np.random.default_rng(3)
    # explorer1's body lies 1 % inside the triangle inequality: dispersed by 0.1 % and 0.1 rad/s
    scenes = [
        replace(
            explorer,
            inertia=tuple(np.array(explorer.inertia) * (1 + 0.001 * rng.standard_normal(3))),
            angular_velocity=tuple(
                np.array(explorer.angular_velocity) + 0.1 * rng.standard_normal(3)
            ),
        )
        for _ in range(BODIES)
    ]
    alone = scenes[:LONE]
    lone = fastest(lambda: [Plant(scene, 1.0).run(900.0) for scene in alone], calls) / LONE
    many = fastest(lambda: Plant(scenes, 1.0).run(900.0), max(1, calls // 2)) / BODIES
    return {
        'step_one_us': step_one * 1e6,
        'step_batch_us': step_batch * 1e6,
        'batch_over_one': step_batch / step_one,
        'explorer_one_ms': lone * 1e3,
        'explorer_batch_ms': many * 1e3,
        'explorer_ratio': many / lone,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--output', help='write the report here (Markdown)')
    parser.add_argument('--rounds', type=int, default=3)
    parser.add_argument('--calls', type=int, default=3)
    args = parser.parse_args(argv)

    import numba
    import numpy
    import scipy

    report = Report('The plant: one body and batches, in process', 'make bench-plant')
    report.add(
        f'- versions: numpy {numpy.__version__}, scipy {scipy.__version__}, '
        f'numba {numba.__version__}'
    )
    report.add('')
    report.add(
        f'{args.rounds} rounds; each figure is median (min–max) over the rounds of the fastest of '
        f'{args.calls} calls (wall time). Bodies: inertia (2.0, 4.6, 4.95) kg m² and '
        'ω0 (6, 0.05, 0) rad/s, dispersed 2 % and 0.1 rad/s (seeded), a damper (J 0.05, c 0.01), '
        'DOP853 at 1e-10.'
    )
    report.add('')
    rounds = [measure_round(args.calls) for _ in range(args.rounds)]

    def column(key):
        return spread([r[key] for r in rounds])

    report.add('| measure | value | target (issue 28) | met |')
    report.add('|---|---|---|---|')
    step_one = statistics.median(r['step_one_us'] for r in rounds)
    step_batch = statistics.median(r['step_batch_us'] for r in rounds)
    ratio = statistics.median(r['explorer_ratio'] for r in rounds)
    report.add(
        '| one `step` of a one-body plant (damper + commanded torque, 10 Hz) | '
        f'{column("step_one_us")} µs | ≤ 20 µs | {"yes" if step_one <= 20 else "**no**"} |'
    )
    report.add(
        f'| a batched `step` of {BODIES:,} such bodies, per body | {column("step_batch_us")} µs '
        f"({column('batch_over_one')} of one body's step) | ≤ 5 µs | "
        f'{"yes" if step_batch <= 5 else "**no**"} |'
    )
    report.add(
        f'| {BODIES:,} dispersed explorer1 bodies, 900 s at 1 Hz (`run`), per body | '
        f'{column("explorer_batch_ms")} ms, {column("explorer_ratio")} of a body alone '
        f'({column("explorer_one_ms")} ms) | ≤ 1.5x one body | '
        f'{"yes" if ratio <= 1.5 else "**no**"} |'
    )
    report.add('')
    report.add(
        "The node's lock-step against rclpy's ping-pong floor: `make bench-lockstep` "
        '(docs/bench/lockstep.md).'
    )
    report.save(args.output)
    return 0


if __name__ == '__main__':
    sys.exit(main())
