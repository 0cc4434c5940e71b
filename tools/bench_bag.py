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
Benchmark of the offline bag writer.

A script, not a test: it prints what it measured and the machine.

- ``torquefree_bag`` throughput (samples/s; a sample = angular_velocity + attitude) for a 1 min and
  a 1 h bag at 100 Hz, side by side in the same run with the raw ``mcap`` writer writing the same
  number of pre-serialized messages with the same chunking (the library's own limit);
- where the time goes per sample (``torquefree_ros.bench.pipeline``): the exact propagator, CDR
  encoding, bag writing in blocks, and the node's recorder one sample at a time;
- peak memory (VmHWM, the process's own high-water mark, reset at exec) of a fresh process writing
  each bag, beside one that only imports: flat means it does not grow with the duration.
  ``--day`` measures only that, for one bag of 24 h at 1 kHz (86.4 million samples, ~15 GB, ~20
  min).

Every timing is repeated (``--repeats``, ours and raw interleaved) and given as median (min–max).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_report import Report, spread  # noqa: E402

RATE = 100.0
CASES = {'1 min': 60.0, '1 h': 3600.0}
DAY = '24 h at 1 kHz'  # --day: (duration s, rate Hz) below
DAY_BAG = (86_400.0, 1_000.0)


def _ours(duration: float, output: Path, rate: float = RATE) -> float:
    from torquefree_ros.bag.offline import write_scene_bag
    from torquefree_ros.core.scene.loader import default_scene

    started = time.perf_counter()
    write_scene_bag(default_scene(), output, duration, rate)
    return time.perf_counter() - started


def _raw_mcap(messages: list[bytes], output: Path) -> float:
    """
    Time mcap's Writer alone writing the same messages.

    The same message count through mcap's Writer alone: one schema, two channels, no metadata work.
    """
    from mcap.writer import CompressionType, Writer

    with open(output, 'wb') as stream:
        started = time.perf_counter()
        writer = Writer(stream, chunk_size=1024 * 1024, compression=CompressionType.NONE)
        writer.start(profile='ros2', library='raw')
        schema = writer.register_schema('geometry_msgs/msg/Vector3Stamped', 'ros2msg', b'')
        channels = (
            writer.register_channel('/a', 'cdr', schema),
            writer.register_channel('/b', 'cdr', schema),
        )
        add = writer.add_message
        for i, data in enumerate(messages):
            stamp = (i >> 1) * 10_000_000
            add(channels[i & 1], stamp, data, stamp)
        writer.finish()
        return time.perf_counter() - started


def _child(case: str) -> None:
    """One measurement in a fresh process, so that its peak memory is its own."""
    with tempfile.TemporaryDirectory() as tmp:
        seconds, size = 0.0, 0
        if case == 'imports':
            import torquefree_ros.cli.bag  # noqa: F401
        else:
            duration, rate = DAY_BAG if case == DAY else (CASES[case], RATE)
            seconds = _ours(duration, Path(tmp) / 'bag', rate)
            size = sum(f.stat().st_size for f in (Path(tmp) / 'bag').iterdir())
    # not ru_maxrss: Linux keeps it across fork and exec, so it would report the parent's size
    hwm_kib = next(
        int(line.split()[1])
        for line in Path('/proc/self/status').read_text().splitlines()
        if line.startswith('VmHWM:')
    )
    print(json.dumps({'seconds': seconds, 'bytes': size, 'max_rss_mib': hwm_kib / 1024}))


def _in_child(case: str) -> dict:
    out = subprocess.run(
        [sys.executable, __file__, '--child', case], capture_output=True, text=True
    )
    if out.returncode:
        raise SystemExit(f'--child {case!r} failed:\n{out.stderr}')
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--child', help=argparse.SUPPRESS)
    parser.add_argument(
        '--repeats', type=int, default=3, help='runs of each measurement (default: 3)'
    )
    parser.add_argument(
        '--output', help='also write the report here (make bench-bag: docs/bench/bag.md)'
    )
    parser.add_argument(
        '--day',
        action='store_true',
        help=f'only the peak memory of one {DAY} bag, beside imports only (~20 min)',
    )
    args = parser.parse_args()
    if args.child:
        _child(args.child)
        return 0
    if args.day:
        return _day(args.output)
    import mcap
    import numpy
    from torquefree_ros.bag.cdr import encode_stamped_doubles

    report = Report('Bag writing cost', 'make bench-bag')
    report.add(
        f'mcap {getattr(mcap, "__version__", "?")}; {args.repeats} runs each, median (min–max); '
        'a sample = angular_velocity + attitude at 100 Hz'
    )
    report.add('')
    report.add(
        '| bag | samples | `torquefree_bag` s | samples/s | raw mcap writer s | raw / ours |'
    )
    report.add('|---|---|---|---|---|---|')
    # warm up (imports, the exact kernels' load), not measured
    with tempfile.TemporaryDirectory() as tmp:
        _ours(1.0, Path(tmp) / 'warm')
    for name, duration in CASES.items():
        samples = int(duration * RATE) + 1
        stamps = numpy.arange(samples) * 10_000_000
        omega = encode_stamped_doubles(stamps, 'body', numpy.ones((samples, 3)))
        q = encode_stamped_doubles(stamps, 'world', numpy.ones((samples, 4)))
        messages = [m for pair in zip(omega, q) for m in pair]
        del omega, q
        ours, raw = [], []
        for _ in range(args.repeats):
            with tempfile.TemporaryDirectory() as tmp:
                ours.append(_ours(duration, Path(tmp) / 'ours'))
                raw.append(_raw_mcap(messages, Path(tmp) / 'raw.mcap'))
        report.add(
            f'| {name} | {samples:,} | {spread(ours)} | {spread([samples / t for t in ours])} | '
            f'{spread(raw)} | {spread([r / o for r, o in zip(raw, ours)])} |'
        )
    from torquefree_ros.bench.pipeline import sample_costs

    report.add('')
    costs = [sample_costs() for _ in range(args.repeats)]
    report.add(
        'per sample (µs of CPU): '
        + ', '.join(f'{stage} {spread([c[stage] for c in costs])}' for stage in costs[0])
    )
    memory = {
        case: [_in_child(case)['max_rss_mib'] for _ in range(args.repeats)]
        for case in ('imports', *CASES)
    }
    labels = {case: 'imports only' if case == 'imports' else f'{case} bag' for case in memory}
    report.add(
        'peak memory (VmHWM, MiB, a fresh process each): '
        + ', '.join(
            f'{labels[case]} {statistics.median(values):.0f}' for case, values in memory.items()
        )
    )
    report.save(args.output)
    return 0


def _day(output: str | None) -> int:
    report = Report(f'Bag writing memory, {DAY}', 'make bench-bag-day')
    imports = _in_child('imports')
    day = _in_child(DAY)
    samples = int(DAY_BAG[0] * DAY_BAG[1]) + 1
    report.add(
        f'`torquefree_bag default --duration {DAY_BAG[0]:.0f} --rate {DAY_BAG[1]:.0f}` '
        '(write_scene_bag in a fresh process), one run'
    )
    report.add('')
    report.add('| process | peak memory (VmHWM, MiB) | samples | bag size (GB) | s | samples/s |')
    report.add('|---|---|---|---|---|---|')
    report.add(f'| imports only | {imports["max_rss_mib"]:.0f} | | | | |')
    report.add(
        f'| {DAY} bag | {day["max_rss_mib"]:.0f} | {samples:,} | {day["bytes"] / 1e9:.1f} | '
        f'{day["seconds"]:.0f} | {samples / day["seconds"]:,.0f} |'
    )
    report.save(output)
    return 0


if __name__ == '__main__':
    sys.exit(main())
