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
``torquefree_campaign``: Monte Carlo campaigns (``torquefree_ros.campaigns``).

``torquefree_campaign run FILE --output DIR`` runs a campaign file (or a library campaign's name)
and writes ``DIR/runs.parquet`` (a row per run: inputs, metrics, status) and ``DIR/campaign.yaml``;
by default in this process or on a local Dask cluster of this machine's cores, whichever finishes
first (the first chunk is timed here and weighed against the cluster's start-up; the engine and
why are printed), ``--scheduler local`` on a local cluster, ``--scheduler ADDRESS`` on an existing
cluster, ``--scheduler in-process`` without Dask.
Finished chunks are kept in ``DIR/parts/`` as they complete: ``--resume`` continues an interrupted
campaign, ``--overwrite`` starts over. A campaign file with ``trajectories: {every: N}`` (or
``{rate: HZ}``) also keeps its runs' decimated samples in ``DIR/trajectories/`` (Parquet parts).
``torquefree_campaign report DIR`` writes plots and a Markdown summary of the table
(``DIR/report/`` by default), with percentile envelopes of ``|w|`` over time when trajectories were
kept.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

from .common import _duration, console_command
from ..campaigns import CampaignError, library_campaigns, load_campaign

BAD_INPUT = 2  # argparse's own status for a bad command line


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='torquefree_campaign',
        description='Monte Carlo campaigns: one scene dispersed over many runs, a row of metrics '
        'per run.',
        epilog='library campaigns: ' + (', '.join(sorted(library_campaigns())) or 'none'),
    )
    commands = parser.add_subparsers(dest='command', metavar='COMMAND', required=True)
    run = commands.add_parser(
        'run',
        help='run a campaign into DIR/runs.parquet',
        description='Run a campaign file (or a library campaign) and write DIR/runs.parquet, a '
        'row per run (its drawn inputs, metrics, status and reason), with the campaign file and '
        'the versions in its metadata.',
    )
    run.add_argument(
        'campaign', metavar='FILE', help="a campaign file (YAML) or a library campaign's name"
    )
    run.add_argument(
        '--output',
        required=True,
        metavar='DIR',
        help='directory to write runs.parquet into (each finished chunk is kept in DIR/parts/ '
        'until then)',
    )
    run.add_argument(
        '--scheduler',
        metavar='ADDRESS',
        help="a Dask scheduler's address (tcp://HOST:PORT); 'local' for a local cluster, "
        "'in-process' for no Dask (default: whichever finishes first, in-process or a local "
        'cluster, by the first chunk timed in-process against the start-up of a cluster)',
    )
    run.add_argument(
        '--workers',
        type=_positive,
        metavar='N',
        help='worker processes of the local cluster (default: one per core)',
    )
    run.add_argument(
        '--chunk',
        type=_positive,
        metavar='RUNS',
        help=(
            'runs per chunk, a part file and a progress step (default: 256, up to 1024 while '
            'every worker gets 8 chunks; fewer for long runs); the table does not depend on it'
        ),
    )
    again = run.add_mutually_exclusive_group()
    again.add_argument(
        '--resume',
        action='store_true',
        help='continue the campaign DIR holds: compute only the runs its finished chunks lack '
        '(the campaign file, its scene and the versions must be the same); a finished one is left '
        'as is',
    )
    again.add_argument(
        '--overwrite', action='store_true', help='start over: remove the campaign DIR holds'
    )
    run.add_argument(
        '--progress',
        choices=('auto', 'always', 'never'),
        default='auto',
        help='the progress line on stderr (runs done, runs/s, ETA): auto = only on a terminal',
    )
    report = commands.add_parser(
        'report',
        help="plots and a Markdown summary of a campaign's table",
        description='Read DIR/runs.parquet and write summary.md (runs, statuses with their '
        "reasons, each metric's min/median/p95/max, the worst runs with their drawn inputs), "
        'histograms.png (each metric, its worst run marked) and, when the campaign kept '
        'trajectories, envelopes.png (the 5/50/95 %% percentiles of |w| over time across the '
        "runs, and the worst run). Needs matplotlib: pip install '.[plot]'.",
    )
    report.add_argument(
        'directory', metavar='DIR', help="a campaign's output directory (holding runs.parquet)"
    )
    report.add_argument(
        '--output', metavar='DIR', help='where to write the report (default: DIR/report)'
    )
    report.add_argument(
        '--worst',
        metavar='COLUMN',
        help='envelopes.png: show the worst run of this metric column (largest |value|) instead '
        'of the run of the largest final |w|',
    )
    return parser


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected a positive integer, got {text!r}') from None
    if value < 1:
        raise argparse.ArgumentTypeError(f'expected a positive integer, got {text!r}')
    return value


class RunProgress:
    """
    A campaign's progress line on stderr: runs done, runs/s, ETA and the engine.

    The ``progress(done_runs, total_runs)`` for :func:`run_campaign`: one line on stderr,
    rewritten at most every ``period`` s, only on a terminal unless ``enabled`` is forced. The
    first call gives the runs already done (a resumed campaign's). The speed is taken from the
    first chunk in on, so that a cluster's start-up does not weigh on the ETA. :meth:`engine` is
    the ``on_engine`` of :func:`run_campaign`: it says the engine and why on a line of its own
    (always: it is no progress), and the progress line names the engine from then on.
    """

    def __init__(
        self, stream=None, enabled: bool | None = None, period: float = 0.5, clock=time.monotonic
    ):
        self.stream = sys.stderr if stream is None else stream
        self.enabled = (
            bool(getattr(self.stream, 'isatty', lambda: False)()) if enabled is None else enabled
        )
        self.period, self.clock = period, clock
        self.first = None  # runs done before this session
        self.base = None  # (time, runs done) at the first chunk in
        self.start = self.last = None
        self.shown = False
        self.choice = None  # the engine (an EngineChoice), once settled

    def __call__(self, done: int, total: int) -> None:
        now = self.clock()
        if self.first is None:
            self.first, self.start, self.last = done, now, now
        elif self.base is None:
            self.base = (now, done)
        if not self.enabled or (now - self.last < self.period and done < total):
            return
        self.last = now
        counted = self.base is not None and now > self.base[0] and done > self.base[1]
        since, base_done = self.base if counted else (self.start, self.first)
        speed = (done - base_done) / (now - since) if now > since else 0.0
        self.stream.write(
            '\r'
            + progress_line(
                done, total, speed, self.first, self.choice.label if self.choice else None
            )
            + '\033[K'
        )
        self.stream.flush()
        self.shown = True

    def engine(self, choice) -> None:
        """Take the engine the campaign runs on; say which and why, on a line of its own."""
        self.choice = choice
        line = f'torquefree_campaign: engine: {choice}'
        self.stream.write(f'\r{line}\033[K\n' if self.shown else f'{line}\n')
        self.stream.flush()

    def close(self) -> None:
        if self.shown:
            self.stream.write('\r\033[K')
            self.stream.flush()
            self.shown = False


def progress_line(
    done: int, total: int, speed: float, resumed: int = 0, engine: str | None = None
) -> str:
    """
    Format the progress line's text: ``done`` of ``total`` runs at ``speed`` runs/s, and the ETA.

    ``resumed`` of the runs done were kept from an earlier run; ``engine`` names the engine, once
    it is settled.
    """
    eta = _duration((total - done) / speed if speed > 0 else math.inf)
    percent = 100.0 * done / total if total else 100.0
    kept = f', {resumed:,} resumed' if resumed else ''
    where = f', {engine}' if engine else ''
    return (
        f'{done:,}/{total:,} runs ({percent:.0f} %{kept}), {speed:,.1f} runs/s, ETA {eta}{where}'
    )


@console_command('torquefree_campaign')
def main(argv=None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command == 'report':
        return _report(args)
    if args.workers is not None and args.scheduler not in (None, 'local'):
        parser.error(
            '--workers: only for the local cluster (an existing cluster has its own workers)'
        )
    return _run(args)


def _run(args) -> int:
    from ..campaigns import run_campaign
    from ..campaigns.results import RESULTS_FILE
    from ..campaigns.store import PARTS_DIRECTORY, ResumeError, TRAJECTORIES_DIRECTORY

    try:
        campaign = load_campaign(args.campaign)
    except CampaignError as error:
        print(f'torquefree_campaign: {error}', file=sys.stderr)
        return BAD_INPUT
    if campaign.body_acceptance is not None and campaign.body_acceptance < 0.9:
        what = (
            'each run redraws until its body is physical: the kept bodies are the dispersion '
            'conditioned on it'
            if campaign.invalid_body == 'redraw'
            else 'those runs fail (status invalid_body)'
        )
        print(
            f'torquefree_campaign: note: {campaign.body_acceptance:.0%} of the first draws give a '
            f'physical body; {what}',
            file=sys.stderr,
        )
    progress = RunProgress(enabled={'auto': None, 'always': True, 'never': False}[args.progress])
    started = time.perf_counter()
    try:
        table = run_campaign(
            campaign,
            scheduler=args.scheduler,
            workers=args.workers,
            output=args.output,
            chunk_size=args.chunk,
            overwrite=args.overwrite,
            resume=args.resume,
            progress=progress,
            on_engine=progress.engine,
        )
    except (FileExistsError, NotADirectoryError, ResumeError) as error:
        print(f'torquefree_campaign: {error}', file=sys.stderr)
        return BAD_INPUT
    except (OSError, TimeoutError) as error:
        # the output directory, or a scheduler that does not answer
        print(f'torquefree_campaign: {error}', file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        progress.close()
        print(
            'torquefree_campaign: the finished chunks are kept in '
            f'{args.output}/{PARTS_DIRECTORY}; the same command with --resume computes '
            'only the rest',
            file=sys.stderr,
        )
        raise
    finally:
        progress.close()
    elapsed = time.perf_counter() - started
    ok = sum(1 for status in table.column('status').to_pylist() if status == 'ok')
    resumed = progress.first or 0
    computed = table.num_rows - resumed
    choice = progress.choice
    where = ''
    if choice is not None:
        where = ' in-process' if choice.engine == 'in-process' else f' on a {choice.label}'
    what = (
        f'{computed:,} computed{where} in {elapsed:.2f} s, '
        f'{computed / max(elapsed, 1e-9):,.0f} runs/s'
        if computed
        else 'finished before, nothing computed'
    )
    print(
        f'{args.output}/{RESULTS_FILE}: {table.num_rows} runs ({ok} ok, '
        f'{table.num_rows - ok} failed{f", {resumed:,} resumed" if resumed else ""}); {what}'
    )
    if campaign.trajectory_every:
        every = (
            'every sample'
            if campaign.trajectory_every == 1
            else f'every {campaign.trajectory_every}th sample'
        )
        rate = campaign.rate / campaign.trajectory_every
        print(
            f'{args.output}/{TRAJECTORIES_DIRECTORY}: {every} ({rate:g} Hz) '
            f'of the {ok} finished runs'
        )
    return 0


def _report(args) -> int:
    from ..campaigns.report import ReportError, write_report

    try:
        written = write_report(args.directory, args.output, worst=args.worst)
    except ReportError as error:
        print(f'torquefree_campaign: {error}', file=sys.stderr)
        return BAD_INPUT
    except OSError as error:  # the report's directory
        print(f'torquefree_campaign: {error}', file=sys.stderr)
        return 1
    for path in written:
        print(path)
    return 0


if __name__ == '__main__':
    sys.exit(main())
