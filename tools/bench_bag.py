#!/usr/bin/env python3
"""Benchmark of the offline bag writer (a script, not a test): prints what it measured and the machine.

- ``torquefree_bag`` throughput (samples/s; a sample = angular_velocity + attitude) for a 1 min and a
  1 h bag at 100 Hz, side by side in the same run with the raw ``mcap`` writer writing the same number
  of pre-serialized messages with the same chunking (the library's own limit);
- where the time goes per sample (``torquefree_ros.bench.pipeline``): the exact propagator, CDR
  encoding, bag writing in blocks, and the node's recorder one sample at a time;
- peak memory (max RSS) of a fresh process writing each bag, beside one that only imports: flat
  means it does not grow with the duration.
"""

from __future__ import annotations

import argparse
import json
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

RATE = 100.0
CASES = {"1 min": 60.0, "1 h": 3600.0}


def _ours(duration: float, output: Path) -> float:
    from torquefree_ros.bag_cli import write_scene_bag
    from torquefree_ros.core.scene import default_scene

    started = time.perf_counter()
    write_scene_bag(default_scene(), output, duration, RATE)
    return time.perf_counter() - started


def _raw_mcap(messages: list[bytes], output: Path) -> float:
    """The same message count through mcap's Writer alone: one schema, two channels, no metadata work."""
    from mcap.writer import CompressionType, Writer

    with open(output, "wb") as stream:
        started = time.perf_counter()
        writer = Writer(stream, chunk_size=1024 * 1024, compression=CompressionType.NONE)
        writer.start(profile="ros2", library="raw")
        schema = writer.register_schema("geometry_msgs/msg/Vector3Stamped", "ros2msg", b"")
        channels = (writer.register_channel("/a", "cdr", schema), writer.register_channel("/b", "cdr", schema))
        add = writer.add_message
        for i, data in enumerate(messages):
            stamp = (i >> 1) * 10_000_000
            add(channels[i & 1], stamp, data, stamp)
        writer.finish()
        return time.perf_counter() - started


def _child(case: str) -> None:
    """One measurement in a fresh process, so that its peak memory is its own."""
    with tempfile.TemporaryDirectory() as tmp:
        seconds = 0.0
        if case != "imports":
            seconds = _ours(CASES[case], Path(tmp) / "bag")
        else:
            import torquefree_ros.bag_cli  # noqa: F401
    print(json.dumps({"seconds": seconds, "max_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))


def _in_child(case: str) -> dict:
    out = subprocess.run([sys.executable, __file__, "--child", case], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        _child(args.child)
        return 0
    import mcap
    import numpy

    print(f"machine: {platform.processor() or platform.machine()}, {platform.python_implementation()} "
          f"{platform.python_version()}, numpy {numpy.__version__}, mcap {mcap.__version__ if hasattr(mcap, '__version__') else '?'}")
    print(f"{'bag':>6} {'samples':>8} {'ours s':>8} {'samples/s':>10} {'raw mcap s':>11} {'raw/ours':>9}")
    from torquefree_ros.cdr import encode_stamped_doubles

    for name, duration in CASES.items():
        with tempfile.TemporaryDirectory() as tmp:
            ours = _ours(duration, Path(tmp) / "ours")
            samples = int(duration * RATE) + 1
            stamps = numpy.arange(samples) * 10_000_000
            omega = encode_stamped_doubles(stamps, "body", numpy.ones((samples, 3)))
            q = encode_stamped_doubles(stamps, "world", numpy.ones((samples, 4)))
            messages = [m for pair in zip(omega, q) for m in pair]
            del omega, q
            raw = _raw_mcap(messages, Path(tmp) / "raw.mcap")
        print(f"{name:>6} {samples:>8} {ours:>8.3f} {samples / ours:>10.0f} {raw:>11.3f} {raw / ours:>9.2f}"
              f"   (raw: {raw / len(messages) * 1e6:.2f} us/message, ours: {ours / len(messages) * 1e6:.2f})")
    from torquefree_ros.bench.pipeline import sample_costs

    costs = sample_costs()
    print("per sample (us, CPU): " + ", ".join(f"{stage} {cost:.2f}" for stage, cost in costs.items()))
    baseline = _in_child("imports")
    print(f"peak memory (max RSS): imports only {baseline['max_rss_mib']:.0f} MiB", end="")
    for name in CASES:
        result = _in_child(name)
        print(f", {name} bag {result['max_rss_mib']:.0f} MiB", end="")
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
