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
The report of a finished campaign (``torquefree_campaign report DIR``).

It reads ``DIR/runs.parquet`` and writes into ``DIR/report/`` (or ``--output``):

* ``summary.md`` — the campaign (file, scene, runs, seed, time grid, versions); the runs by status,
  with the reasons of the failed ones and how often each was given; each metric column's min,
  median, 95th percentile (numpy's default, linear interpolation) and max over the runs that
  finished with a finite value (a value that is NaN, such as ``settle_time`` of a run that never
  settles, is counted apart as undefined); the worst runs with their drawn inputs;
* ``histograms.png`` — a histogram of each metric column, its worst run marked and named;
* ``envelopes.png`` — when the campaign kept trajectories (``DIR/trajectories/``, see
  :mod:`.store`): the 5th, 50th and 95th percentiles (numpy's default, linear interpolation) of
  ``|w|`` across the runs at each kept time, and the worst run's ``|w|``: by default the run of the
  largest final ``|w|`` (its last kept sample), or with ``worst=COLUMN`` the worst run of that
  metric.

"Worst" is the largest ``|value|`` (every built-in metric but the final rates is non-negative,
where larger is worse: drift, cone angle, settle time, flips, attitude error; a final rate counts
by its size); ties go to the lowest run. The summary says whether trajectories were kept, and which
(every how many samples, at what rate); without them there are no envelopes of the rates over time.
"""

from __future__ import annotations

from collections import Counter
import json
from pathlib import Path
import re

import numpy as np

from .results import RESULTS_FILE
from .store import MANIFEST_FILE, PARTS_DIRECTORY, TRAJECTORIES_DIRECTORY

SUMMARY_FILE = 'summary.md'
HISTOGRAMS_FILE = 'histograms.png'
ENVELOPES_FILE = 'envelopes.png'
PERCENTILES = (5, 50, 95)
REPORT_DIRECTORY = 'report'
_FIXED = ('run', 'status', 'reason', 'redraws')
MAX_REASONS = 5  # distinct reasons listed per status
_INDEXED = re.compile(r'^(.*)\[(\d+)\]$')
_DECIMAL = re.compile(r'(?<![\w.])[-+]?(?:\d+\.\d*|\.\d+|\d+(?=[eE]))(?:[eE][-+]?\d+)?(?![\w.])')


class ReportError(ValueError):
    """A directory that holds no campaign table to report on (the message names it)."""


# -- reading --------------------------------------------------------------------------------------
def read_campaign_table(directory) -> tuple:
    """
    Read ``(table, summary)`` of the campaign in ``directory``.

    The table is its ``runs.parquet``, the summary the campaign summary in its metadata; a
    :class:`ReportError` naming the directory or file otherwise.
    """
    import pyarrow.parquet as pq

    directory = Path(directory)
    if not directory.exists():
        raise ReportError(f'{directory}: no such directory')
    if not directory.is_dir():
        raise ReportError(f"{directory}: not a directory (expected a campaign's output directory)")
    path = directory / RESULTS_FILE
    if not path.is_file():
        if (directory / PARTS_DIRECTORY / MANIFEST_FILE).is_file():
            raise ReportError(
                f'{directory}: the campaign is not finished (no {RESULTS_FILE} yet, its finished '
                f'chunks are in {PARTS_DIRECTORY}/): torquefree_campaign run FILE --output '
                f'{directory} --resume finishes it'
            )
        raise ReportError(f"{directory}: no {RESULTS_FILE} (not a campaign's output directory)")
    try:
        table = pq.read_table(path)
    except (OSError, ValueError) as error:  # pyarrow's ArrowInvalid is a ValueError
        raise ReportError(f'{path}: cannot be read as Parquet ({error})') from None
    try:
        summary = json.loads((table.schema.metadata or {})[b'torquefree_ros.campaign_summary'])
        metric_columns = [
            column for entry in summary['metrics'].values() for column in entry['columns']
        ]
    except (KeyError, ValueError, TypeError, AttributeError):
        raise ReportError(
            f"{path}: not a campaign's table (its metadata has no campaign summary)"
        ) from None
    missing = [column for column in (*_FIXED, *metric_columns) if column not in table.column_names]
    if missing:
        raise ReportError(f"{path}: not a campaign's table (no column {missing[0]!r})")
    return table, summary


def metric_units(table, summary: dict) -> dict:
    """Map each metric column to its unit, in the table's order."""
    units = {
        column: entry.get('unit', '')
        for entry in summary['metrics'].values()
        for column in entry['columns']
    }
    return {column: units[column] for column in table.column_names if column in units}


def input_columns(table, summary: dict) -> list[str]:
    metric = set(metric_units(table, summary))
    return [name for name in table.column_names if name not in _FIXED and name not in metric]


def column_values(table, column: str) -> np.ndarray:
    """Return a metric column as float64, null (a run that did not finish) as NaN."""
    return (
        table.column(column).cast('float64').fill_null(float('nan')).to_numpy(zero_copy_only=False)
    )


# -- what the summary says ------------------------------------------------------------------------
def reason_kind(reason: str) -> str:
    """
    Return a reason with its drawn numbers (decimals) as ``…``.

    The runs that failed the same way share it.
    """
    return _DECIMAL.sub('…', reason)


def statuses(table) -> list[tuple]:
    """
    Count the runs by status: ``(status, runs, [(reason kind, runs, first run), ...])``.

    ``ok`` first, then by runs; the kinds by runs, then by first run.
    """
    runs, status = table.column('run').to_pylist(), table.column('status').to_pylist()
    reason = table.column('reason').to_pylist()
    counts = Counter(status)
    found = []
    for name in sorted(counts, key=lambda s: (s != 'ok', -counts[s], s)):
        kinds: dict = {}
        for run, st, text in zip(runs, status, reason):
            if st == name and text:
                kind = reason_kind(text)
                count, first = kinds.get(kind, (0, run))
                kinds[kind] = (count + 1, min(first, run))
        found.append(
            (
                name,
                counts[name],
                sorted(
                    ((k, n, f) for k, (n, f) in kinds.items()),
                    key=lambda item: (-item[1], item[2]),
                ),
            )
        )
    return found


def metric_statistics(table, summary: dict) -> list[dict]:
    """
    Compute each metric column's statistics over the finished runs.

    Per metric column: ``count`` (finite values), ``undefined`` (finished runs without one),
    ``min``, ``median``, ``p95``, ``max`` (None when there is no finite value).
    """
    finished = np.array([s == 'ok' for s in table.column('status').to_pylist()], dtype=bool)
    rows = []
    for column, unit in metric_units(table, summary).items():
        values = column_values(table, column)
        finite = values[finished & np.isfinite(values)]
        row = {
            'column': column,
            'unit': unit,
            'count': int(finite.size),
            'undefined': int(np.count_nonzero(finished & ~np.isfinite(values))),
        }
        for key, function in (
            ('min', np.min),
            ('median', np.median),
            ('p95', lambda v: np.percentile(v, 95)),
            ('max', np.max),
        ):
            row[key] = float(function(finite)) if finite.size else None
        rows.append(row)
    return rows


def worst_runs(table, summary: dict) -> list[dict]:
    """
    Find, per metric column, the run of the largest finite ``|value|``.

    Each row: ``column``, ``run``, ``value``, ``inputs`` (target path -> drawn value or list of
    values).
    """
    runs = table.column('run').to_numpy()
    inputs = input_columns(table, summary)
    found = []
    for column in metric_units(table, summary):
        values = column_values(table, column)
        size = np.where(np.isfinite(values), np.abs(values), -np.inf)
        if not np.isfinite(values).any():
            continue
        row = int(np.argmax(size))  # the first of equal sizes: the lowest run
        found.append(
            {
                'column': column,
                'run': int(runs[row]),
                'value': float(values[row]),
                'inputs': _grouped({name: table.column(name)[row].as_py() for name in inputs}),
            }
        )
    return found


def _grouped(values: dict) -> dict:
    """
    Group the components of a vector target into a list.

    ``{"body.moments[0]": a, "body.moments[1]": b, ...}`` -> ``{"body.moments": [a, b, ...]}``.
    """
    grouped: dict = {}
    for name, value in values.items():
        match = _INDEXED.match(name)
        if match:
            grouped.setdefault(match.group(1), []).append(value)
        else:
            grouped[name] = value
    return grouped


def rate_envelopes(directory, table=None, summary=None, worst: str | None = None) -> dict | None:
    """
    Compute the percentile envelopes of ``|w|`` over time from ``directory``'s trajectories.

    None when the campaign kept none. Otherwise: ``times`` (K,), ``runs`` (R,) the runs with a
    trajectory, ``magnitude`` (R, K) their ``|w| = sqrt(w_x² + w_y² + w_z²)``, ``percentiles`` {5,
    50, 95: (K,)} across the runs (``np.percentile``, linear interpolation), ``worst_run`` (None
    without runs) and ``worst_by`` (what made it the worst: ``"final |w|"`` or the metric column
    ``worst``).
    """
    if table is None or summary is None:
        table, summary = read_campaign_table(directory)
    kept = summary.get('trajectories')
    path = Path(directory) / TRAJECTORIES_DIRECTORY
    if not kept:
        if worst is not None:
            raise ReportError(
                f'{directory}: worst {worst!r}: the campaign kept no trajectories to plot'
            )
        return None
    if not path.is_dir():
        raise ReportError(
            f'{path}: missing (the campaign kept trajectories; the directory was moved or removed)'
        )
    import pyarrow.dataset as ds

    try:
        data = ds.dataset(path, format='parquet').to_table(
            columns=['run', 't', 'w_x', 'w_y', 'w_z']
        )
    except (OSError, ValueError) as error:  # pyarrow's ArrowInvalid is a ValueError
        raise ReportError(
            f"{path}: cannot be read as the campaign's trajectories ({error})"
        ) from None
    data = data.sort_by([('run', 'ascending'), ('t', 'ascending')])
    samples = int(kept['samples'])
    if data.num_rows % samples:
        raise ReportError(f'{path}: {data.num_rows} rows are not whole runs of {samples} samples')
    runs = data.column('run').to_numpy()[::samples]
    times = data.column('t').to_numpy()[:samples]
    w = [data.column(name).to_numpy() for name in ('w_x', 'w_y', 'w_z')]
    magnitude = np.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).reshape(-1, samples)
    if not runs.size:
        times = np.arange(samples) / float(kept['rate'])
    percentiles = {
        p: (np.percentile(magnitude, p, axis=0) if runs.size else np.full(samples, np.nan))
        for p in PERCENTILES
    }
    worst_run, worst_by = None, 'final |w|'
    if worst is not None:
        if worst not in metric_units(table, summary):
            raise ReportError(
                f'worst: {worst!r} is not a metric column of the campaign (columns: '
                f'{", ".join(metric_units(table, summary))})'
            )
        worst_by = worst
        found = [row for row in worst_runs(table, summary) if row['column'] == worst]
        worst_run = found[0]['run'] if found else None
    elif runs.size:
        # the first of equal sizes: the lowest run
        worst_run = int(runs[int(np.argmax(magnitude[:, -1]))])
    return {
        'times': times,
        'runs': runs,
        'magnitude': magnitude,
        'percentiles': percentiles,
        'worst_run': worst_run,
        'worst_by': worst_by,
        'every': int(kept['every']),
        'rate': float(kept['rate']),
        'directory': path,
    }


# -- writing --------------------------------------------------------------------------------------
def write_report(directory, output=None, worst: str | None = None) -> list[Path]:
    """
    Write the report of the campaign in ``directory``; return the files written.

    The files are ``summary.md``, ``histograms.png`` and, when the campaign kept trajectories,
    ``envelopes.png``, into ``output`` (default ``directory/report``); ``worst``: the metric column
    whose worst run the envelopes show (default: the run of the largest final ``|w|``).
    """
    table, summary = read_campaign_table(directory)
    envelopes = rate_envelopes(directory, table, summary, worst)
    figure_class = _figure_class()
    output = Path(directory) / REPORT_DIRECTORY if output is None else Path(output)
    output.mkdir(parents=True, exist_ok=True)
    worst_rows = worst_runs(table, summary)
    histograms = output / HISTOGRAMS_FILE
    _histograms(figure_class, table, summary, worst_rows, histograms)
    written = []
    if envelopes is not None:
        written.append(output / ENVELOPES_FILE)
        _envelopes(figure_class, envelopes, written[-1])
    markdown = output / SUMMARY_FILE
    markdown.write_text(
        summary_markdown(
            table,
            summary,
            Path(directory) / RESULTS_FILE,
            HISTOGRAMS_FILE,
            envelopes,
            ENVELOPES_FILE,
        ),
        encoding='utf-8',
    )
    return [markdown, histograms, *written]


def _figure_class():
    try:
        # a Figure of its own renders with Agg, no pyplot state
        from matplotlib.figure import Figure
    except ImportError:
        raise ReportError(
            "the report's plots need matplotlib, an optional extra: "
            "pip install 'torquefree_ros[plot]'"
        ) from None
    return Figure


def _number(value) -> str:
    if value is None:
        return '–'
    if isinstance(value, int) and not isinstance(value, bool):
        return str(value)
    return f'{value:.6g}'


def _cell(text: str) -> str:
    return str(text).replace('\n', ' ').replace('|', '\\|')


def _inputs(inputs: dict) -> str:
    def shown(value):
        return (
            '[' + ', '.join(_number(v) for v in value) + ']'
            if isinstance(value, list)
            else _number(value)
        )

    return (
        '; '.join(f'`{path}` = {shown(value)}' for path, value in inputs.items())
        or 'none dispersed'
    )


def summary_markdown(
    table,
    summary: dict,
    source: Path,
    histograms: str,
    envelopes: dict | None = None,
    envelopes_file: str = ENVELOPES_FILE,
) -> str:
    meta = table.schema.metadata or {}
    versions = json.loads(meta.get(b'torquefree_ros.versions', b'{}'))
    description = ''
    try:
        import yaml

        description = (
            yaml.safe_load(meta.get(b'torquefree_ros.campaign', b'').decode('utf-8')) or {}
        ).get('description', '')
    except (ValueError, AttributeError, yaml.YAMLError):
        pass
    runs = table.num_rows
    lines = [f'# Campaign report: {Path(str(summary.get("source", source))).name}', '']
    if description:
        lines += [_cell(description), '']
    lines += [
        f'- campaign: `{summary.get("source")}`, scene `{summary.get("scene")}`',
        f'- {runs:,} runs, seed {summary.get("seed")}, {summary.get("duration"):g} s at '
        f'{summary.get("rate"):g} Hz '
        f'({summary.get("samples"):,} samples a run)',
        f'- table: `{source}`',
        '- made with '
        + ', '.join(f'{name} {version}' for name, version in versions.items() if version),
    ]
    if summary.get('body_acceptance') is not None:
        lines.append(f'- physical bodies among the first draws: {summary["body_acceptance"]:.1%}')
    found = statuses(table)
    lines += ['', '## Runs', '']
    if any(reasons for _, _, reasons in found):
        lines += [
            'Reasons with their drawn numbers as …, each with how many runs gave it and the first '
            'of them.',
            '',
        ]
    lines += ['| status | runs | share | reasons |', '|---|---:|---:|---|']
    for status, count, reasons in found:
        shown = '; '.join(
            f'{n}× {_cell(kind)} (run {first})' for kind, n, first in reasons[:MAX_REASONS]
        )
        if len(reasons) > MAX_REASONS:
            shown += f'; and {len(reasons) - MAX_REASONS} more kinds of reason'
        lines.append(f'| {status} | {count:,} | {100.0 * count / runs:.1f} % | {shown} |')
    lines += [
        '',
        '## Metrics',
        '',
        'Over the runs that finished (`ok`) with a finite value; *undefined*: finished runs whose '
        'value is NaN (a metric that does not apply to the run, such as the settle time of a run '
        'that never settles). p95: the 95th percentile (linear interpolation).',
        '',
        '| metric | unit | runs | undefined | min | median | p95 | max |',
        '|---|---|---:|---:|---:|---:|---:|---:|',
    ]
    for row in metric_statistics(table, summary):
        lines.append(
            f'| {row["column"]} | {row["unit"] or "–"} | {row["count"]:,} '
            f'| {row["undefined"]:,} | '
            + ' | '.join(_number(row[key]) for key in ('min', 'median', 'p95', 'max'))
            + ' |'
        )
    lines += [
        '',
        f'![histograms of the metrics]({histograms})',
        '',
        '## Worst runs',
        '',
        "The run with the largest |value| of each metric, with its drawn inputs (the table's "
        'input columns).',
        '',
        '| metric | run | value | drawn inputs |',
        '|---|---:|---:|---|',
    ]
    for row in worst_runs(table, summary):
        lines.append(
            f'| {row["column"]} | {row["run"]} | {_number(row["value"])} '
            f'| {_inputs(row["inputs"])} |'
        )
    lines += ['', '## Rates over time', '']
    if envelopes is None:
        lines += [
            'No trajectories kept (the campaign file has no `trajectories` option), so no '
            'percentile envelopes of the rates over time: the table holds no rates but the final '
            'ones.',
            '',
        ]
        return '\n'.join(lines)
    every = envelopes['every']
    lines += [
        f'Trajectories kept: every {"sample" if every == 1 else f"{every}th sample"} '
        f'({envelopes["rate"]:g} Hz, {envelopes["times"].size:,} samples a run) '
        f'of each finished run ({envelopes["runs"].size:,} runs), '
        f'in `{envelopes["directory"]}` (Parquet parts: '
        '`pyarrow.dataset.dataset(...)` opens them lazily).',
        '',
    ]
    if not envelopes['runs'].size:
        lines += ['No finished run with a trajectory: no envelopes.', '']
        return '\n'.join(lines)
    by = (
        'the largest final |w|'
        if envelopes['worst_by'] == 'final |w|'
        else f'the largest |{envelopes["worst_by"]}|'
    )
    worst = (
        f'and the worst run, run {envelopes["worst_run"]} (by {by})'
        if envelopes['worst_run'] is not None
        else f'(no run has a finite {envelopes["worst_by"]}: no worst run)'
    )
    lines += [
        f'The 5th, 50th and 95th percentiles of |w| across the runs at each kept time, {worst}.',
        '',
        f'![percentile envelopes of |w|]({envelopes_file})',
        '',
    ]
    return '\n'.join(lines)


def _envelopes(Figure, envelopes: dict, path: Path) -> None:
    figure = Figure(figsize=(7.5, 4.0), layout='constrained')
    axis = figure.subplots()
    times, bands = envelopes['times'], envelopes['percentiles']
    axis.set_xlabel('t (s)', fontsize=9)
    axis.set_ylabel('|w| (rad/s)', fontsize=9)
    axis.tick_params(labelsize=8)
    runs = envelopes['runs']
    if not runs.size:
        axis.text(
            0.5,
            0.5,
            'no finished run with a trajectory',
            ha='center',
            va='center',
            transform=axis.transAxes,
        )
    else:
        axis.fill_between(
            times, bands[5], bands[95], color='#4a7ab5', alpha=0.3, linewidth=0, label='5–95 %'
        )
        axis.plot(times, bands[50], color='#4a7ab5', linewidth=1.2, label='median')
        row = (
            int(np.searchsorted(runs, envelopes['worst_run']))
            if envelopes['worst_run'] is not None
            else -1
        )
        if 0 <= row < runs.size and runs[row] == envelopes['worst_run']:
            axis.plot(
                times,
                envelopes['magnitude'][row],
                color='#c0392b',
                linewidth=1.0,
                label=f'worst: run {envelopes["worst_run"]} ({envelopes["worst_by"]})',
            )
        axis.legend(fontsize=8)
    axis.set_title(f'|w| over time across {envelopes["runs"].size:,} runs', fontsize=10)
    figure.savefig(path, dpi=110)


def _histograms(Figure, table, summary, worst, path: Path) -> None:
    units = metric_units(table, summary)
    finished = np.array([s == 'ok' for s in table.column('status').to_pylist()], dtype=bool)
    worst_of = {row['column']: row for row in worst}
    columns = list(units)
    across = min(3, max(1, len(columns)))
    down = max(1, -(-len(columns) // across))
    figure = Figure(figsize=(4.4 * across, 3.2 * down), layout='constrained')
    axes = figure.subplots(down, across, squeeze=False).ravel()
    for axis, column in zip(axes, columns):
        values = column_values(table, column)
        finite = values[finished & np.isfinite(values)]
        axis.set_title(column, fontsize=10)
        axis.set_xlabel(units[column] or 'value', fontsize=8)
        axis.set_ylabel('runs', fontsize=8)
        axis.tick_params(labelsize=7)
        if not finite.size:
            axis.text(
                0.5, 0.5, 'no finite values', ha='center', va='center', transform=axis.transAxes
            )
            continue
        axis.hist(finite, bins=_bins(finite, table.schema.field(column).type), color='#4a7ab5')
        if column in worst_of:
            row = worst_of[column]
            axis.axvline(row['value'], color='#c0392b', linewidth=1.0)
            axis.annotate(
                f'run {row["run"]}',
                (row['value'], 1.0),
                xycoords=('data', 'axes fraction'),
                xytext=(-3, -3),
                textcoords='offset points',
                ha='right',
                va='top',
                fontsize=7,
                color='#c0392b',
            )
    for axis in axes[len(columns):]:
        axis.set_visible(False)
    figure.suptitle(
        f'{table.num_rows:,} runs, {int(finished.sum()):,} ok: each metric, its worst run marked',
        fontsize=10,
    )
    figure.savefig(path, dpi=110)


def _bins(values: np.ndarray, kind):
    import pyarrow as pa

    low, high = float(values.min()), float(values.max())
    if pa.types.is_integer(kind) and high - low <= 60:
        return np.arange(low - 0.5, high + 1.5)  # one bin per integer
    if low == high:
        return 1
    return 40
