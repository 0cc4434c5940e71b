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
The same work through the public API of this tree and of an earlier revision, side by side.

A script, not a test: it checks that a change (a reorganisation, say) left the costs where they
were. Each round runs every measure once in a fresh process of each tree, alternating (so a noisy
moment hits both alike), and takes the ratio this tree / the revision within the round; the figures
are CPU time (``process_time``) of the fastest of ``--calls`` calls, compilation and first loads
outside the timing. The revision is checked out into a temporary git worktree.

- the exact solution (``propagate``, auto: analytic) per sample, 10 000 samples of a tumbling body;
- the exact solution for a batch (``propagate_batch``), 200 bodies x 100 samples, per body-sample;
- a scene with effects (``load_scene('explorer1')``: a damper, DOP853 at its accuracy), 100 s at
  100 Hz, per simulated second;
- a plant step (``Plant``, the library ``detumble`` scene, a commanded torque, 10 Hz), per step.

Usage: ``.venv/bin/python tools/bench_against.py --base REV [--output FILE]``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_report import Report, spread  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

MEASURE = r"""
import json, sys, time
import numpy as np
import torquefree_ros as tf

calls = int(sys.argv[1])


def fastest(function):
    best = float('inf')
    for _ in range(calls):
        started = time.process_time()
        function()
        best = min(best, time.process_time() - started)
    return best


out = {}
times = np.linspace(0.0, 100.0, 10_000)
args = ([2.0, 3.0, 4.0], [0.3, 1.0, 0.2], [0.0, 0.0, 0.0, 1.0])
tf.propagate(*args, times[:10])
out['exact_ns'] = fastest(lambda: tf.propagate(*args, times)) / times.size * 1e9
rng = np.random.default_rng(1)
inertia = np.array([2.0, 3.0, 4.0]) * (1 + 0.05 * rng.random((200, 3)))
omega = np.array([0.3, 1.0, 0.2]) + 0.1 * rng.standard_normal((200, 3))
q = np.tile([0.0, 0.0, 0.0, 1.0], (200, 1))
few = np.linspace(0.0, 10.0, 100)
tf.propagate_batch(inertia, omega, q, few[:3])
out['batch_ns'] = fastest(lambda: tf.propagate_batch(inertia, omega, q, few)) / 20_000 * 1e9
explorer = tf.load_scene('explorer1')
samples = np.arange(10_001) / 100.0
explorer.propagator().states(samples[:2])
out['effects_us'] = fastest(lambda: explorer.propagator().states(samples)) / 100.0 * 1e6
plant = tf.Plant(tf.load_scene('detumble'), 10.0)
torque = np.array([0.001, -0.002, 0.0005])
plant.step(torque)


def steps():
    for _ in range(500):
        plant.step(torque)


out['plant_us'] = fastest(steps) / 500 * 1e6
print(json.dumps(out))
"""

MEASURES = {
    'exact_ns': 'exact solution (`propagate`), per sample, ns',
    'batch_ns': 'exact solution for 200 bodies (`propagate_batch`), per body-sample, ns',
    'effects_us': '`explorer1` (damper, DOP853), CPU per simulated second at 100 Hz, µs',
    'plant_us': '`Plant.step` (`detumble`, commanded torque, 10 Hz), per step, µs',
}


def measure(tree: Path, calls: int) -> dict:
    """Run the measures in a fresh interpreter importing the package from ``tree``."""
    result = subprocess.run(
        [sys.executable, '-c', f'import sys; sys.path.insert(0, {str(tree)!r})\n' + MEASURE,
         str(calls)],
        capture_output=True, text=True, check=True, cwd=tree,
    )
    return json.loads(result.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--base', required=True, help='the revision to compare with (git)')
    parser.add_argument('--output', help='write the report here (Markdown)')
    parser.add_argument('--rounds', type=int, default=5)
    parser.add_argument('--calls', type=int, default=3)
    args = parser.parse_args(argv)
    base = subprocess.run(
        ['git', 'rev-parse', '--short', args.base], cwd=ROOT, capture_output=True, text=True,
        check=True,
    ).stdout.strip()
    head = subprocess.run(
        ['git', 'rev-parse', '--short', 'HEAD'], cwd=ROOT, capture_output=True, text=True,
        check=True,
    ).stdout.strip()
    with tempfile.TemporaryDirectory() as scratch:
        worktree = Path(scratch) / 'base'
        subprocess.run(['git', 'worktree', 'add', '--detach', '-q', str(worktree), base],
                       cwd=ROOT, check=True)
        try:
            measure(worktree, 1)  # numba compiles the revision's kernels into its own tree
            measure(ROOT, 1)
            rounds = []
            for _ in range(args.rounds):
                rounds.append((measure(worktree, args.calls), measure(ROOT, args.calls)))
        finally:
            subprocess.run(['git', 'worktree', 'remove', '--force', str(worktree)], cwd=ROOT,
                           check=False)
    report = Report(f'This tree ({head}) against {base}, side by side', 'tools/bench_against.py')
    report.add(
        f'{args.rounds} rounds, each running both trees in fresh processes, alternating; CPU '
        f'time, fastest of {args.calls} calls; median (min–max) over the rounds; the ratio is '
        'taken within each round.'
    )
    report.add('')
    report.add(f'| measure | {base} | {head} | {head} / {base} |')
    report.add('|---|---|---|---|')
    for key, label in MEASURES.items():
        old = [r[0][key] for r in rounds]
        new = [r[1][key] for r in rounds]
        ratios = [n / o for o, n in zip(old, new)]
        report.add(f'| {label} | {spread(old)} | {spread(new)} | {spread(ratios)} |')
    report.add('')
    worst = max(
        statistics.median(r[1][key] / r[0][key] for r in rounds) for key in MEASURES
    )
    report.add(f'Largest median ratio: {worst:.3g}.')
    report.save(args.output)
    return 0


if __name__ == '__main__':
    sys.exit(main())
