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
Benchmark of the test kit (``torquefree_ros.testing``).

A script, not a test: it prints what it measured and the machine.

- the fixture's set-up (``simulator(...)`` entered: a private context in a domain of its own, the
  node, the kit's recorder), its first ``advance(1)`` (which waits for discovery) and teardown
  (every node destroyed, the context shut down, the domain released);
- ``advance(1)`` with one subscriber node added (a callback on ``angular_velocity``), and with none
  (the kit's own recorder only): one sample out of the node's loop thread and every watched
  callback run;
- beside them, in the same process and run, rclpy's floor: a bare publish-and-take round trip (one
  ``Vector3Stamped`` published, the executor spun in the same thread until its callback has run).

Each figure: median (min–max) over ``--rounds`` rounds (wall time, ``perf_counter``).
"""

from __future__ import annotations

import argparse
from pathlib import Path
import statistics
import sys
import time

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_report import Report, spread  # noqa: E402

# the exact solution; angular_velocity, attitude, /clock and markers each sample
SCENE = 'dzhanibekov'


def set_up_and_teardown(count: int) -> tuple[list[float], list[float], list[float]]:
    """Seconds to set up, for the first advance(1) (which waits for discovery), to tear down."""
    from torquefree_ros.testing import Simulator

    ups, firsts, downs = [], [], []
    for _ in range(count):
        started = time.perf_counter()
        sim = Simulator(scene=SCENE)
        ups.append(time.perf_counter() - started)
        started = time.perf_counter()
        sim.advance(1)
        firsts.append(time.perf_counter() - started)
        started = time.perf_counter()
        sim.close()
        downs.append(time.perf_counter() - started)
    return ups, firsts, downs


def advance_cost(samples: int, subscriber: bool) -> float:
    """Seconds per advance(1) (the first sample, which waits for discovery, not counted)."""
    from geometry_msgs.msg import Vector3Stamped
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from torquefree_ros.testing import simulator

    with simulator(scene=SCENE) as sim:
        if subscriber:
            node = sim.create_node('bench_subscriber')
            node.create_subscription(
                Vector3Stamped,
                'angular_velocity',
                lambda m: None,
                QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE),
            )
        sim.advance(1)
        started = time.perf_counter()
        for _ in range(samples):
            sim.advance(1)
        return (time.perf_counter() - started) / samples


def round_trip(count: int) -> float:
    """Seconds per bare publish-and-take round trip in one process and thread."""
    from geometry_msgs.msg import Vector3Stamped
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from torquefree_ros.testing.domains import claim_domain

    claim, context = claim_domain(), rclpy.Context()
    try:
        rclpy.init(context=context, domain_id=claim.domain_id)
        node = rclpy.create_node('bench_round_trip', context=context)
        qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        publisher = node.create_publisher(Vector3Stamped, 'round_trip', qos)
        taken = [0]
        node.create_subscription(
            Vector3Stamped, 'round_trip', lambda m: taken.__setitem__(0, taken[0] + 1), qos
        )
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        deadline = time.monotonic() + 20.0
        while publisher.get_subscription_count() == 0:
            if time.monotonic() > deadline:
                raise RuntimeError('the subscription was not matched within 20 s')
            executor.spin_once(timeout_sec=0.01)
        message = Vector3Stamped()

        def once():
            want = taken[0] + 1
            publisher.publish(message)
            while taken[0] < want:
                executor.spin_once(timeout_sec=1.0)

        once()
        started = time.perf_counter()
        for _ in range(count):
            once()
        cost = (time.perf_counter() - started) / count
        executor.shutdown()
        node.destroy_node()
        return cost
    finally:
        context.try_shutdown()
        claim.release()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--output', help='write the report here (Markdown)')
    parser.add_argument('--rounds', type=int, default=3)
    parser.add_argument('--fixtures', type=int, default=5, help='set-ups and teardowns per round')
    parser.add_argument(
        '--samples', type=int, default=2000, help='advance(1) calls and round trips per round'
    )
    args = parser.parse_args(argv)

    import rclpy  # noqa: F401 - imports out of the timings
    from torquefree_ros.testing import Simulator

    # numba's kernels and the message types loaded once, out of the timings
    Simulator(scene=SCENE).close()
    report = Report(
        "The test kit: fixture and advance(1), beside rclpy's round trip",
        '.venv/bin/python tools/bench_testing_kit.py',
    )
    report.add(
        f'{args.rounds} rounds, median (min–max). Scene `{SCENE}` (the exact solution; each '
        'sample goes out on angular_velocity, attitude, /clock and markers). Each round: '
        f'{args.fixtures} set-ups and teardowns (their median), {args.samples} advance(1) calls '
        f'and {args.samples} round trips (the mean of each).'
    )
    report.add('')
    rows = {'up': [], 'first': [], 'down': [], 'one': [], 'none': [], 'floor': []}
    for _ in range(args.rounds):
        ups, firsts, downs = set_up_and_teardown(args.fixtures)
        rows['up'].append(statistics.median(ups))
        rows['first'].append(statistics.median(firsts))
        rows['down'].append(statistics.median(downs))
        rows['one'].append(advance_cost(args.samples, subscriber=True))
        rows['none'].append(advance_cost(args.samples, subscriber=False))
        rows['floor'].append(round_trip(args.samples))

    def ms(key):
        return spread([1e3 * value for value in rows[key]])

    def us(key):
        return spread([1e6 * value for value in rows[key]])

    ratio = spread([one / floor for one, floor in zip(rows['one'], rows['floor'])])
    report.add('| measure | value |')
    report.add('|---|---|')
    report.add(
        "| fixture set-up (`simulator(...)` entered: context, domain, node, the kit's recorder) "
        f'| {ms("up")} ms |'
    )
    report.add(
        "| its first `advance(1)` (waits for discovery: the node's publishers matching the "
        f'recorder) | {ms("first")} ms |'
    )
    report.add(
        '| fixture teardown (nodes destroyed, context shut down, domain released) | '
        f'{ms("down")} ms |'
    )
    report.add(f'| `advance(1)`, one subscriber node added | {us("one")} µs |')
    report.add(f"| `advance(1)`, no node added (the kit's recorder only) | {us('none')} µs |")
    report.add(
        f'| bare rclpy publish-and-take round trip (one process, one thread) | {us("floor")} µs |'
    )
    report.add(f'| `advance(1)` with one subscriber / the round trip | {ratio} |')
    report.add('')
    report.add(
        "An advance(1) is one sample: the loop's thread woken to publish four messages, and the "
        "executor spun in the test's thread until every watched callback (the subscriber's, the "
        "recorder's two) has run."
    )
    report.save(args.output)
    return 0


if __name__ == '__main__':
    sys.exit(main())
