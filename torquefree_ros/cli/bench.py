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
``torquefree_bench``: the work-precision report.

Writes ``work_precision.csv`` (every measurement, with the machine and versions),
``work_precision.png`` (with the ``plot`` extra) and ``results.md`` (per-case tables, the targets
as ratios from this run, the effects' and the ROS layer's cost per sample) to ``--output-dir``.
``--smoke`` is the test suite's quick run: two cases, two settings per method.
"""

from __future__ import annotations

import argparse
import datetime
import os
from pathlib import Path
import shlex
import sys
import time

from .common import console_command
from ..bench.cases import BENCH_CASES, load_cases, SMOKE_CASES
from ..bench.methods import all_methods
from ..bench.report import case_table, describe_setting, environment, plot, targets, write_csv
from ..bench.sweep import sweep

DEFAULT_OUTPUT = Path('docs') / 'bench'


@console_command('torquefree_bench')
def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog='torquefree_bench',
        description='The work-precision report: every propagator, scipy solve_ivp and MuJoCo RK4 '
        "on the hard cases and the free gyrostat's; writes work_precision.csv, work_precision.png "
        'and results.md (tens of minutes: results.md records how long; --smoke: a few minutes).',
    )
    parser.add_argument(
        '--output-dir',
        type=Path,
        default=DEFAULT_OUTPUT,
        metavar='DIR',
        help='where work_precision.csv/.png and results.md go (default: docs/bench)',
    )
    parser.add_argument('--smoke', action='store_true', help='two cases, two settings per method')
    parser.add_argument(
        '--case',
        action='append',
        metavar='NAME',
        help='a case to run (repeatable; default: the published set)',
    )
    parser.add_argument(
        '--method',
        action='append',
        metavar='LABEL',
        help='a method label to run (repeatable; default: all)',
    )
    parser.add_argument(
        '--no-mujoco', action='store_true', help='leave MuJoCo out even when importable'
    )
    parser.add_argument(
        '--no-costs', action='store_true', help='skip the effects and ROS-layer cost sections'
    )
    args = parser.parse_args(argv)

    try:
        cases = load_cases(args.case or (SMOKE_CASES if args.smoke else BENCH_CASES))
    except ValueError as error:
        parser.error(str(error))
    methods = all_methods(include_mujoco=not args.no_mujoco)
    if args.method:
        known = {m.label for m in methods}
        unknown = [name for name in args.method if name not in known]
        if unknown:
            parser.error(
                f'--method: unknown method {unknown[0]!r} (known: {", ".join(sorted(known))})'
            )
        methods = [m for m in methods if m.label in args.method]
    try:
        args.output_dir.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        parser.error(f'--output-dir: cannot create {args.output_dir}: {error.strerror or error}')
    if not os.access(args.output_dir, os.W_OK):
        parser.error(f'--output-dir: {args.output_dir} is not writable')

    started = time.monotonic()
    env = environment()
    measurements = sweep(methods, cases, smoke=args.smoke, progress=_progress)
    csv_path = args.output_dir / 'work_precision.csv'
    write_csv(csv_path, measurements, env)
    png_path = args.output_dir / 'work_precision.png'
    plotted = plot(png_path, measurements)
    sections = [_markdown(measurements, cases, env, plotted)]
    if not args.no_costs:
        sections.append(_costs_markdown(smoke=args.smoke))
    command = 'torquefree_bench ' + ' '.join(
        shlex.quote(a) for a in (sys.argv[1:] if argv is None else argv)
    )
    today = datetime.datetime.now(datetime.timezone.utc)
    made = (
        f'Made by `{command.strip()}` (`make bench`) on {today:%Y-%m-%d} '
        f'in {(time.monotonic() - started) / 60:.0f} minutes.\n\n'
    )
    header, _, rest = sections[0].partition('\n\n')
    sections[0] = f'{header}\n\n{made}{rest}'
    (args.output_dir / 'results.md').write_text('\n'.join(sections))
    print('\n'.join(targets(measurements)))
    print(
        f'\nwrote {csv_path}, {args.output_dir / "results.md"}'
        + (f', {png_path}' if plotted else " (no plot: pip install 'torquefree_ros[plot]')")
        + f' in {time.monotonic() - started:.0f} s'
    )
    return 0


def _progress(m) -> None:
    outcome = (
        f'{m.attitude_error_rad:.1e} rad, {m.cpu_us_per_sim_s:,.0f} µs/s' if m.ok else m.status
    )
    print(
        f'  {m.case:28s} {m.method:14s} {describe_setting(m):22s} {outcome}',
        file=sys.stderr,
        flush=True,
    )


def _markdown(measurements, cases, env, plotted: bool) -> str:
    lines = [
        '# Work-precision report (`torquefree_bench`)',
        '',
        'Machine and versions: ' + '; '.join(f'{k} {v}' for k, v in env.items()) + '.',
        '',
        "Error: the largest attitude error (rad) over each case's reference samples (mpmath, 45 "
        'digits for the free body, 40 for the gyrostat), from a run to those samples alone (its '
        'CPU time is the cost to the horizon in '
        'the CSV). Cost: CPU time (construction included) to produce a 100 Hz output, per '
        'simulated second. Adaptive methods use `atol = rtol / 100`; fixed steps are given in '
        "seconds (swept as 8 … 2048 steps per rotation, 2π/|ω0|). scipy's `solve_ivp` gets the "
        'same right-hand side as our numerical propagators, so the comparison is of the '
        'integrators.',
        '',
    ]
    if plotted:
        lines += ['![work-precision](work_precision.png)', '']
    lines += [
        '## Targets (ratios measured in this run)',
        '',
        *targets(measurements),
        '',
        '## Per case',
        '',
    ]
    for case in cases:
        omega = [float(f'{w:.6g}') for w in case.angular_velocity]
        lines += [
            f'### {case.name}',
            '',
            f'Inertia {case.inertia.tolist()}, ω0 {omega} rad/s, '
            f'horizon {case.horizon:g} s, float64 floor {case.attitude_floor.max():.1e} rad.',
            '',
            case_table(measurements, case.name),
            '',
        ]
    failed = [m for m in measurements if not m.ok]
    if failed:
        lines += ['### Runs that failed or were skipped', '']
        lines += [f'- {m.case}, {m.method} {describe_setting(m)}: {m.status}' for m in failed]
        lines.append('')
    return '\n'.join(lines)


def _costs_markdown(smoke: bool) -> str:
    from ..bench.effects_cost import motion_effect_costs, output_costs
    from ..bench.pipeline import sample_costs

    lines = [
        '## What each effect adds',
        '',
        'A scene computes only the effects it names. Per effect (body of the `imu` scene, RK4 '
        'step 10 ms):',
        '',
        '| effect | right-hand side (µs) | added (µs) | RK4 step (µs) | added per step (µs) |',
        '|---|---|---|---|---|',
    ]
    for row in motion_effect_costs(number=200 if smoke else 2000):
        lines.append(
            f'| {row["effect"]} | {row["rhs_us"]:.2f} | {row["added_rhs_us"]:+.2f} '
            f'| {row["rk4_step_us"]:.2f} | {row["added_step_us"]:+.2f} |'
        )
    lines += ['', '| output | µs per sample (blocks of 256) |', '|---|---|']
    lines += [
        f'| {row["output"]} | {row["us_per_sample"]:.3f} |'
        for row in output_costs(number=5 if smoke else 20)
    ]
    lines += [
        '',
        '## The whole cost of a sample (default scene, 100 Hz)',
        '',
        '| stage | µs per sample |',
        '|---|---|',
    ]
    lines += [
        f'| {stage} | {cost:.2f} |'
        for stage, cost in sample_costs(2000 if smoke else 20000).items()
    ]
    lines += [
        '',
        "The node's real-time figures and the bag writer's throughput are measured by "
        '`make bench-node` and `make bench-bag` ([node.md](node.md), [bag.md](bag.md)).',
        '',
    ]
    return '\n'.join(lines)


if __name__ == '__main__':
    sys.exit(main())
