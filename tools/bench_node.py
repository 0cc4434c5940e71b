#!/usr/bin/env python3
"""Benchmark of the simulator node's ROS layer (a script, not a test): prints what it measured and
the machine it ran on.

- real time: the highest publish_rate at which fewer than 1 % of samples are late (published more
  than one period after they were due), with a subscriber in another process receiving both topics;
- CPU use of the node process at 100 Hz;
- samples/s as fast as possible (real_time_factor 0, /clock included);
- cost per sample, side by side in one run: the core's block evaluation, the CDR encoding, the
  publishes (``torquefree_ros.bench.pipeline``), and, for comparison, rclpy's message-object path.

The node runs in this process (its loop thread plus an executor thread, as under `ros2 run`).
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

SUBSCRIBER = r"""
import sys, rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
rclpy.init()
node = rclpy.create_node("bench_subscriber")
counts = [0, 0]
qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
node.create_subscription(Vector3Stamped, "angular_velocity", lambda m: counts.__setitem__(0, counts[0] + 1), qos)
node.create_subscription(QuaternionStamped, "attitude", lambda m: counts.__setitem__(1, counts[1] + 1), qos)
print("ready", flush=True)
try:
    rclpy.spin(node)
except BaseException:
    pass
print(counts[0], counts[1], flush=True)
"""


def _isolate_dds() -> None:
    os.environ.setdefault("ROS_DOMAIN_ID", str(150 + os.getpid() % 80))
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"


class NodeUnderTest:
    def __init__(self, **parameters):
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.parameter import Parameter

        from torquefree_ros.sim_node import TorqueFreeSim

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
                raise RuntimeError("the subscriber was not discovered")
            time.sleep(0.01)

    def close(self):
        self.executor.shutdown()
        self.thread.join(5.0)
        self.node.destroy_node()
        self.context.try_shutdown()


def start_subscriber():
    process = subprocess.Popen([sys.executable, "-c", SUBSCRIBER], stdout=subprocess.PIPE, text=True)
    assert process.stdout.readline().strip() == "ready"
    return process


def stop_subscriber(process):
    process.send_signal(2)
    out, _ = process.communicate(timeout=20)
    return [int(x) for x in out.split()[:2]]


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
        received = stop_subscriber(subscriber)
    return {"published": published, "late": late, "cpu": cpu / wall, "wall": wall, "received": received}


def message_object_cost(samples: int = 20000) -> float:
    """Seconds per sample of the path the node avoids: filling message objects and rclpy publish(msg)."""
    import rclpy
    from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
    from rosgraph_msgs.msg import Clock

    from torquefree_ros.core.scene import default_scene
    from torquefree_ros.core.simulation import Simulation

    block = Simulation(default_scene().propagator(), 100.0).samples(0, samples)
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("bench_publish", context=context)
    omega_pub = node.create_publisher(Vector3Stamped, "angular_velocity", 10)
    q_pub = node.create_publisher(QuaternionStamped, "attitude", 10)
    clock_pub = node.create_publisher(Clock, "/clock", 10)
    omega_msg, q_msg, clock_msg = Vector3Stamped(), QuaternionStamped(), Clock()
    omega_msg.header.frame_id, q_msg.header.frame_id = "body", "world"
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
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="duration of each run (default 5)")
    parser.add_argument("--rates", type=float, nargs="+", default=[100, 500, 1000, 2000, 4000, 8000])
    args = parser.parse_args(argv)
    _isolate_dds()
    import numpy
    import rclpy  # noqa: F401

    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, {platform.platform()}; "
          f"python {platform.python_version()}, numpy {numpy.__version__}, ROS domain {os.environ['ROS_DOMAIN_ID']}")

    print("\nreal time (real_time_factor 1), both topics, a subscriber in another process:")
    print("| publish_rate (Hz) | published | late | late % | received w/q (whole run) | node CPU (% of a core) |")
    print("|---|---|---|---|---|---|")
    sustained = 0.0
    for rate in args.rates:
        r = measure_run(args.seconds, publish_rate=float(rate), qos_depth=1000)
        late_share = r["late"] / max(r["published"], 1)
        print(f"| {rate:g} | {r['published']} | {r['late']} | {100 * late_share:.2f} | "
              f"{r['received'][0]}/{r['received'][1]} | {100 * r['cpu']:.1f} |", flush=True)
        if late_share < 0.01 and r["published"] >= 0.99 * rate * r["wall"]:
            sustained = max(sustained, rate)
    print(f"highest rate sustained in real time with < 1 % late samples: {sustained:g} Hz")

    r = measure_run(args.seconds, publish_rate=100.0, real_time_factor=0.0, qos_depth=1000)
    print(f"\nas fast as possible (real_time_factor 0, /clock published): {r['published'] / r['wall']:.0f} samples/s, "
          f"subscriber received {r['received'][0]}/{r['received'][1]} (reliable keep-last 1000 drops what it "
          f"cannot take), node CPU {100 * r['cpu']:.0f} % of a core")

    from torquefree_ros.bench.pipeline import sample_costs

    costs = sample_costs()
    print("\ncost per sample (us), blocks of 256, no subscriber, one process (CPU time):")
    for stage in ("propagate (exact)", "CDR encoding", "node publishes (3 raw, no subscriber)"):
        print(f"  {stage}: {costs[stage]:.2f}")
    total = sum(costs[stage] for stage in ("propagate (exact)", "CDR encoding", "node publishes (3 raw, no subscriber)"))
    print(f"  total: {total:.2f} us -> at most {1e6 / total:.0f} samples/s")
    print(f"  for comparison, filling message objects and rclpy publish(msg): "
          f"{1e6 * message_object_cost():.2f} us per sample")
    return 0


if __name__ == "__main__":
    sys.exit(main())
