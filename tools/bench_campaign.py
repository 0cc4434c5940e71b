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
Benchmark of Monte Carlo campaigns (``torquefree_ros.campaigns``).

A script, not a test: what the campaign machinery adds to the compute and how it scales, beside
Basilisk's figures.

- 10 000 torque-free runs (the library's ``dzhanibekov_rates``: the Dzhanibekov body, rates and
  spin dispersed, six metrics), 100 s at 10 Hz, metrics only, written to a directory as the command
  line does: the campaign on 1 and on 2 local workers (clusters started and warmed beforehand),
  beside the bare compute (the same drawn bodies through ``propagate_batch`` plus the same metrics
  in one process, in the engine's blocks of runs; no draws, no engine, no table);
- 1 000 dispersed explorer1 runs (``explorer1_damper``: inertia, rates, attitude and the damper's
  damping dispersed), 900 s at 1 Hz, on 2 local workers, end to end as ``torquefree_campaign run
  --scheduler local --workers 2`` does it (the cluster started and closed inside the time);
- what the engine costs: a local cluster's start-up, a worker's first chunk (imports and kernels),
  the per-chunk overhead (in this process and on a worker), the memory (RSS) of a worker;
- both sides of the default engine's switch (``engine.choose_engine``): campaigns below and above
  the compute a local cluster's start-up outweighs, each in-process, on a local cluster started
  within the time, and with the default (which says what it picked), in this process and from the
  command line in a fresh process; and a local cluster's start-up, warm-up and close measured
  beside ``engine.LOCAL_CLUSTER_STARTUP``. ``--switch-only`` measures this part alone;
- the closed-loop detumble campaign (the library's ``bdot_detumble``: 1 000 runs of three orbits,
  B-dot at 1 Hz on the batched plant) with the default engine, end to end as ``torquefree_campaign
  run`` does it, beside the bare batch compute of some of its runs in one process: the plant
  stepped alone (a held dipole), and the plant with its sensors read and the law answering (the
  closed loop without draws, metrics, chunks or table). ``--only detumble`` measures this part
  alone (one round: a campaign of several minutes).

Wall time (``perf_counter``), and beside it the CPU time of this process and the workers (which
shows the work done when other processes share the cores); ``--rounds`` rounds give median
(min–max), the ratios taken within each round.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_report import Report, spread  # noqa: E402

RUNS = 10_000
DURATION, RATE = 100.0, 10.0
OVERHEAD_TASKS = 400  # one-run, one-sample chunks: the engine's cost per chunk
# the default engine's switch: (runs, duration s) at RATE, from little compute to much
SWITCH_CASES = ((10_000, 1.0), (10_000, 100.0), (60_000, 100.0))
ENGINES = ('in-process', 'local', None)  # None: the default
BASILISK = (
    "Basilisk 2.12's Monte Carlo `Controller` (2 threads) runs 40 torque-free runs of 100 s at "
    '**1.5–1.7 runs/s** (it sleeps 1 s per run and builds a process pool per pair of runs); a '
    'plain process pool of the same Basilisk simulations reaches **14.9 runs/s** (issue 32, '
    'measured by another session on this machine)'
)


def use_the_workers_allocator() -> bool:
    """
    Set this process's glibc allocator as a local cluster's workers'.

    The workers' settings are ``engine.MALLOC_ENVIRONMENT``: the bare compute and the in-process
    figures are then measured on the workers' footing.
    """
    import ctypes

    from torquefree_ros.campaigns.engine import MALLOC_ENVIRONMENT

    try:
        libc = ctypes.CDLL('libc.so.6')
    except OSError:
        return False
    M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3  # malloc.h
    return bool(
        libc.mallopt(M_MMAP_THRESHOLD, int(MALLOC_ENVIRONMENT['MALLOC_MMAP_THRESHOLD_']))
        and libc.mallopt(M_TRIM_THRESHOLD, int(MALLOC_ENVIRONMENT['MALLOC_TRIM_THRESHOLD_']))
    )


def torque_free_campaign(runs: int = RUNS):
    from torquefree_ros.campaigns import load_campaign
    import yaml

    data = yaml.safe_load(load_campaign('dzhanibekov_rates').text)
    data.update(runs=runs, duration=DURATION, rate=RATE)
    return data


def bare_compute(campaign, draws) -> float:
    """
    Time the runs' physics and metrics alone, in seconds.

    propagate_batch and the metrics, a block of runs at a time (the engine's blocks: the size that
    keeps the arrays' pages, engine.BLOCK_SAMPLES).
    """
    import numpy as np
    from torquefree_ros import propagate_batch
    from torquefree_ros.campaigns import engine

    times = np.arange(campaign.samples) / campaign.rate
    size = engine.block_runs(campaign)
    started = time.perf_counter()
    nominal = engine._nominal(campaign, times) if campaign.needs_nominal else None
    for low in range(0, len(draws), size):
        chunk = draws[low: low + size]
        omega, q = propagate_batch(
            np.array([d.inertia for d in chunk]),
            np.array([d.omega for d in chunk]),
            np.array([d.q for d in chunk]),
            times,
        )
        samples = engine._samples(
            times, chunk, omega, q, np.empty(omega.shape[:2] + (0,)), nominal=nominal
        )
        for use in campaign.metrics:
            use.evaluate(samples)
    return time.perf_counter() - started


def timed(function) -> float:
    started = time.perf_counter()
    function()
    return time.perf_counter() - started


def worker_cpu(client) -> float:
    """CPU seconds (user + system) the client's workers have used so far, all threads."""

    def used():
        import psutil

        times = psutil.Process().cpu_times()
        return times.user + times.system

    return sum(client.run(used).values()) if client is not None else 0.0


def wall_and_cpu(function, client=None) -> tuple[float, float, float]:
    """
    Time ``function``: wall seconds, and CPU seconds of this process and of ``client``'s workers.

    On a shared machine the CPU shows the work even when other processes take the cores.
    """
    cpu0, workers0 = time.process_time(), worker_cpu(client)
    wall = timed(function)
    return wall, time.process_time() - cpu0, worker_cpu(client) - workers0


def start_cluster(workers: int):
    """
    Start a local cluster and its client, warmed.

    Warmed: every worker has run a chunk (imports, kernels).
    """
    from distributed import Client
    from torquefree_ros.campaigns import run_campaign
    from torquefree_ros.campaigns.engine import local_cluster

    started = time.perf_counter()
    cluster = local_cluster(workers)
    client = Client(cluster)
    client.wait_for_workers(workers)
    up = time.perf_counter() - started
    first = timed(
        lambda: run_campaign(torque_free_campaign(workers), scheduler=client, chunk_size=1)
    )
    return cluster, client, up, first


def worker_memory(client) -> list[tuple[float, float]]:
    """(RSS, peak RSS) of each worker, MiB."""

    def measure():
        import resource

        import psutil

        rss = psutil.Process().memory_info().rss / 2**20
        return rss, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**10

    return list(client.run(measure).values())


def measure_round(directory: Path) -> dict:
    """
    Measure one round: the bare compute, then the campaign on 1 and on 2 warm local workers.

    Each cluster is started and warmed for its measurement and closed after it, so no idle
    cluster shares the cores with the one measured (as none would with a user's campaign).
    """
    from torquefree_ros.campaigns import engine, load_campaign, run_campaign

    campaign = load_campaign(torque_free_campaign())
    draws = [engine.draw_run(campaign, run) for run in range(campaign.runs)]
    bare_compute(campaign, draws[:10])  # this process's kernels loaded before the timing
    result = {}
    result['bare'], result['bare_cpu'], _ = wall_and_cpu(lambda: bare_compute(campaign, draws))
    for workers in (1, 2):
        cluster, client, _, _ = start_cluster(workers)
        try:
            wall, driver, on_workers = wall_and_cpu(
                lambda: run_campaign(
                    campaign, scheduler=client, output=directory / f'w{workers}', overwrite=True
                ),
                client,
            )
            if workers == 2:
                result['memory'] = worker_memory(client)  # after a campaign
        finally:
            client.close()
            cluster.close()
        result[f'workers_{workers}'], result[f'workers_{workers}_driver'] = wall, driver
        result[f'workers_{workers}_cpu'] = driver + on_workers
    result['ratio_1'] = result['workers_1'] / result['bare']
    result['ratio_1_cpu'] = result['workers_1_cpu'] / result['bare_cpu']
    result['speedup_2'] = result['workers_1'] / result['workers_2']
    # where the time goes, in this process: the draws, the engine without Dask, the part files and
    # the table
    result['draws'] = timed(
        lambda: [engine.draw_run(campaign, run) for run in range(campaign.runs)]
    )
    result['in_process'] = timed(lambda: run_campaign(campaign, scheduler='in-process'))
    result['in_process_output'] = timed(
        lambda: run_campaign(
            campaign, scheduler='in-process', output=directory / 'inproc', overwrite=True
        )
    )
    result['explorer'] = timed(
        lambda: run_campaign(
            'explorer1_damper',
            scheduler='local',
            workers=2,
            output=directory / 'explorer',
            overwrite=True,
        )
    )
    return result


def engine_costs(clusters: dict, directory: Path) -> dict:
    """
    Per chunk: one-run one-sample chunks in this process, then on the warm 1-worker cluster.

    On the cluster, in the engine's tasks of several chunks (``engine.tasks``), then a task a
    chunk.
    """
    from torquefree_ros.campaigns import engine, load_campaign, run_campaign

    tiny = torque_free_campaign(OVERHEAD_TASKS)
    tiny.update(duration=0.0, metrics=['final_rates'])
    in_process = min(
        timed(lambda: run_campaign(tiny, scheduler='in-process', chunk_size=1)) for _ in range(2)
    )
    with_parts = min(
        timed(
            lambda: run_campaign(
                tiny,
                scheduler='in-process',
                chunk_size=1,
                output=directory / 'tiny',
                overwrite=True,
            )
        )
        for _ in range(2)
    )
    client = clusters[1][1]
    # as the engine groups them (engine.tasks), then a task a chunk
    grouped = min(
        timed(lambda: run_campaign(tiny, scheduler=client, chunk_size=1)) for _ in range(2)
    )
    tasks_per_worker = engine.TASKS_PER_WORKER
    engine.TASKS_PER_WORKER = OVERHEAD_TASKS
    try:
        alone = min(
            timed(lambda: run_campaign(tiny, scheduler=client, chunk_size=1)) for _ in range(2)
        )
    finally:
        engine.TASKS_PER_WORKER = tasks_per_worker
    return {
        'chunk_in_process_ms': 1e3 * in_process / OVERHEAD_TASKS,
        'part_file_ms': 1e3 * (with_parts - in_process) / OVERHEAD_TASKS,
        'chunk_dask_ms': 1e3 * (alone - in_process) / OVERHEAD_TASKS,
        'chunk_grouped_ms': 1e3 * (grouped - in_process) / OVERHEAD_TASKS,
        'grouped_tasks': len(engine.tasks(engine.chunks(load_campaign(tiny), 1), 1)),
    }


def engine_name(engine) -> str:
    return 'default' if engine is None else engine


def switch_round(directory: Path) -> dict:
    """
    Time each switch case with each engine, in this process (warm) and from the command line.

    In this process the kernels are loaded beforehand; a local cluster is started and closed
    within its time, as a campaign does. From the command line: a fresh interpreter per campaign,
    timed end to end (what a user waits for). The default's choice is kept.
    """
    from torquefree_ros.campaigns import run_campaign

    import yaml

    run_campaign(torque_free_campaign(10), scheduler='in-process')  # this process's kernels
    result = {}
    for runs, duration in SWITCH_CASES:
        data = torque_free_campaign(runs)
        data.update(duration=duration)
        for engine in ENGINES:
            picked = []
            result[('api', runs, duration, engine_name(engine))] = timed(
                lambda: run_campaign(data, scheduler=engine, on_engine=picked.append)
            )
            if engine is None:
                result[('api-picked', runs, duration)] = str(picked[0])
        path = directory / f'switch-{runs}-{duration:g}.yaml'
        path.write_text(yaml.safe_dump(data))
        for engine in ENGINES:
            command = [sys.executable, '-m', 'torquefree_ros.cli.campaign', 'run', str(path)]
            command += ['--output', str(directory / 'switch-out'), '--overwrite']
            command += [] if engine is None else ['--scheduler', engine]
            started = time.perf_counter()
            done = subprocess.run(command, capture_output=True, text=True, check=True)
            result[('cli', runs, duration, engine_name(engine))] = time.perf_counter() - started
            if engine is None:
                said = [
                    line.split('engine: ', 1)[1]
                    for line in done.stderr.splitlines()
                    if line.startswith('torquefree_campaign: engine: ')
                ]
                result[('cli-picked', runs, duration)] = said[0]
    # what a local cluster adds: a campaign of two one-run, one-sample chunks on one, less the same
    # in this process
    tiny = torque_free_campaign(2)
    tiny.update(duration=0.0, metrics=['final_rates'])
    alone = timed(lambda: run_campaign(tiny, scheduler='in-process', chunk_size=1))
    result['cluster_overhead'] = (
        timed(lambda: run_campaign(tiny, scheduler='local', chunk_size=1)) - alone
    )
    return result


DETUMBLE_BARE_RUNS = 100  # runs of the detumble campaign whose bare compute is timed


def detumble_bare(campaign, runs: int) -> dict:
    """
    Time the first ``runs`` runs' plant over the whole duration, in one batch, in this process.

    The plant stepped alone at the controller's rate with a dipole held (the plant's own work:
    the commands accepted, the held inputs, the compiled kernels), then the closed loop as the
    engine runs it (``controllers.closed_loop``: the sensors read, the law answering, the
    campaign's samples kept), without draws, metrics, chunks or table.
    """
    import numpy as np
    from torquefree_ros.campaigns import engine
    from torquefree_ros.campaigns.controllers import closed_loop, law_values
    from torquefree_ros.plant import Plant

    draws = [engine.draw_run(campaign, run) for run in range(runs)]
    scenes = [engine._scene_of(campaign, draw) for draw in draws]
    steps = engine.plant_steps(campaign)
    dipole = np.full((runs, 3), 0.05)  # A m^2: within every run's rods

    def plant_alone():
        plant = Plant(scenes, campaign.controller.rate)
        for _ in range(steps - 1):
            plant.step(dipole=dipole)

    with np.errstate(all='ignore'):
        closed_loop(campaign, scenes[:2], law_values(campaign, draws[:2]))  # kernels loaded
        plant_wall, plant_cpu, _ = wall_and_cpu(plant_alone)
        loop_wall, loop_cpu, _ = wall_and_cpu(
            lambda: closed_loop(campaign, scenes, law_values(campaign, draws))
        )
    return {
        'runs': runs,
        'steps': steps,
        'plant': plant_wall,
        'plant_cpu': plant_cpu,
        'loop': loop_wall,
        'loop_cpu': loop_cpu,
    }


def detumble_campaign_timed(campaign='bdot_detumble') -> dict:
    """
    Run the library's ``bdot_detumble`` with the default engine, end to end, timed.

    As ``torquefree_campaign run bdot_detumble`` does it: ``run_campaign`` with no scheduler (the
    first chunks timed here, the rest where it finishes first). Wall time, this process's CPU and
    its finished children's (a local cluster's workers, once closed), the engine's choice and the
    table's statuses.
    """
    import resource

    from torquefree_ros.campaigns import run_campaign

    picked = []
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    load = os.getloadavg()
    wall, cpu, _ = wall_and_cpu(
        lambda: picked.append(run_campaign(campaign, on_engine=picked.append))
    )
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    table = picked.pop()
    statuses = table.column('status').to_pylist()
    settle = [x for x in table.column('settle_time').to_pylist() if x is not None]
    return {
        'wall': wall,
        'cpu': cpu,
        'children_cpu': (after.ru_utime + after.ru_stime)
        - (children.ru_utime + children.ru_stime),
        'engine': str(picked[0]) if picked else 'none',
        'ok': statuses.count('ok'),
        'runs': len(statuses),
        'settled': sum(1 for x in settle if x == x),
        'settle': settle,
        'load_before': load,
        'load_after': os.getloadavg(),
    }


def report_detumble(report, bare: dict, timed_campaign: dict, campaign='bdot_detumble') -> None:
    """Add the detumble campaign's section."""
    import numpy as np
    from torquefree_ros.campaigns import load_campaign

    campaign = load_campaign(campaign)
    runs, steps = campaign.runs, bare['steps']
    controller = campaign.controller
    report.add('')
    report.add('## The detumble campaign (closed loop)')
    report.add('')
    report.add(
        f'`bdot_detumble` from the campaign library: {runs:,} runs of {campaign.duration:g} s '
        f'(three orbits), B-dot (`{controller.name}`) at {controller.rate:g} Hz on the batched '
        f'plant ({steps:,} plant samples a run, the magnetometer read and the law answering at '
        f"each), metrics on the campaign's {campaign.rate:g} Hz grid ({campaign.samples:,} "
        'samples). Load average (1, 5, 15 min) before the campaign: '
        + ' '.join(f'{x:.2f}' for x in timed_campaign['load_before'])
        + ', after: '
        + ' '.join(f'{x:.2f}' for x in timed_campaign['load_after'])
        + f' ({os.cpu_count()} cores, shared with other processes).'
    )
    report.add('')
    wall = timed_campaign['wall']
    cpu = timed_campaign['cpu'] + timed_campaign['children_cpu']
    report.add('| measure | value | target (issue 41) | met |')
    report.add('|---|---|---|---|')
    report.add(
        "| the campaign, default engine, end to end (`run_campaign('bdot_detumble')`) | "
        f'{wall:,.0f} s ({runs / wall:.2f} runs/s; CPU {cpu:,.0f} s: this process '
        f'{timed_campaign["cpu"]:,.0f} s, the local workers {timed_campaign["children_cpu"]:,.0f}'
        f' s); engine: {timed_campaign["engine"]} | ≤ 600 s | '
        f'{"yes" if wall <= 600 else "**no**"} |'
    )
    for key, what in (
        ('plant', 'the plant stepped alone (a dipole held; no sensors, no law)'),
        ('loop', 'the closed loop (plant, sensors read, law; no draws, metrics, chunks, table)'),
    ):
        per_run = bare[f'{key}_cpu'] / bare['runs']
        report.add(
            f'| bare batch compute, {bare["runs"]} runs in one batch, one process: {what} | '
            f'{bare[key]:,.1f} s ({bare["runs"] / bare[key]:.2f} runs/s; CPU '
            f'{bare[f"{key}_cpu"]:,.1f} s, {1e6 * per_run / steps:.1f} µs a body-step; '
            f'{runs:,} runs: {runs * per_run:,.0f} s of CPU) | | |'
        )
    settle = np.array([x for x in timed_campaign['settle'] if x == x])
    report.add('')
    report.add(
        f'{timed_campaign["ok"]:,} of {timed_campaign["runs"]:,} runs ok; '
        f'{timed_campaign["settled"]:,} detumbled (|w| below 0.5 deg/s to the end)'
        + (
            f': detumble time median {np.median(settle):,.0f} s, 5-95 % '
            f'{np.percentile(settle, 5):,.0f}-{np.percentile(settle, 95):,.0f} s.'
            if settle.size
            else '.'
        )
    )


def report_switch(report, rounds: list[dict]) -> None:
    """Add the switch's tables: each case with each engine, and what the default picked."""
    from torquefree_ros.campaigns import engine, load_campaign

    workers = engine.expected_workers('local', None)
    startup = engine.LOCAL_CLUSTER_STARTUP
    report.add('')
    report.add(
        "The default engine's switch (`engine.choose_engine`): the first chunk runs in this "
        'process, timed; the rest goes to a local cluster of a worker per core '
        f'({workers} here) only when its estimated compute C exceeds `LOCAL_CLUSTER_STARTUP` '
        f'({startup:g} s) + C / {workers}, that is C > {startup * workers / max(workers - 1, 1):g}'
        f' s here. Each campaign is `dzhanibekov_rates` at {RATE:g} Hz; the local cluster is '
        'started and closed within its time, as a campaign does.'
    )
    for where, title in (
        (
            'api',
            'In this process (`run_campaign`, kernels loaded beforehand, no output directory):',
        ),
        (
            'cli',
            'From the command line in a fresh process (`torquefree_campaign run FILE --output '
            'DIR`, end to end: the interpreter, imports, the campaign and its files):',
        ),
    ):
        report.add('')
        report.add(title)
        report.add('')
        report.add('| campaign | in-process | local cluster | default | the default picked |')
        report.add('|---|---|---|---|---|')
        for runs, duration in SWITCH_CASES:
            samples = load_campaign(dict(torque_free_campaign(runs), duration=duration)).samples

            def cell(engine, runs=runs, duration=duration):
                values = [r[(where, runs, duration, engine)] for r in rounds]
                speeds = spread([runs / value for value in values])
                return f'{spread(values)} s ({speeds} runs/s)'

            picked = {r[(f'{where}-picked', runs, duration)] for r in rounds}
            report.add(
                f'| {runs:,} runs of {samples:,} samples | {cell("in-process")} | '
                f'{cell("local")} | {cell("default")} | {"; ".join(sorted(picked))} |'
            )
    report.add('')
    report.add(
        "A local cluster's start-up, its workers' first imports and kernels and its close, "
        'measured (a campaign of two one-run chunks on a local cluster, less the same in this '
        f'process): {spread([r["cluster_overhead"] for r in rounds])} s, beside '
        f'`engine.LOCAL_CLUSTER_STARTUP` = {startup:g} s.'
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--output', help='write the report here (Markdown)')
    parser.add_argument('--rounds', type=int, default=3)
    parser.add_argument(
        '--switch-only',
        action='store_true',
        help="measure the default engine's switch alone (both sides of it)",
    )
    parser.add_argument(
        '--only',
        choices=('detumble',),
        help='measure one part alone: detumble, the closed-loop bdot_detumble campaign',
    )
    args = parser.parse_args(argv)

    import dask
    import distributed
    import numba
    import numpy
    import pyarrow
    from torquefree_ros.campaigns import load_campaign

    allocator = use_the_workers_allocator()
    report = Report(
        "Monte Carlo campaigns: the machinery's cost and its scaling", 'make bench-campaign'
    )
    report.add(
        f'- versions: numpy {numpy.__version__}, numba {numba.__version__}, '
        f'dask {dask.__version__}, distributed {distributed.__version__}, '
        f'pyarrow {pyarrow.__version__}'
    )
    report.add('')
    campaign = load_campaign(torque_free_campaign())
    report.add(
        "- this process's allocator: "
        + (
            "glibc's thresholds set as the workers' (`engine.MALLOC_ENVIRONMENT`)"
            if allocator
            else "glibc's defaults (mallopt unavailable)"
        )
    )
    load = ' '.join(f'{x:.2f}' for x in os.getloadavg())
    report.add(f'- load average when it started: {load} (the cores are shared)')
    report.add('')
    rounds_line = (
        f'{args.rounds} round{"s" if args.rounds != 1 else ""}; each figure is the median '
        '(min–max) over the rounds (wall time unless it says CPU)'
    )
    if args.only == 'detumble':
        from torquefree_ros.campaigns import load_campaign as load

        detumble = load('bdot_detumble')
        bare = detumble_bare(detumble, DETUMBLE_BARE_RUNS)
        report_detumble(report, bare, detumble_campaign_timed())
        report.save(args.output)
        return 0
    if args.switch_only:
        report.add(rounds_line + '.')
        with tempfile.TemporaryDirectory(prefix='bench_campaign_') as temporary:
            switches = [switch_round(Path(temporary)) for _ in range(args.rounds)]
        report_switch(report, switches)
        report.save(args.output)
        return 0
    report.add(
        rounds_line + ', the ratios taken within each round. Torque-free: `dzhanibekov_rates` '
        f'with {RUNS:,} runs of {DURATION:g} s at '
        f'{RATE:g} Hz ({campaign.samples:,} samples a run; metrics '
        f'{", ".join(use.metric.name for use in campaign.metrics)}), written to a directory '
        '(part files, then `runs.parquet`) on a local cluster started and warmed before the '
        'timing, the only one running (each is closed after its measurement).'
    )
    report.add('')

    clusters, start_up = {}, {}
    with tempfile.TemporaryDirectory(prefix='bench_campaign_') as temporary:
        directory = Path(temporary)
        try:
            rounds = [measure_round(directory) for _ in range(args.rounds)]
            switches = [switch_round(directory) for _ in range(args.rounds)]
            memory = rounds[-1]['memory']
            for workers in (1, 2):
                cluster, client, up, first = start_cluster(workers)
                clusters[workers] = (cluster, client)
                start_up[workers] = (up, first)
            costs = engine_costs(clusters, directory)
        finally:
            for cluster, client in clusters.values():
                client.close()
                cluster.close()
    detumble = load_campaign('bdot_detumble')
    detumble_bare_compute = detumble_bare(detumble, DETUMBLE_BARE_RUNS)
    detumble_timed = detumble_campaign_timed()

    def column(key, scale=1.0):
        return spread([scale * r[key] for r in rounds])

    def median(key):
        return statistics.median(r[key] for r in rounds)

    def runs_per_second(key):
        return spread([RUNS / r[key] for r in rounds])

    ratio, speedup, explorer = median('ratio_1'), median('speedup_2'), median('explorer')
    report.add('| measure | value | target (issue 32) | met |')
    report.add('|---|---|---|---|')
    report.add(
        f'| bare compute: `propagate_batch` + metrics, {RUNS:,} runs, one process | '
        f'{column("bare")} s ({runs_per_second("bare")} runs/s; CPU {column("bare_cpu")} s) | | |'
    )
    report.add(
        f'| campaign, 1 local worker | {column("workers_1")} s ({runs_per_second("workers_1")} '
        f'runs/s), {column("ratio_1")} of the bare compute (CPU, workers and this process: '
        f"{column('workers_1_cpu')} s, {column('ratio_1_cpu')} of the bare compute's) | ≤ 1.3x | "
        f'{"yes" if ratio <= 1.3 else "**no**"} |'
    )
    report.add(
        f'| campaign, 2 local workers | {column("workers_2")} s ({runs_per_second("workers_2")} '
        f'runs/s), {column("speedup_2")} the runs/s of 1 worker '
        f'(CPU {column("workers_2_cpu")} s) | ≥ 1.8x | '
        f'{"yes" if speedup >= 1.8 else "**no**"} |'
    )
    report.add(
        '| 1,000 dispersed explorer1 runs, 900 s at 1 Hz, 2 local workers, end to end '
        f'(cluster start and close included) | {column("explorer")} s | ≤ 30 s | '
        f'{"yes" if explorer <= 30 else "**no**"} |'
    )
    report.add('')
    report.add(
        f'For reference, the field: {BASILISK}. Here the 2-worker campaign runs '
        f'{RUNS / median("workers_2"):,.0f} runs/s of 1 001 samples each.'
    )
    report.add('')
    report.add(
        'Where the time of the torque-free campaign goes (this process unless it says workers; '
        "on 2 workers this process's CPU (the client's results, the part files, the table) shares "
        'the 2 cores with them):'
    )
    report.add('')
    report.add('| stage | time |')
    report.add('|---|---|')
    report.add(f'| the bare compute | {column("bare")} s |')
    report.add(
        f"| drawing the {RUNS:,} runs' inputs (a generator per run, the body checked) | "
        f'{column("draws")} s |'
    )
    report.add(
        '| the campaign in this process (draws, chunks, metrics, table) | '
        f'{column("in_process")} s |'
    )
    report.add(
        '| the same, written to a directory (part files, `runs.parquet`) | '
        f'{column("in_process_output")} s |'
    )
    report.add(
        f'| the same on 1 warm local worker | {column("workers_1")} s (CPU: this process '
        f'{column("workers_1_driver")} s, all {column("workers_1_cpu")} s) |'
    )
    report.add(
        f'| the same on 2 warm local workers | {column("workers_2")} s (CPU: this process '
        f'{column("workers_2_driver")} s, all {column("workers_2_cpu")} s) |'
    )
    cores = os.cpu_count() or 1
    if cores <= 2:
        # from CPU times alone, which other processes on the machine do not change: 1 worker at
        # best takes its own CPU (this process runs beside it on the other core); 2 workers at best
        # all the CPU over the cores, this process's included
        bound = statistics.median(
            (r['workers_1_cpu'] - r['workers_1_driver']) / (r['workers_2_cpu'] / cores)
            for r in rounds
        )
        report.add('')
        report.add(
            f'With {cores} cores this process (the client: results, part files, table) shares '
            'them with the 2 workers. From the CPU times alone, which other processes do not '
            f'change, the best 2-worker speed-up this machine allows is {bound:.3g}x: 1 worker at '
            'best takes its own CPU (this process beside it on the other core), 2 workers at best '
            f"all the CPU, this process's included, over {cores} cores."
        )
    report.add('')
    report.add('What the engine costs:')
    report.add('')
    report.add('| cost | value |')
    report.add('|---|---|')
    for workers, (up, first) in start_up.items():
        report.add(
            f'| a local cluster of {workers} worker{"s" if workers > 1 else ""}: start-up '
            f'(workers connected) | {up:.2f} s |'
        )
        report.add(
            f'| its first campaign ({workers} one-run chunks: imports and kernels loaded in each '
            f'worker) | {first:.2f} s |'
        )
    report.add(
        f'| a chunk in this process (one run of one sample, {OVERHEAD_TASKS} chunks) | '
        f'{costs["chunk_in_process_ms"]:.2f} ms |'
    )
    report.add(f"| writing a chunk's part file | {costs['part_file_ms']:.2f} ms |")
    report.add(
        '| a chunk on a warm local worker as a Dask task of its own, beyond its cost in this '
        f'process | {costs["chunk_dask_ms"]:.2f} ms |'
    )
    report.add(
        f'| the same, {OVERHEAD_TASKS} chunks grouped in {costs["grouped_tasks"]} tasks as the '
        f'engine does (`engine.tasks`), per chunk | {costs["chunk_grouped_ms"]:.2f} ms |'
    )
    for index, (rss, peak) in enumerate(memory):
        report.add(
            f'| worker {index} of 2 after a campaign: RSS (peak) | '
            f'{rss:.0f} MiB ({peak:.0f} MiB) |'
        )
    report_switch(report, switches)
    report_detumble(report, detumble_bare_compute, detumble_timed)
    report.save(args.output)
    return 0


# the local cluster's workers are spawned processes that import this module
if __name__ == '__main__':
    sys.exit(main())
