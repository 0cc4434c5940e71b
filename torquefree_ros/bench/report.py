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
The report's outputs from the measurements: the CSV, the tables, the targets and the plot.

The CSV, the per-case tables ("to reach 1e-6 / 1e-9 / 1e-12 rad, method X costs Y µs per simulated
second"), the targets as ratios measured in the same run, and the work-precision plot.
"""

from __future__ import annotations

import csv
from importlib import metadata
import math
import os
import platform
import sys

import numpy as np

from .cases import GYROSTAT_PREFIX, load_cases

TARGETS = (1e-6, 1e-9, 1e-12)
#: the exact propagators: the free body's and the free gyrostat's, each on its own cases
EXACT_METHODS = ('analytic', 'gyrostat')
#: the accuracy grid on which "where RK4 stops being worth it" is read
_CROSSOVER_TARGETS = tuple(10.0**-k for k in range(2, 14))


def environment() -> dict:
    """Return the machine and the versions the numbers belong to."""
    versions = {}
    for package in ('numpy', 'scipy', 'mujoco', 'matplotlib', 'torquefree_ros'):
        try:
            versions[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            continue
    cpu = platform.processor() or platform.machine()
    try:
        with open('/proc/cpuinfo') as info:
            cpu = next(
                line.split(':', 1)[1].strip() for line in info if line.startswith('model name')
            )
    except (OSError, StopIteration):
        pass
    return {
        'machine': f'{cpu}, {os.cpu_count()} cores, {platform.platform()}',
        'python': sys.version.split()[0],
        **versions,
    }


def write_csv(path, measurements, env: dict) -> None:
    """
    Write the measurements as CSV, one row per measurement.

    The rows come after ``# key: value`` lines naming the machine and versions.
    """
    from .sweep import Measurement

    with open(path, 'w', newline='') as stream:
        for key, value in env.items():
            stream.write(f'# {key}: {value}\n')
        writer = csv.DictWriter(stream, fieldnames=Measurement.columns())
        writer.writeheader()
        for measurement in measurements:
            writer.writerow({k: _csv_value(v) for k, v in measurement.row().items()})


def read_csv(path) -> list[dict]:
    with open(path, newline='') as stream:
        return list(csv.DictReader(line for line in stream if not line.startswith('#')))


def _csv_value(value):
    if isinstance(value, float):
        return '' if math.isnan(value) else f'{value:.6g}'
    return '' if value is None else value


# -- reading the measurements ---------------------------------------------------------------------
def cheapest(measurements, case: str, methods, target: float, cost: str = 'cpu_us_per_sim_s'):
    """
    Find the cheapest measurement (by ``cost``) of ``methods`` on ``case`` that reaches ``target``.

    The measurement of any of ``methods`` whose attitude error is within ``target`` rad (``None``:
    not reached).
    """
    names = {methods} if isinstance(methods, str) else set(methods)
    reaching = [
        m
        for m in measurements
        if m.ok and m.case == case and m.method in names and m.attitude_error_rad <= target
    ]
    return min(reaching, key=lambda m: getattr(m, cost), default=None)


def _method_order(measurements) -> list[str]:
    return list(dict.fromkeys(m.method for m in measurements))


def _case_order(measurements) -> list[str]:
    return list(dict.fromkeys(m.case for m in measurements))


def describe_setting(m) -> str:
    """``rtol 1e-10``, ``step 0.0117``, ``dt 0.01``; empty for a method without a setting."""
    return '' if m.setting is None else f'{m.setting_name} {m.setting:.3g}'


def _cost(value: float) -> str:
    """Three significant digits; whole numbers with separators from 100 up."""
    return f'{value:,.0f}' if value >= 100 else f'{value:.3g}'


def case_table(measurements, case: str) -> str:
    """
    Markdown: per method, the cost (µs per simulated second at 100 Hz) to reach each target.

    A gyrostat case's table opens with a sentence naming its effects.
    """
    rows = [m for m in measurements if m.case == case]
    best = {}
    for m in rows:
        if m.ok and (
            m.method not in best or m.attitude_error_rad < best[m.method].attitude_error_rad
        ):
            best[m.method] = m
    head = (
        '| method | '
        + ' | '.join(f'to reach {t:.0e} rad' for t in TARGETS)
        + ' | best error reached (rad) |'
    )
    lines = [head, '|---' * (len(TARGETS) + 2) + '|']
    for method in _method_order(rows):
        cells = []
        for target in TARGETS:
            m = cheapest(rows, case, method, target)
            cells.append(
                f'{_cost(m.cpu_us_per_sim_s)} µs/s ({describe_setting(m)})'.replace(' ()', '')
                if m
                else 'not reached'
            )
        reached = f'{best[method].attitude_error_rad:.1e}' if method in best else 'failed'
        lines.append(f'| {method} | ' + ' | '.join(cells) + f' | {reached} |')
    if case.startswith(GYROSTAT_PREFIX):
        lines[:0] = [f'The free gyrostat: {load_cases([case])[0].describe_effects()}.', '']
    return '\n'.join(lines)


def targets(measurements) -> list[str]:
    """
    Report the issue's targets, each a ratio measured in this run, one line per case.

    A section is left out when its methods were not run.
    """
    exact = {m.case: m for m in measurements if m.method in EXACT_METHODS and m.ok}
    methods = _method_order(measurements)
    sections = [
        _exact_vs_dop853(
            measurements, exact, [name for name in ('dop853', 'scipy DOP853') if name in methods]
        ),
        _exact_vs_mujoco(measurements, exact),
        _ours_vs_scipy_dop853(measurements, methods),
        _where_rk4_stops(measurements, methods),
    ]
    lines = []
    for section in filter(None, sections):
        lines += ([''] if lines else []) + section
    return lines


def _best_error(measurements, case: str, method: str) -> float:
    return min(
        (
            m.attitude_error_rad
            for m in measurements
            if m.ok and m.case == case and m.method == method
        ),
        default=float('nan'),
    )


def _exact_vs_dop853(measurements, exact: dict, dop853s: list) -> list[str]:
    lines = [
        '**Exact vs DOP853 at 1e-9 rad** (cost of the cheapest DOP853 setting that reaches 1e-9 '
        "rad over the exact propagator's: for a 100 Hz stream / to the horizon's reference "
        'samples; then the horizon from which DOP853 costs 100× the exact propagator, its cost to '
        "the horizon extrapolated linearly in the horizon, the exact one's constant):"
    ]
    for case in _case_order(measurements):
        a = exact.get(case)
        if a is None:
            continue
        parts = []
        for name in dop853s:
            stream = cheapest(measurements, case, name, 1e-9)
            jump = cheapest(measurements, case, name, 1e-9, cost='cpu_ms_to_horizon')
            if stream:
                hundredfold = (
                    100.0 * a.cpu_ms_to_horizon / (jump.cpu_ms_to_horizon / jump.horizon_s)
                )
                parts.append(
                    f'{name} {stream.cpu_us_per_sim_s / a.cpu_us_per_sim_s:.1f}× / '
                    f'{jump.cpu_ms_to_horizon / a.cpu_ms_to_horizon:.0f}× '
                    f'(100× from {_cost(hundredfold)} s)'
                )
            else:
                best = _best_error(measurements, case, name)
                parts.append(f'{name} never reaches it (best {best:.1e} rad)')
        lines.append(f'- {case} (exact: {a.attitude_error_rad:.1e} rad): ' + '; '.join(parts))
    return lines


def _exact_vs_mujoco(measurements, exact: dict) -> list[str]:
    mujoco = [
        m
        for m in measurements
        if m.method == 'mujoco RK4' and m.ok and np.isclose(m.setting, 0.01)
    ]
    if not mujoco:
        return []
    lines = [
        '**Exact at 100 Hz vs MuJoCo RK4 at dt = 0.01 s** (time per simulated second, exact / '
        'MuJoCo; target ≤ 0.5):'
    ]
    for m in mujoco:
        a = exact.get(m.case)
        if a:
            lines.append(
                f'- {m.case}: {a.cpu_us_per_sim_s:.0f} / {m.cpu_us_per_sim_s:.0f} µs = '
                f'{a.cpu_us_per_sim_s / m.cpu_us_per_sim_s:.2f} '
                f'(MuJoCo {m.cpu_us_per_sim_s / 100:.1f} µs per step; '
                f'its attitude error {m.attitude_error_rad:.1e} rad)'
            )
    return lines


def _ours_vs_scipy_dop853(measurements, methods: list) -> list[str]:
    ours = [
        name
        for name in methods
        if name not in EXACT_METHODS
        and any(m.method == name and m.family == 'torquefree_ros' for m in measurements)
    ]
    if not ours or 'scipy DOP853' not in methods:
        return []
    lines = [
        f'**Best numerical propagator ({", ".join(ours)}) vs scipy DOP853 at equal accuracy** '
        '(cost ratio ours / scipy; target ≤ 1):'
    ]
    for case in _case_order(measurements):
        parts = []
        for target in TARGETS:
            mine, theirs = (
                cheapest(measurements, case, ours, target),
                cheapest(measurements, case, 'scipy DOP853', target),
            )
            if mine and theirs:
                ratio = mine.cpu_us_per_sim_s / theirs.cpu_us_per_sim_s
                parts.append(f'{target:.0e}: {ratio:.2f} ({mine.method})')
            elif mine:
                parts.append(f'{target:.0e}: only ours ({mine.method})')
            elif theirs:
                parts.append(f'{target:.0e}: only scipy')
        if parts:
            lines.append(f'- {case}: ' + ', '.join(parts))
    return lines


def _where_rk4_stops(measurements, methods: list) -> list[str]:
    fixed = [name for name in ('rk4', 'lie_rk4') if name in methods]
    if not fixed or 'dop853' not in methods:
        return []
    lines = [
        '**Where RK4 stops being worth it** (the tightest accuracy at which the cheaper of '
        f'{" and ".join(fixed)} still costs no more than dop853):'
    ]
    for case in _case_order(measurements):
        worth = None
        for target in _CROSSOVER_TARGETS:
            rk, dp = (
                cheapest(measurements, case, fixed, target),
                cheapest(measurements, case, 'dop853', target),
            )
            if rk and (dp is None or rk.cpu_us_per_sim_s <= dp.cpu_us_per_sim_s):
                worth = target
        lines.append(
            f'- {case}: '
            + (
                f'down to {worth:.0e} rad'
                if worth
                else 'never (dop853 is cheaper at every accuracy)'
            )
        )
    return lines


def plot(path, measurements) -> bool:
    """
    Plot log-log attitude error vs cost, one panel per case, one line per method.

    Return ``False`` when matplotlib (the ``plot`` extra) is missing.
    """
    try:
        import matplotlib

        matplotlib.use('Agg')
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    cases = _case_order(measurements)
    methods = _method_order(measurements)
    columns = min(4, len(cases))
    rows = math.ceil(len(cases) / columns)
    figure, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 3.6 * rows), squeeze=False)
    colours = plt.get_cmap('tab10')
    for ax, case in zip(axes.flat, cases):
        floor = next(m.attitude_floor_rad for m in measurements if m.case == case)
        for index, method in enumerate(methods):
            points = sorted(
                (
                    (m.cpu_us_per_sim_s, max(m.attitude_error_rad, 1e-17))
                    for m in measurements
                    if m.case == case and m.method == method and m.ok
                ),
                key=lambda p: p[0],
            )
            if points:
                x, y = zip(*points)
                style = '*' if len(points) == 1 else '.-'
                ax.loglog(
                    x,
                    y,
                    style,
                    color=colours(index % 10),
                    label=method,
                    markersize=10 if len(points) == 1 else 5,
                )
        ax.axhline(max(floor, 1e-16), color='0.6', linestyle=':', linewidth=1)
        ax.set_title(case, fontsize=9)
        ax.set_xlabel('CPU µs per simulated second (100 Hz output)', fontsize=8)
        ax.set_ylabel('max attitude error (rad)', fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, which='major', alpha=0.3)
    for ax in axes.flat[len(cases):]:
        ax.axis('off')
    legend = {}  # every method once, from whichever panel has it (the exact ones differ by case)
    for ax in axes.flat[: len(cases)]:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            legend.setdefault(label, handle)
    labels = [method for method in methods if method in legend]
    handles = [legend[label] for label in labels]
    columns_in_legend = min(len(labels), 2 * columns + 1)
    legend_rows = math.ceil(len(labels) / columns_in_legend)
    figure.legend(handles, labels, loc='lower center', ncol=columns_in_legend, fontsize=8)
    figure.suptitle(
        'Work-precision: attitude error against the mpmath reference vs CPU time '
        '(dotted: the float64 floor)',
        fontsize=10,
    )
    figure.tight_layout(rect=(0, 0.035 * legend_rows * 2 / rows, 1, 0.97))
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return True
