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
Benchmark of the simulator node's ROS layer.

A script, not a test: it prints what it measured and the machine it ran on.

- real time: the share of late samples (published more than one period after they were due) at each
  publish_rate, with a subscriber in another process receiving both topics, beside the machine's
  own floor: a bare loop that only waits for each deadline the way the node does, at the same rate,
  run right after, with its late share by the same rule;
- CPU use of the node process at 100 Hz;
- samples/s as fast as possible (real_time_factor 0, /clock included);
- cost per sample, side by side in one run: the core's block evaluation, the CDR encoding, the
  publishes (``torquefree_ros.bench.pipeline``), and, for comparison, rclpy's message-object path.

The node runs in this process (its loop thread plus an executor thread, as under `ros2 run`).
Every figure is repeated (``--repeats``) and given as median (min–max).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
import subprocess
import sys
import threading
import time

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_report import Report, spread  # noqa: E402

SUBSCRIBER = r"""
import sys, rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
rclpy.init()
node = rclpy.create_node("bench_subscriber")
counts = [0, 0]
qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
node.create_subscription(
    Vector3Stamped, "angular_velocity", lambda m: counts.__setitem__(0, counts[0] + 1), qos
)
node.create_subscription(
    QuaternionStamped, "attitude", lambda m: counts.__setitem__(1, counts[1] + 1), qos
)
print("ready", flush=True)
try:
    rclpy.spin(node)
except BaseException:
    pass
print(counts[0], counts[1], flush=True)
"""


def _isolate_dds() -> None:
    os.environ.setdefault('ROS_DOMAIN_ID', str(150 + os.getpid() % 80))
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'


class NodeUnderTest:

    def __init__(self, **parameters):
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.parameter import Parameter
        from torquefree_ros.ros.node import TorqueFreeSim

        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        overrides = [Parameter(k, value=v) for k, v in parameters.items()]
        self.node = TorqueFreeSim(context=self.context, parameter_overrides=overrides)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self):
        try:
            self.executor.spin()
        except Exception:  # noqa: BLE001 - shutdown
            pass

    def wait_subscribed(self, timeout=20.0):
        publisher = self.node._outputs.attitude
        deadline = time.monotonic() + timeout
        while publisher.get_subscription_count() == 0:
            if time.monotonic() > deadline:
                raise RuntimeError('the subscriber was not discovered')
            time.sleep(0.01)

    def close(self):
        self.executor.shutdown()
        self.thread.join(5.0)
        self.node.destroy_node()
        self.context.try_shutdown()


def start_subscriber():
    process = subprocess.Popen(
        [sys.executable, '-c', SUBSCRIBER], stdout=subprocess.PIPE, text=True
    )
    assert process.stdout.readline().strip() == 'ready'
    return process


def stop_subscriber(process):
    process.send_signal(2)
    process.communicate(timeout=20)


def measure_run(seconds: float, **parameters) -> dict:
    subscriber = start_subscriber()
    try:
        node = NodeUnderTest(**parameters)
    except BaseException:
        subscriber.kill()
        raise
    try:
        node.wait_subscribed()
        loop = node.node.sample_loop
        published0, late0 = loop.published, loop.late
        cpu0, wall0 = time.process_time(), time.monotonic()
        time.sleep(seconds)
        cpu, wall = time.process_time() - cpu0, time.monotonic() - wall0
        published, late = loop.published - published0, loop.late - late0
    finally:
        node.close()
        stop_subscriber(subscriber)
    return {'published': published, 'late': late, 'cpu': cpu / wall, 'wall': wall}


def sleep_floor(rate: float, seconds: float) -> float:
    """
    Return the share of ticks of a bare loop that wake more than one period late.

    The ticks that wake more than one period after their deadline, waiting as the node's sample
    loop waits (``threading.Event.wait`` until the deadline) and doing nothing else: what the
    machine's scheduler alone costs at this rate.
    """
    period, wake = 1.0 / rate, threading.Event()
    ticks = max(1, int(seconds * rate))
    start, late = time.monotonic(), 0
    for k in range(ticks):
        due = start + k * period
        delay = due - time.monotonic()
        if delay > 0:
            wake.wait(delay)
        late += time.monotonic() - due > period
    return late / ticks


def message_object_cost(samples: int = 20000) -> float:
    """
    Return the seconds per sample of the path the node avoids.

    That path: filling message objects and rclpy publish(msg).
    """
    from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
    import rclpy
    from rosgraph_msgs.msg import Clock
    from torquefree_ros.core.scene.loader import default_scene
    from torquefree_ros.core.run.simulation import Simulation

    block = Simulation(default_scene().propagator(), 100.0).samples(0, samples)
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node('bench_publish', context=context)
    omega_pub = node.create_publisher(Vector3Stamped, 'angular_velocity', 10)
    q_pub = node.create_publisher(QuaternionStamped, 'attitude', 10)
    clock_pub = node.create_publisher(Clock, '/clock', 10)
    omega_msg, q_msg, clock_msg = Vector3Stamped(), QuaternionStamped(), Clock()
    omega_msg.header.frame_id, q_msg.header.frame_id = 'body', 'world'
    t = time.perf_counter()
    for stamp, w, q in zip(block.stamps_ns.tolist(), block.omega_B.tolist(), block.q_NB.tolist()):
        sec, nanosec = divmod(stamp, 1_000_000_000)
        for header in (omega_msg.header, q_msg.header):
            header.stamp.sec, header.stamp.nanosec = sec, nanosec
        clock_msg.clock.sec, clock_msg.clock.nanosec = sec, nanosec
        v, o = omega_msg.vector, q_msg.quaternion
        v.x, v.y, v.z = w
        o.x, o.y, o.z, o.w = q
        clock_pub.publish(clock_msg)
        omega_pub.publish(omega_msg)
        q_pub.publish(q_msg)
    cost = (time.perf_counter() - t) / samples
    node.destroy_node()
    context.try_shutdown()
    return cost


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().split('\n\n')[0])
    parser.add_argument(
        '--seconds', type=float, default=5.0, help='duration of each run (default: 5)'
    )
    parser.add_argument('--rates', type=float, nargs='+', default=[100, 500, 1000, 2000, 4000])
    parser.add_argument(
        '--repeats', type=int, default=3, help='runs of each measurement (default: 3)'
    )
    parser.add_argument(
        '--output', help='also write the report here (make bench-node: docs/bench/node.md)'
    )
    args = parser.parse_args(argv)
    _isolate_dds()
    import rclpy  # noqa: F401

    report = Report('Simulator node cost', 'make bench-node')
    report.add(
        f'{args.repeats} runs of {args.seconds:g} s each, median (min–max); '
        f'ROS domain {os.environ["ROS_DOMAIN_ID"]}'
    )
    report.add('')
    report.add(
        'Real time (real_time_factor 1), both topics, a subscriber in another process. '
        'A sample is late when it'
    )
    report.add(
        'goes out more than one period after its stamp; the sleep floor is a bare loop that '
        'only waits for'
    )
    report.add(
        'each deadline the same way, run right after at the same rate: lateness the node '
        'cannot go below.'
    )
    report.add('')
    report.add(
        '| publish_rate (Hz) | late samples, % | sleep floor, late ticks % | '
        'node CPU, % of a core |'
    )
    report.add('|---|---|---|---|')
    for rate in args.rates:
        late, floor, cpu = [], [], []
        for _ in range(args.repeats):
            r = measure_run(args.seconds, publish_rate=float(rate), qos_depth=1000)
            late.append(100 * r['late'] / max(r['published'], 1))
            cpu.append(100 * r['cpu'])
            floor.append(100 * sleep_floor(rate, args.seconds))
        report.add(f'| {rate:g} | {spread(late)} | {spread(floor)} | {spread(cpu)} |')

    throughput = []
    for _ in range(args.repeats):
        r = measure_run(args.seconds, publish_rate=100.0, real_time_factor=0.0, qos_depth=1000)
        throughput.append(r['published'] / r['wall'])
    report.add('')
    report.add(
        'As fast as possible (real_time_factor 0, /clock published, a subscriber in another '
        f'process): {spread(throughput)} samples/s.'
    )

    from torquefree_ros.bench.pipeline import sample_costs

    stages = ('propagate (exact)', 'CDR encoding', 'node publishes (3 raw, no subscriber)')
    costs = [sample_costs() for _ in range(args.repeats)]
    objects = [1e6 * message_object_cost() for _ in range(args.repeats)]
    report.add('')
    total = spread([sum(c[stage] for stage in stages) for c in costs])
    report.add(
        'Cost per sample (µs of CPU), blocks of 256, no subscriber, one process: '
        + ', '.join(f'{stage} {spread([c[stage] for c in costs])}' for stage in stages)
        + f'; total {total}. For comparison, filling message objects and rclpy publish(msg): '
        f'{spread(objects)}.'
    )
    report.save(args.output)
    return 0


if __name__ == '__main__':
    sys.exit(main())
