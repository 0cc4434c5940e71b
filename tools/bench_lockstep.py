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
Benchmark of the closed loop in lock-step.

A script, not a test: it prints what it measured and the machine it ran on.

- round trips per second: the node (this process, lock-step, as fast as the controller answers, the
  ``detumble`` library scene) and a rate-damping controller in another process that answers every
  angular_velocity sample with a WrenchStamped; a round trip is one sample out and its answer in;
- per step, side by side in one run: the node's own work (offering the command to the hold, sealing
  the interval, computing the sample with DOP853 across the hold, CDR encoding), split at the
  moment the rates go out (the rest overlaps the controller's answer), and rclpy's costs it cannot
  avoid: publishing a raw sample, taking one message from a subscription.

Every figure is repeated (``--repeats``) and given as median (min–max).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
import statistics
import subprocess
import sys
import time

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_node import _isolate_dds, NodeUnderTest  # noqa: E402
from bench_report import Report, spread  # noqa: E402

CONTROLLER = r"""
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from geometry_msgs.msg import Vector3Stamped, WrenchStamped
rclpy.init()
node = rclpy.create_node("bench_controller")
qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
publisher = node.create_publisher(WrenchStamped, "torque_command", qos)
command = WrenchStamped()
command.header.frame_id = "body"
def answer(sample):
    command.header.stamp = sample.header.stamp
    v, t = sample.vector, command.wrench.torque
    t.x, t.y, t.z = -0.01 * v.x, -0.01 * v.y, -0.01 * v.z
    publisher.publish(command)
node.create_subscription(Vector3Stamped, "angular_velocity", answer, qos)
print("ready", flush=True)
try:
    rclpy.spin(node)
except BaseException:
    pass
"""


def round_trips(
    seconds: float, scene: str = 'detumble', controller: str = CONTROLLER,
    command: str = 'torque_command',
) -> dict:
    """Measure the node's lock-step on ``scene`` answered by ``controller`` on ``command``."""
    controller = subprocess.Popen(
        [sys.executable, '-c', controller], stdout=subprocess.PIPE, text=True
    )
    try:
        assert controller.stdout.readline().strip() == 'ready'
        node = NodeUnderTest(
            scene=scene, lockstep=True, real_time_factor=0.0, lockstep_timeout=0.2
        )
    except BaseException:
        controller.kill()
        raise
    try:
        samples = node.node._outputs.angular_velocity
        commands = node.node._commands._subscriptions[command]
        deadline = time.monotonic() + 20.0
        while not (samples.get_subscription_count() and commands.get_publisher_count()):
            if time.monotonic() > deadline:
                raise RuntimeError('the controller was not discovered')
            time.sleep(0.01)
        loop = node.node.sample_loop
        # past the start-up run's unanswered first samples (each waits lockstep_timeout)
        time.sleep(1.5)
        published0, missed0 = loop.published, loop.missed_steps
        cpu0, wall0 = time.process_time(), time.monotonic()
        time.sleep(seconds)
        cpu, wall = time.process_time() - cpu0, time.monotonic() - wall0
        published, missed = loop.published - published0, loop.missed_steps - missed0
    finally:
        node.close()
        controller.send_signal(2)
        controller.communicate(timeout=20)
    return {'rate': published / wall, 'missed': missed, 'cpu': cpu / wall}


def ping_pong(
    seconds: float, threaded: bool, controller: str = CONTROLLER,
    command: tuple = ('torque_command', 'geometry_msgs.msg.WrenchStamped'),
) -> float:
    """
    Measure the round trips per second of rclpy alone.

    This process publishes a raw angular_velocity sample and waits for the same controller's
    answer before the next. ``threaded``: as the node does it, the sample goes out from a thread of
    its own that waits for the executor's thread to hand it the answer; otherwise the answer's
    callback publishes the next sample (one thread, the floor). ``command``: the answer's topic
    and message type (module.Class).
    """
    import importlib
    import threading

    from geometry_msgs.msg import Vector3Stamped
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from rclpy.serialization import serialize_message

    topic, type_name = command
    module, _, name = type_name.rpartition('.')
    answer_type = getattr(importlib.import_module(module), name)
    controller = subprocess.Popen(
        [sys.executable, '-c', controller], stdout=subprocess.PIPE, text=True
    )
    context = rclpy.Context()
    try:
        assert controller.stdout.readline().strip() == 'ready'
        rclpy.init(context=context)
        node = rclpy.create_node('bench_ping', context=context)
        qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
        publisher = node.create_publisher(Vector3Stamped, 'angular_velocity', qos)
        sample = serialize_message(Vector3Stamped())
        answered = threading.Event()
        counts = [0]

        def on_answer(_):
            counts[0] += 1
            if threaded:
                answered.set()
            else:
                publisher.publish(sample)

        node.create_subscription(answer_type, topic, on_answer, qos, raw=True)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        deadline = time.monotonic() + 20.0
        while not (publisher.get_subscription_count() and node.count_publishers(topic)):
            if time.monotonic() > deadline:
                raise RuntimeError('the controller was not discovered')
            time.sleep(0.01)
        stop = threading.Event()

        def ping():
            while not stop.is_set():
                answered.clear()
                publisher.publish(sample)
                answered.wait(0.2)

        spinner = threading.Thread(target=lambda: _spin_until(executor, stop), daemon=True)
        spinner.start()
        if threaded:
            pinger = threading.Thread(target=ping, daemon=True)
            pinger.start()
        else:
            publisher.publish(sample)
        time.sleep(1.0)  # warm-up
        count0, wall0 = counts[0], time.monotonic()
        time.sleep(seconds)
        rate = (counts[0] - count0) / (time.monotonic() - wall0)
        stop.set()
        spinner.join(5.0)
        if threaded:
            pinger.join(5.0)
        executor.shutdown()
        node.destroy_node()
    finally:
        context.try_shutdown()
        controller.send_signal(2)
        controller.communicate(timeout=20)
    return rate


def _spin_until(executor, stop) -> None:
    while not stop.is_set():
        executor.spin_once(timeout_sec=0.05)


def step_costs(steps: int = 2000) -> dict:
    """Seconds per lock-step step of the node's own work, and of rclpy's publish and take."""
    from geometry_msgs.msg import Vector3Stamped
    import numpy as np
    import rclpy
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from torquefree_ros import load_scene
    from torquefree_ros.bag.samples import encode_block, encode_leading, encode_trailing
    from torquefree_ros.core.run.simulation import Simulation

    scene = load_scene('detumble')
    simulation = Simulation(scene.propagator(), 100.0, outputs=scene.outputs)
    ((_, hold),) = simulation.command_holds
    hold.frame_id = 'body'
    block = simulation.samples(0, 1)
    leading = trailing = 0.0
    for n in range(1, steps + 1):
        started = time.perf_counter()
        w = block.omega_B[0]
        hold.receive(hold.stamp_ns(n - 1), -0.01 * w, frame_id='body')
        hold.seal(n - 1)
        block = simulation.samples(n, 1, outputs=False)
        encode_leading(block, 'body', clock=True)
        rates_out = time.perf_counter()
        block = simulation.with_outputs(block)
        encode_trailing(block, 'body', 'world', simulation.outputs)
        leading += rates_out - started
        trailing += time.perf_counter() - rates_out
    node_cost = (leading + trailing) / steps

    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node('bench_rclpy', context=context)
    qos = QoSProfile(depth=steps, reliability=ReliabilityPolicy.RELIABLE)
    publisher = node.create_publisher(Vector3Stamped, 'bench_take', qos)
    subscription = node.create_subscription(Vector3Stamped, 'bench_take', lambda m: None, qos)
    message = encode_block(block, 'body', 'world')[0].messages[0]
    deadline = time.monotonic() + 20.0
    while publisher.get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    started = time.perf_counter()
    for _ in range(steps):
        publisher.publish(message)
    publish_cost = (time.perf_counter() - started) / steps
    time.sleep(0.5)  # let every message arrive
    taken, started = 0, time.perf_counter()
    while subscription.handle.take_message(subscription.msg_type, subscription.raw) is not None:
        taken += 1
    take_cost = (time.perf_counter() - started) / max(taken, 1)
    # the executor's share: one spin_once that takes a message and runs an empty callback
    from rclpy.executors import SingleThreadedExecutor

    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    for _ in range(steps):
        publisher.publish(message)
    time.sleep(0.5)
    called = [0]
    subscription.callback = lambda m: called.__setitem__(0, called[0] + 1)
    started = time.perf_counter()
    while called[0] < steps // 2:
        executor.spin_once(timeout_sec=0.0)
    dispatch_cost = (time.perf_counter() - started) / called[0]
    executor.shutdown()
    node.destroy_node()
    context.try_shutdown()
    assert np.isfinite(node_cost) and taken > steps // 2, taken
    return {
        'node': node_cost,
        'leading': leading / steps,
        'trailing': trailing / steps,
        'publish': publish_cost,
        'take': take_cost,
        'dispatch': dispatch_cost,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().split('\n\n')[0])
    parser.add_argument(
        '--seconds', type=float, default=5.0, help='duration of each round-trip run (default: 5)'
    )
    parser.add_argument(
        '--repeats', type=int, default=3, help='runs of each measurement (default: 3)'
    )
    parser.add_argument(
        '--output', help='also write the report here (make bench-lockstep: docs/bench/lockstep.md)'
    )
    args = parser.parse_args(argv)
    _isolate_dds()

    report = Report('Closed loop in lock-step', 'make bench-lockstep')
    report.add(f'{args.repeats} runs, median (min–max); ROS domain {os.environ["ROS_DOMAIN_ID"]}')
    report.add('')
    runs, floors, handoffs = [], [], []
    for _ in range(args.repeats):  # interleaved, so that a noisy moment hits all three alike
        floors.append(ping_pong(args.seconds, threaded=False))
        runs.append(round_trips(args.seconds))
        handoffs.append(ping_pong(args.seconds, threaded=True))
    ratios = [r['rate'] / f for r, f in zip(runs, floors)]
    report.add(
        'Round trips per second (library scene `detumble` at 100 Hz, DOP853 at 1e-10 across each '
        f'hold, the controller in another process, {args.seconds:g} s each): '
        f'{spread([r["rate"] for r in runs])}; '
        f"missed steps {spread([r['missed'] for r in runs])}; the node's process CPU "
        f'{spread([100 * r["cpu"] for r in runs])} % of a core.'
    )
    report.add('')
    report.add(
        "rclpy's floor, side by side (the same controller; this process publishes a raw sample "
        "and waits for the answer before the next): answered from the answer's callback, one "
        f'thread, {spread(floors)} round trips per second; from a thread of its own handed each '
        f"answer by the executor's thread, as the node's sample loop is, {spread(handoffs)}."
    )
    report.add(f"The node's lock-step / the floor, run by run: {spread(ratios)}.")
    report.add('')
    costs = [step_costs() for _ in range(args.repeats)]
    report.add(
        "Per step, µs, in one process: the node's own work (command into the hold, seal, one "
        f'sample computed, CDR encoded) {spread([1e6 * c["node"] for c in costs])}, of which '
        f'{spread([1e6 * c["leading"] for c in costs])} before the rates go out (/clock and '
        'angular_velocity) and '
        f'{spread([1e6 * c["trailing"] for c in costs])} after them (attitude and markers, '
        'computed and encoded while the controller works on its answer); rclpy publishing one '
        f'raw sample {spread([1e6 * c["publish"] for c in costs])}; rclpy taking one message '
        f'{spread([1e6 * c["take"] for c in costs])}; the executor taking one message and calling '
        f'its callback {spread([1e6 * c["dispatch"] for c in costs])}.'
    )
    leading_us = statistics.median(1e6 * c['leading'] for c in costs)
    round_trip = 1e6 / statistics.median(r['rate'] for r in runs)
    floor = 1e6 / statistics.median(floors)
    report.add('')
    report.add(
        f"Where a round trip goes (medians): {round_trip:.0f} µs; rclpy's floor (both "
        f"processes' executors, DDS both ways, the controller) is {floor:.0f} µs, and the node's "
        f'work before the rates go out {leading_us:.0f} µs. The rest of a step (the trailing '
        'work, two more publishes) runs while the controller answers, so a round trip can beat '
        "floor + the node's work; what is left "
        f'({round_trip - floor - leading_us:+.0f} µs) is the node taking the command through its '
        "own wait set (raw) where the floor runs its executor's callback, the trailing work when "
        "it outlasts the controller, and the machine's noise."
    )
    report.save(args.output)
    return 0


if __name__ == '__main__':
    sys.exit(main())
