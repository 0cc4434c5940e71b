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
Benchmark of the exact propagator's cost.

A script, not a test: it prints what it measured and the machine.

On every hard case of ``torquefree_ros/bench/hard_cases.json``, side by side in the same process:

- per sample in a block of 10 000, against one ``scipy.special.ellipj`` call per element (the same
  count), at the case's parameter and at ``m = 1/2``: the ratio says what the exact solution costs
  beyond the cheapest elliptic function evaluation there is (scipy takes shortcuts next to ``m =
  0`` and ``m = 1``, where its call costs a tenth: the second ratio is the one to compare across
  cases);
- per sample in a block of 256 (the node's block) over that of a block of 10 000, and a call of one
  sample: the fixed cost of one call;
- building the propagator (``make_propagator``: checks, frame, constants).

Then ``propagate_batch`` for 1 000 dispersed bodies x 100 samples, per body-sample, against one
body's stream of 100 000 samples and against the loop of ``propagate`` calls a user would write.

Everything twice when numba is installed: the exact attitude compiled (the ``fast`` extra, what
propagators use then) and with numpy (``switch.ENABLED`` switched in the same process);
and the kernels' first call in a new process, compiling them and loading them from numba's cache.

Each timing is the fastest of several calls (the least disturbed by a shared machine); a round
measures everything once, and ``--rounds`` rounds give median (min–max).

The exact free gyrostat's accuracy/cost curve (issue 43): on the library ``gyrostat`` scene and
on coasting reaction wheels (``wheels_coasting_rotor_axis``), the ``gyrostat`` propagator beside
``dop853`` at rtol 1e-8 … 1e-14 (``atol = rtol / 100``, auto's pair), each run over the
reference's horizon at 100 Hz, construction included: the error against the mpmath reference
(``torquefree_ros/bench/gyrostat_cases.json``) at its samples, the reference's float64 floor
beside it, and the CPU time per sample (``time.process_time``: a loaded machine's waiting is not
counted), with each method's ratio to the gyrostat's and the gyrostat's to the free body's exact
sample (``analytic``, same inertia and rates) in the same round. ``--output`` also writes
``gyrostat_work_precision.csv`` and ``.png`` beside the report.

The oblique gyrostat (``h`` off every principal axis, :mod:`.gyrostat_oblique`) on cases of its
mpmath reference (``test/data/gyrostat_oblique_cases.json``): the evaluation of one built
:class:`.ObliqueAttitude` per sample over the case's horizon at 100 Hz beside the free body's
(``analytic``, same inertia and rates, built once) in the same round, on each path, with the
errors against the reference at its samples.
"""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path
import statistics
import sys
import tempfile
import time

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_report import fastest, Report, spread  # noqa: E402
from torquefree_ros.core.numerics import kernels as switch  # noqa: E402

BLOCK, SMALL_BLOCK = 10_000, 256
BODIES, BODY_SAMPLES = 1_000, 100


def _use(path: str) -> None:
    switch.ENABLED = path == 'compiled'


def _first_call_s(cache_dir: str) -> float:
    """
    Time a new process's first propagation beyond its second, in seconds.

    The first propagation (m > 1/2, then m <= 1/2) of a new process beyond the same process's
    second: the kernels compiled, or loaded from ``cache_dir``.
    """
    import subprocess

    code = (
        'import time; from torquefree_ros import propagate\n'
        'def both(): propagate([2, 3, 4], [0.7, 0.5, 0.6], [0, 0, 0, 1], [1.0]); '
        'propagate([1, 2, 3], [0.3, 0.2, 1], [0, 0, 0, 1], [1.0])\n'
        'a = time.perf_counter(); both(); b = time.perf_counter(); both(); '
        'c = time.perf_counter()\n'
        'print((b - a) - (c - b))'
    )
    env = {**os.environ, 'NUMBA_CACHE_DIR': cache_dir, 'TORQUEFREE_ROS_KERNELS': 'numba'}
    return float(
        subprocess.run(
            [sys.executable, '-c', code],
            env=env,
            check=True,
            capture_output=True,
            text=True,
            cwd=Path(__file__).resolve().parents[1],
        ).stdout
    )


def _case_round(case, calls: int) -> dict:
    import numpy as np
    from scipy.special import ellipj
    from torquefree_ros.core.propagators import make_propagator

    propagator = make_propagator(case.inertia, case.angular_velocity, case.orientation)
    polhode = propagator.polhode
    times = np.linspace(0.0, case.horizon, BLOCK)
    small = times[:SMALL_BLOCK] + 0.5 * case.horizon  # away from t = 0, as later blocks are
    m = 1.0 - polhode.jacobi.mc if polhode is not None else 0.5
    u = times * (polhode.rate if polhode is not None else 1.0)
    per_sample = fastest(lambda: propagator(times), calls) / BLOCK
    small_per_sample = fastest(lambda: propagator(small), 10 * calls) / SMALL_BLOCK
    build = fastest(
        lambda: make_propagator(case.inertia, case.angular_velocity, case.orientation),
        20 * calls,
    )
    return {
        'sample_ns': per_sample * 1e9,
        'ellipj_ratio': per_sample / (fastest(lambda: ellipj(u, m), calls) / BLOCK),
        'generic_ellipj_ratio': per_sample / (fastest(lambda: ellipj(u, 0.5), calls) / BLOCK),
        'small_block_ratio': small_per_sample / per_sample,
        'one_sample_us': fastest(lambda: propagator(small[:1]), 20 * calls) * 1e6,
        'build_us': build * 1e6,
    }


def _batch_round(calls: int) -> dict:
    import numpy as np
    from torquefree_ros import propagate, propagate_batch

    rng = np.random.default_rng(0)
    inertia = [2.0, 3.0, 4.0] * (1.0 + 0.01 * rng.standard_normal((BODIES, 3)))
    omega0 = [0.7, 0.5, 0.6] + 0.01 * rng.standard_normal((BODIES, 3))
    orientation = np.tile([0.0, 0.0, 0.0, 1.0], (BODIES, 1))
    times = np.linspace(0.0, 30.0, BODY_SAMPLES)
    stream = np.linspace(0.0, 30.0 * BODIES, BODIES * BODY_SAMPLES)
    batch = fastest(lambda: propagate_batch(inertia, omega0, orientation, times), calls)
    one = fastest(lambda: propagate(inertia[0], omega0[0], orientation[0], stream), calls)
    loop = fastest(
        lambda: [propagate(inertia[i], omega0[i], orientation[i], times) for i in range(BODIES)],
        calls,
    )
    samples = BODIES * BODY_SAMPLES
    return {
        'batch_ns': batch / samples * 1e9,
        'stream_ns': one / samples * 1e9,
        'loop_ns': loop / samples * 1e9,
        'batch_ratio': batch / one,
        'loop_ratio': loop / one,
    }


GYROSTAT_RTOLS = (1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14)
GYROSTAT_RATE = 100.0  # Hz: the samples each run computes
#: (label, reference case): the scene is the case's (a rotor, or coasting wheels)
GYROSTAT_SCENES = (
    ('library gyrostat scene (rotor 5 N m s on the intermediate axis, 100 s)', 'library_gyrostat'),
    ('coasting reaction wheel (wheels_coasting_rotor_axis, 40 s)', 'wheels_coasting_rotor_axis'),
)


def _gyrostat_scene(case):
    from torquefree_ros.core.scene.loader import scene_from_mapping

    effect = (
        {'reaction_wheels': {'wheels': case['wheels']}}
        if 'wheels' in case
        else {'rotor': case['rotor']}
    )
    return scene_from_mapping(
        {
            'body': {'inertia': case['inertia']},
            'initial': {
                'angular_velocity': case['angular_velocity'],
                'orientation': case['orientation'],
            },
            'effects': [effect],
        }
    )


def _gyrostat_round(case, calls: int) -> dict:
    """
    Return ``{method: (ns per sample, build µs, evaluation ns per sample, errors...)}``.

    The first figure is a whole run (build and samples) per sample; an exact propagator's
    evaluation alone is timed on one built propagator (an integrator's work is its steps: NaN).
    The errors: rate (relative), attitude and wheel angle (rad), NaN where not measured.
    """
    import numpy as np
    from torquefree_ros.core.propagators import ATOL_PER_RTOL, make_propagator
    from torquefree_ros.core.run.accuracy import trajectory_errors

    scene = _gyrostat_scene(case)
    grid = np.arange(int(round(case['times'][-1] * GYROSTAT_RATE)) + 1) / GYROSTAT_RATE
    picked = np.rint(np.asarray(case['times']) * GYROSTAT_RATE).astype(int)
    assert np.array_equal(grid[picked], case['times'])  # the reference's times, exactly

    def measure(build, exact=False, errors=True):
        def run():
            return build().states(grid)

        seconds = fastest(run, calls, clock=time.process_time)
        build_s = fastest(build, calls, clock=time.process_time)
        evaluation = math.nan
        if exact:
            built = build()
            evaluation = fastest(lambda: built.states(grid), calls, clock=time.process_time)
            evaluation = evaluation / grid.size * 1e9
        costs = (seconds / grid.size * 1e9, build_s * 1e6, evaluation)
        if not errors:
            return (*costs, math.nan, math.nan, math.nan)
        omega, q, x = run()
        rate, attitude = trajectory_errors(omega[picked], q[picked], case['omega'], case['q'])
        angle = (
            float(np.abs(x[picked][:, 1::2] - np.asarray(case['wheel_angles'])).max())
            if 'wheel_angles' in case
            else math.nan
        )
        return (*costs, float(rate.max()), float(attitude.max()), angle)

    rows = {'gyrostat': measure(scene.propagator, exact=True)}
    rows['analytic (free body, cost only)'] = measure(
        lambda: make_propagator(
            case['inertia'], case['angular_velocity'], case['orientation'], 'analytic'
        ),
        exact=True,
        errors=False,
    )
    for rtol in GYROSTAT_RTOLS:
        rows[f'dop853 rtol {rtol:g}'] = measure(
            lambda rtol=rtol: scene.propagator('dop853', rtol=rtol, atol=rtol * ATOL_PER_RTOL)
        )
    return rows


#: the oblique gyrostat's cases timed (test/data/gyrostat_oblique_cases.json)
OBLIQUE_CASES = (
    'oblique_generic',
    'oblique_dominant_h',
    'oblique_separatrix_one_saddle_below_1e-10',
    'oblique_long_horizon',
)
OBLIQUE_FILE = (
    Path(__file__).resolve().parents[1] / 'test' / 'data' / 'gyrostat_oblique_cases.json'
)


def _oblique_round(case, calls: int) -> dict:
    """
    Return the oblique gyrostat's evaluation and the free body's, ns per sample, and the errors.

    On the path switched on now (the dispatch is chosen when an attitude is built). CPU time of
    the fastest of ``calls`` evaluations of the whole grid, each on an object built once.
    """
    import numpy as np
    from torquefree_ros.core.exact.gyrostat_oblique import ObliqueAttitude, solve_oblique
    from torquefree_ros.core.propagators import make_propagator
    from torquefree_ros.core.run.accuracy import trajectory_errors

    grid = np.arange(int(round(case['times'][-1] * GYROSTAT_RATE)) + 1) / GYROSTAT_RATE
    h = case['rotor_vector']
    motion = solve_oblique(case['inertia'], case['angular_velocity'], h)
    attitude = ObliqueAttitude(motion, h, np.eye(3), case['orientation'])
    free = make_propagator(
        case['inertia'], case['angular_velocity'], case['orientation'], 'analytic'
    )
    oblique_ns = fastest(lambda: attitude(grid), calls, clock=time.process_time)
    free_ns = fastest(lambda: free.states(grid), calls, clock=time.process_time)
    omega, q = attitude(np.asarray(case['times']))
    rate, angle = trajectory_errors(omega, q, case['omega'], case['q'])
    return {
        'oblique_ns': oblique_ns / grid.size * 1e9,
        'free_ns': free_ns / grid.size * 1e9,
        'ratio': oblique_ns / free_ns,
        'rate_error': float(rate.max()),
        'attitude_error': float(angle.max()),
        'samples': grid.size,
    }


def _oblique_section(report, rounds: dict) -> None:
    report.add('')
    report.add('## The oblique gyrostat (h off every principal axis): its evaluation per sample')
    report.add('')
    report.add(
        "One built `ObliqueAttitude` evaluated over the case's horizon at 100 Hz, beside the "
        "free body's exact evaluation (`analytic`, same inertia and rates, built once) in the "
        'same round and on the same path (CPU ns per sample, `time.process_time`, the fastest of '
        "several calls); the errors against the case's mpmath reference "
        '(test/data/gyrostat_oblique_cases.json) at its samples, rates relative and attitude in '
        "rad. The issue's target: the oblique sample at most 2x the free body's."
    )
    report.add('')
    report.add(
        '| path | case | samples | oblique (ns per sample) | free body (ns per sample) | '
        'oblique / free body | rate error (rel) | attitude error (rad) |'
    )
    report.add('|---|---|---|---|---|---|---|---|')
    for (path, name), per_round in rounds.items():
        first = per_round[0]
        report.add(
            f'| {path} | {name} | {first["samples"]:,} | '
            f'{spread([r["oblique_ns"] for r in per_round])} | '
            f'{spread([r["free_ns"] for r in per_round])} | '
            f'{spread([r["ratio"] for r in per_round])} | {first["rate_error"]:.2g} | '
            f'{first["attitude_error"]:.2g} |'
        )


def _gyrostat_section(report, rounds: dict, cases: dict) -> None:
    report.add('')
    report.add('## The exact free gyrostat beside DOP853 (issue 43: accuracy/cost)')
    report.add('')
    report.add(
        'Each run computes the reference horizon at 100 Hz, the propagator built inside the timed '
        "call; the error is the largest over the reference's samples against the mpmath "
        "reference (rates relative, attitude and wheel angles in rad), the floor the reference's "
        'own (float64 inputs moved by one rounding unit). Cost: CPU ns per sample of the whole '
        "run (`time.process_time`, the fastest of several calls) and its ratio to the gyrostat's "
        'in the same round; for the exact propagators also the build alone (µs) and the '
        'evaluation alone (ns per sample, on one built propagator). The machine was loaded by '
        'other work during the run: read the ratios, not the absolute times.'
    )
    for label, name in GYROSTAT_SCENES:
        case, per_round = cases[name], rounds[name]
        report.add('')
        report.add(
            f'**{label}**: floor {max(case["rate_floor"]):.2g} (rates), '
            f'{max(case["attitude_floor"]):.2g} rad (attitude)'
            + (
                f', {max(case["angle_floor"]):.2g} rad (angles, up to '
                f'{max(abs(v) for row in case["wheel_angles"] for v in row):.3g} rad)'
                if 'wheel_angles' in case
                else ''
            )
            + ':'
        )
        report.add('')
        report.add(
            '| method | rate error (rel) | attitude error (rad) | angle error (rad) | '
            'ns per sample, whole run (CPU) | / gyrostat | build (µs) | evaluation (ns per '
            'sample) |'
        )
        report.add('|---|---|---|---|---|---|---|---|')
        for method in per_round[0]:
            values = [r[method] for r in per_round]
            ratios = [r[method][0] / r['gyrostat'][0] for r in per_round]
            errors = [
                '' if math.isnan(values[0][k]) else f'{values[0][k]:.2g}' for k in (3, 4, 5)
            ]
            evaluation = (
                '' if math.isnan(values[0][2]) else spread([v[2] for v in values])
            )
            report.add(
                f'| {method} | {" | ".join(errors)} | {spread([v[0] for v in values])} | '
                f'{spread(ratios)} | {spread([v[1] for v in values])} | {evaluation} |'
            )
        evaluations = [
            r['gyrostat'][2] / r['analytic (free body, cost only)'][2] for r in per_round
        ]
        report.add('')
        report.add(
            "The gyrostat's evaluation per sample over the free body's (`analytic`, same inertia "
            f'and rates), same round: {spread(evaluations)}.'
        )


def _gyrostat_files(output: str, rounds: dict, cases: dict) -> None:
    """Write ``gyrostat_work_precision.csv`` and ``.png`` beside the report."""
    import statistics as stats

    base = Path(output).with_name('gyrostat_work_precision')
    lines = ['case,method,rate_error_rel,attitude_error_rad,angle_error_rad,cpu_ns_per_sample,'
             'ratio_to_gyrostat,attitude_floor_rad']
    for _, name in GYROSTAT_SCENES:
        per_round, case = rounds[name], cases[name]
        for method in per_round[0]:
            first = per_round[0][method]
            cost = stats.median(r[method][0] for r in per_round)
            ratio = stats.median(r[method][0] / r['gyrostat'][0] for r in per_round)
            lines.append(
                f'{name},{method},{first[3]:.6g},{first[4]:.6g},{first[5]:.6g},{cost:.6g},'
                f'{ratio:.6g},{max(case["attitude_floor"]):.6g}'
            )
    base.with_suffix('.csv').write_text('\n'.join(lines) + '\n')
    try:
        import matplotlib

        matplotlib.use('Agg')
        import matplotlib.pyplot as plt
    except ImportError:
        return
    figure, axes = plt.subplots(1, len(GYROSTAT_SCENES), figsize=(11, 4.2), squeeze=False)
    for axis, (label, name) in zip(axes[0], GYROSTAT_SCENES):
        per_round, case = rounds[name], cases[name]

        def point(method):
            cost = stats.median(r[method][0] for r in per_round)
            return cost, max(per_round[0][method][4], 1e-17)

        dop = [point(f'dop853 rtol {rtol:g}') for rtol in GYROSTAT_RTOLS]
        axis.loglog(*zip(*dop), 'o-', label='dop853 (rtol 1e-8 … 1e-14)')
        for (cost, error), rtol in zip(dop, GYROSTAT_RTOLS):
            axis.annotate(f'{rtol:g}', (cost, error), fontsize=7, xytext=(4, 2),
                          textcoords='offset points')
        axis.loglog(*point('gyrostat'), '*', markersize=14, label='gyrostat (exact)')
        evaluation = stats.median(r['gyrostat'][2] for r in per_round)
        axis.loglog(evaluation, point('gyrostat')[1], '*', markersize=14, fillstyle='none',
                    color='C1', label='gyrostat, evaluation alone (a long run)')
        axis.axhline(max(case['attitude_floor']), color='grey', linestyle='--', linewidth=1,
                     label='float64 floor')
        axis.set_title(label, fontsize=9)
        axis.set_xlabel('CPU ns per sample (100 Hz over the horizon, build included)')
        axis.set_ylabel('attitude error vs mpmath (rad)')
        axis.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(base.with_suffix('.png'), dpi=110)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().split('\n\n')[0])
    parser.add_argument(
        '--rounds', type=int, default=3, help='rounds of every measurement (default 3)'
    )
    parser.add_argument(
        '--calls', type=int, default=5, help='calls per timing, the fastest kept (default 5)'
    )
    parser.add_argument('--output', help='also write the report to this Markdown file')
    args = parser.parse_args()

    import json

    from torquefree_ros.bench.cases import load_cases, REFERENCE_FILE

    GYROSTAT_FILE = REFERENCE_FILE.with_name('gyrostat_cases.json')

    names = [case['name'] for case in json.loads(REFERENCE_FILE.read_text())['cases']]
    cases = load_cases(names)
    paths = ('compiled', 'numpy') if switch.ENABLED else ('numpy',)
    started = time.monotonic()
    rounds = {(path, case.name): [] for path in paths for case in cases}
    batch = {path: [] for path in paths}
    for path in paths:  # warm up (imports, first calls, the kernels' compilation), not measured
        _use(path)
        _case_round(cases[0], 1)
        _batch_round(1)
    for _ in range(args.rounds):
        for path in paths:  # side by side: both paths in every round
            _use(path)
            for case in cases:
                rounds[path, case.name].append(_case_round(case, args.calls))
            batch[path].append(_batch_round(max(2, args.calls // 2)))
    gyrostat_cases = {
        case['name']: case
        for case in json.loads(GYROSTAT_FILE.read_text())['cases']
        if case['name'] in {name for _, name in GYROSTAT_SCENES}
    }
    _use(paths[0])  # the default path: compiled when numba is installed
    gyrostat_rounds = {name: [] for _, name in GYROSTAT_SCENES}
    for name in gyrostat_rounds:
        _gyrostat_round(gyrostat_cases[name], 1)  # warm up
    for _ in range(args.rounds):
        for name in gyrostat_rounds:
            gyrostat_rounds[name].append(_gyrostat_round(gyrostat_cases[name], args.calls))
    oblique_cases = {
        case['name']: case
        for case in json.loads(OBLIQUE_FILE.read_text())['cases']
        if case['name'] in OBLIQUE_CASES
    }
    oblique_rounds = {(path, name): [] for path in paths for name in OBLIQUE_CASES}
    for path in paths:  # warm up
        _use(path)
        _oblique_round(oblique_cases[OBLIQUE_CASES[0]], 1)
    for _ in range(args.rounds):
        for path in paths:
            _use(path)
            for name in OBLIQUE_CASES:
                oblique_rounds[path, name].append(_oblique_round(oblique_cases[name], args.calls))
    _use(paths[0])
    first_calls = []
    if 'compiled' in paths:
        for _ in range(args.rounds):  # an empty cache: compiled, then loaded from it
            with tempfile.TemporaryDirectory() as cache:
                first_calls.append((_first_call_s(cache), _first_call_s(cache)))

    report = Report("The exact propagator's cost", 'make bench-exact')
    report.add(
        f'{args.rounds} rounds in {time.monotonic() - started:.0f} s; each figure is median '
        '(min–max) over the rounds of the fastest of several calls.'
    )
    if 'compiled' in paths:
        import numba

        report.add(
            f'The exact attitude compiled (numba {numba.__version__}, the `fast` extra: what '
            'propagators use when it is installed) and with numpy, side by side in every round.'
        )
    else:
        report.add('numba is not installed: the numpy path only.')
    for path in paths:
        _case_table(
            report, path, {name: values for (p, name), values in rounds.items() if p == path}
        )
    report.add('')
    report.add(
        f'`propagate_batch`, {BODIES:,} dispersed bodies (inertia 2, 3, 4 kg m², '
        f'ω0 0.7, 0.5, 0.6 rad/s, 1 % spread) x {BODY_SAMPLES} samples, '
        f"beside one body's stream of {BODIES * BODY_SAMPLES:,} samples and the loop of "
        '`propagate` calls:'
    )
    report.add('')
    report.add('| path | | ns per body-sample | / one stream |')
    report.add('|---|---|---|---|')
    for path in paths:
        cell = {key: spread([r[key] for r in batch[path]]) for key in batch[path][0]}
        report.add(f'| {path} | propagate_batch | {cell["batch_ns"]} | {cell["batch_ratio"]} |')
        report.add(f'| {path} | loop of propagate | {cell["loop_ns"]} | {cell["loop_ratio"]} |')
        report.add(f'| {path} | one stream | {cell["stream_ns"]} | 1 |')
    if first_calls:
        compiled = [first for first, _ in first_calls]
        cached = [again for _, again in first_calls]
        report.add('')
        report.add(
            "The kernels' first call in a new process (both kinds; beyond the second call's "
            f"time): compiling them {spread(compiled)} s; loading them from numba's cache "
            f'{spread(cached)} s.'
        )
    _gyrostat_section(report, gyrostat_rounds, gyrostat_cases)
    report.add('')
    report.add(
        f"(The gyrostat section ran on the {paths[0]} path, its rounds after the free body's.)"
    )
    _oblique_section(report, oblique_rounds)
    report.save(args.output)
    if args.output:
        _gyrostat_files(args.output, gyrostat_rounds, gyrostat_cases)
    return 0


def _case_table(report, path: str, rounds: dict) -> None:
    report.add('')
    report.add(
        f'**{path}**: per sample in a block of {BLOCK:,} and beside one `scipy.special.ellipj` '
        "call per element (same count; at the case's parameter, where scipy takes shortcuts next "
        f'to m = 0 and m = 1, and at m = 1/2); a block of {SMALL_BLOCK} per sample over a block '
        f"of {BLOCK:,}; a call of one sample (a call's fixed cost); building the propagator:"
    )
    report.add('')
    report.add(
        f"| case | ns per sample | / ellipj (case's m) | / ellipj (m = 1/2) | "
        f'block {SMALL_BLOCK} / block {BLOCK:,} | one sample (µs) | build (µs) |'
    )
    report.add('|---|---|---|---|---|---|---|')
    keys = (
        'sample_ns',
        'ellipj_ratio',
        'generic_ellipj_ratio',
        'small_block_ratio',
        'one_sample_us',
        'build_us',
    )
    for name, values in rounds.items():
        report.add(
            f'| {name} | ' + ' | '.join(spread([v[key] for v in values]) for key in keys) + ' |'
        )
    report.add('')
    every = [v for values in rounds.values() for v in values]
    for key, label in (
        ('generic_ellipj_ratio', 'per sample / ellipj at m = 1/2'),
        ('small_block_ratio', f'block {SMALL_BLOCK} / block {BLOCK:,}'),
        ('one_sample_us', 'a call of one sample (µs)'),
        ('build_us', 'build (µs)'),
    ):
        medians = [statistics.median(v[key] for v in values) for values in rounds.values()]
        report.add(
            f'- {label}: {min(medians):.3g} … {max(medians):.3g} over the cases (medians); '
            f'all rounds {min(v[key] for v in every):.3g} … {max(v[key] for v in every):.3g}'
        )


if __name__ == '__main__':
    sys.exit(main())
