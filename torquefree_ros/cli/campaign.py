"""``torquefree_campaign``: Monte Carlo campaigns (``torquefree_ros.campaigns``).

``torquefree_campaign run FILE --output DIR`` runs a campaign file (or a library campaign's name) and
writes ``DIR/runs.parquet`` (a row per run: inputs, metrics, status) and ``DIR/campaign.yaml``; by
default on a local Dask cluster of this machine's cores (a campaign of one chunk runs in this
process), ``--scheduler ADDRESS`` on an existing cluster, ``--scheduler in-process`` without Dask.
"""

from __future__ import annotations

import argparse
import sys
import time

from ..campaigns import CampaignError, library_campaigns, load_campaign
from .common import console_command

BAD_INPUT = 2  # argparse's own status for a bad command line


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="torquefree_campaign",
        description="Monte Carlo campaigns: one scene dispersed over many runs, a row of metrics per run.",
        epilog="library campaigns: " + (", ".join(sorted(library_campaigns())) or "none"))
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    run = commands.add_parser(
        "run", help="run a campaign into DIR/runs.parquet",
        description="Run a campaign file (or a library campaign) and write DIR/runs.parquet, a row per run "
        "(its drawn inputs, metrics, status and reason), with the campaign file and the versions in its metadata.")
    run.add_argument("campaign", metavar="FILE", help="a campaign file (YAML) or a library campaign's name")
    run.add_argument("--output", required=True, metavar="DIR", help="directory to write runs.parquet into")
    run.add_argument("--scheduler", metavar="ADDRESS",
                     help="a Dask scheduler's address (tcp://HOST:PORT); 'local' for a local cluster, "
                     "'in-process' for no Dask (default: a local cluster, or in-process for one chunk)")
    run.add_argument("--workers", type=_positive, metavar="N",
                     help="worker processes of the local cluster (default: one per core)")
    run.add_argument("--chunk", type=_positive, metavar="RUNS",
                     help="runs per task (default: 256, fewer for long runs); the table does not depend on it")
    run.add_argument("--overwrite", action="store_true", help="replace DIR/runs.parquet if it exists")
    return parser


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value


class _Progress:
    """Runs done, runs/s and ETA on one line of stderr, only on a terminal."""

    def __init__(self, stream=None):
        self.stream = sys.stderr if stream is None else stream
        self.enabled = bool(getattr(self.stream, "isatty", lambda: False)())
        self.start = time.monotonic()

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        elapsed = time.monotonic() - self.start
        speed = done / elapsed if elapsed > 0 else 0.0
        eta = f"{(total - done) / speed:.0f} s" if speed > 0 else "--"
        self.stream.write(f"\r{done:,}/{total:,} runs, {speed:,.0f} runs/s, ETA {eta}\033[K")
        self.stream.flush()

    def close(self) -> None:
        if self.enabled:
            self.stream.write("\r\033[K")
            self.stream.flush()


@console_command("torquefree_campaign")
def main(argv=None) -> int:
    from ..campaigns import run_campaign
    from ..campaigns.results import RESULTS_FILE

    parser = _parser()
    args = parser.parse_args(argv)
    if args.workers is not None and args.scheduler not in (None, "local"):
        parser.error("--workers: only for the local cluster (an existing cluster has its own workers)")
    try:
        campaign = load_campaign(args.campaign)
    except CampaignError as error:
        print(f"torquefree_campaign: {error}", file=sys.stderr)
        return BAD_INPUT
    if campaign.body_acceptance is not None and campaign.body_acceptance < 0.9:
        what = ("each run redraws until its body is physical: the kept bodies are the dispersion conditioned on it"
                if campaign.invalid_body == "redraw" else "those runs fail (status invalid_body)")
        print(f"torquefree_campaign: note: {campaign.body_acceptance:.0%} of the first draws give a physical body; "
              f"{what}", file=sys.stderr)
    progress = _Progress()
    started = time.perf_counter()
    try:
        table = run_campaign(campaign, scheduler=args.scheduler, workers=args.workers, output=args.output,
                             chunk_size=args.chunk, overwrite=args.overwrite, progress=progress)
    except FileExistsError as error:
        print(f"torquefree_campaign: {error}", file=sys.stderr)
        return BAD_INPUT
    except (OSError, TimeoutError) as error:  # the output directory, or a scheduler that does not answer
        print(f"torquefree_campaign: {error}", file=sys.stderr)
        return 1
    finally:
        progress.close()
    elapsed = time.perf_counter() - started
    ok = sum(1 for status in table.column("status").to_pylist() if status == "ok")
    print(f"{args.output}/{RESULTS_FILE}: {table.num_rows} runs ({ok} ok, {table.num_rows - ok} failed) in "
          f"{elapsed:.2f} s, {table.num_rows / max(elapsed, 1e-9):,.0f} runs/s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
