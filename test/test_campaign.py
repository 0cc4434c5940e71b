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
Monte Carlo campaigns (issue 32).

The campaign file's checks, the draws, the metrics against known answers, and the engine's one
promise: the same table, bit for bit, in-process, on Dask workers (a LocalCluster, and a scheduler
and workers started as separate processes) and with any chunking.

Every Dask cluster here listens on 127.0.0.1 only and is closed by the test or fixture that made
it.
"""

import collections
import contextlib
import math
import os
from pathlib import Path
import signal
import subprocess
import sys
import threading

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from torquefree_ros import propagate_batch, RigidBody
from torquefree_ros.campaigns import (
    CampaignError,
    library_campaigns,
    load_campaign,
    metric,
    METRICS,
    run_campaign,
)
from torquefree_ros.campaigns.dispersions import run_generator
from torquefree_ros.campaigns.metrics import Samples
from torquefree_ros.cli import campaign as campaign_cli
import yaml

VENV_BIN = Path(sys.executable).parent


# -- helpers --------------------------------------------------------------------------------------
def assert_same_table(a: pa.Table, b: pa.Table) -> None:
    """Bit for bit: the same columns, nulls, bytes of every float (NaN included) and metadata."""
    assert a.schema.equals(b.schema, check_metadata=True)
    assert a.num_rows == b.num_rows
    for name in a.column_names:
        x, y = a.column(name).combine_chunks(), b.column(name).combine_chunks()
        assert x.is_null().equals(y.is_null()), name
        if pa.types.is_floating(x.type):
            xs = x.fill_null(0.0).to_numpy(zero_copy_only=False).view(np.int64)
            ys = y.fill_null(0.0).to_numpy(zero_copy_only=False).view(np.int64)
            assert np.array_equal(xs, ys), name
        else:
            assert x.to_pylist() == y.to_pylist(), name


def torque_free_campaign(runs=600):
    """
    Return a torque-free campaign with every metric.

    A triaxial body near its limit (redraws happen), rates and attitude dispersed.
    """
    return {
        'scene': 'default',
        'runs': runs,
        'seed': 32,
        'duration': 12.0,
        'rate': 5.0,
        'dispersions': {
            'body.moments': {'relative': {'normal': {'sigma': 0.03}}},
            'initial.angular_velocity': [
                {'absolute': {'uniform': {'low': -0.1, 'high': 0.1}}},
                {'replace': {'values': [0.0, 0.2, 0.4]}},
                None,
            ],
            'initial.orientation': {'small_rotation': {'sigma': 0.02}},
        },
        'metrics': [
            'final_rates',
            {'settle_time': {'threshold': 1.2}},
            'cone_angle',
            'flips',
            'energy_drift',
            'momentum_drift',
            'nominal_attitude_error',
        ],
    }


def damper_campaign(runs=60):
    """
    Return a campaign of explorer1 through the batched Plant, in which some runs fail.

    A damping dispersion so wide that some runs draw a negative coefficient, which the scene
    refuses: those rows fail with the reason, the others run.
    """
    return {
        'scene': 'explorer1',
        'runs': runs,
        'seed': 7,
        'duration': 30.0,
        'rate': 1.0,
        'dispersions': {
            'effects[0].damper.damping': {'relative': {'normal': {'sigma': 1.0}}},
            'initial.angular_velocity': {'absolute': {'normal': {'sigma': 0.05}}},
        },
        'metrics': ['final_rates', 'cone_angle', 'energy_drift', 'nominal_attitude_error'],
    }


@pytest.fixture(scope='module')
def cluster():
    """Two worker processes on loopback, started once for the module."""
    from torquefree_ros.campaigns.engine import local_cluster

    with np.errstate(all='ignore'):  # the module-scoped fixture runs outside the per-test errstate
        local = local_cluster(2)
    try:
        yield local
    finally:
        local.close()


# -- the engine: the same table everywhere --------------------------------------------------------
def test_same_table_in_process_on_two_workers_and_with_other_chunks(cluster):
    reference = run_campaign(torque_free_campaign(), scheduler='in-process')
    # torque_free_campaign's 600 runs, none failing (impossible bodies are redrawn)
    assert reference.num_rows == 600 and set(reference.column('status').to_pylist()) == {'ok'}
    assert max(reference.column('redraws').to_pylist()) > 0  # the dispersion does reach the limit
    assert_same_table(
        reference, run_campaign(torque_free_campaign(), scheduler='in-process', chunk_size=7)
    )
    on_workers = run_campaign(
        torque_free_campaign(), scheduler=cluster.scheduler_address, chunk_size=64
    )
    assert_same_table(reference, on_workers)


def test_a_scene_with_effects_gives_the_same_table_on_workers_and_failed_runs_are_rows(cluster):
    reference = run_campaign(damper_campaign(), scheduler='in-process')
    status = reference.column('status').to_pylist()
    failed = [i for i, s in enumerate(status) if s != 'ok']
    assert 0 < len(failed) < len(status)
    for i in failed:  # the scene's own check, with the field path, and no metric for that run
        assert status[i] == 'invalid_scene'
        assert (
            reference.column('reason')[i]
            .as_py()
            .startswith('effects[0].damper.damping: must be > 0')
        )
        assert reference.column('effects[0].damper.damping')[i].as_py() <= 0
        assert not reference.column('final_wx')[i].is_valid
    assert_same_table(
        reference, run_campaign(damper_campaign(), scheduler='in-process', chunk_size=11)
    )
    assert_same_table(
        reference,
        run_campaign(damper_campaign(), scheduler=cluster.scheduler_address, chunk_size=8),
    )


def test_blocks_inside_a_chunk_change_nothing(monkeypatch):
    """
    Blocks of a few runs, failed runs among them, give the same table as one block a chunk.

    A chunk propagates and measures its runs a block at a time (engine.BLOCK_SAMPLES).
    """
    from torquefree_ros.campaigns import engine

    references = [
        run_campaign(make(), scheduler='in-process')
        for make in (torque_free_campaign, damper_campaign)
    ]
    # one block a chunk above: 12 s at 5 Hz is 61 samples a run, 65 536 // 61 = 1 074 runs a block
    assert engine.block_runs(load_campaign(torque_free_campaign())) >= 600
    monkeypatch.setattr(engine, 'BLOCK_SAMPLES', 3 * 61)
    assert engine.block_runs(load_campaign(torque_free_campaign())) == 3
    for make, reference in zip((torque_free_campaign, damper_campaign), references):
        assert_same_table(reference, run_campaign(make(), scheduler='in-process', chunk_size=64))


def test_dask_tasks_group_consecutive_chunks_by_the_number_of_workers():
    """
    Every chunk goes in one task, in run order; fewer tasks than chunks, smaller near the end.

    At most 1 / (TASKS_PER_WORKER * workers) of the chunks a task; a task a chunk without workers.
    """
    from torquefree_ros.campaigns.engine import TASKS_PER_WORKER, tasks

    for chunks in (1, 2, 7, 16, 40, 400):
        parts = [(10 * i, 10 * i + 10) for i in range(chunks)]
        assert tasks(parts, 0) == [[part] for part in parts]
        for workers in (1, 2, 3, 8):
            groups = tasks(parts, workers)
            assert [part for group in groups for part in group] == parts
            largest = max(1, chunks // (TASKS_PER_WORKER * workers))
            sizes = [len(group) for group in groups]
            assert all(1 <= size <= largest for size in sizes), (chunks, workers, sizes)
            assert sizes == sorted(sizes, reverse=True) and sizes[-1] == 1
    sizes = [len(group) for group in tasks([(i, i + 1) for i in range(40)], 2)]
    # at most 40 // (4 * 2) = 5 a task, and ceil(left / (2 * 2)): 40, 35, 30, 25, 20 chunks left
    # give 5; 15 -> 4, 11 -> 3, 8 -> 2, 6 -> 2, then 4, 3, 2, 1 -> 1
    assert sizes == [5, 5, 5, 5, 5, 4, 3, 2, 2, 1, 1, 1, 1]


def test_choose_engine_picks_the_engine_that_finishes_first_and_says_why():
    """
    This process takes the compute C; a local cluster of W workers its start-up S, then C / W.

    The cluster wins when C > S + C / W, that is C > S W / (W - 1); a tie stays in this process,
    and a cluster of 1 worker never wins.
    """
    from torquefree_ros.campaigns.engine import choose_engine

    choice = choose_engine(0.46, 3.0, 2)
    assert (choice.engine, choice.workers, choice.label) == ('in-process', None, 'in-process')
    # 3 + 0.46 / 2 = 3.23 s on the cluster
    assert choice.reason == (
        'about 0.46 s of compute left, against 3.2 s on a local cluster of 2 workers '
        '(3 s to start and close, then 0.23 s)'
    )
    assert str(choice) == f'in-process: {choice.reason}'
    choice = choose_engine(40.0, 3.0, 2)  # 3 + 40 / 2 = 23 s
    assert (choice.engine, choice.workers) == ('local', 2)
    assert str(choice) == (
        'local cluster of 2 workers: about 40 s of compute left, against 23 s on a local '
        'cluster of 2 workers (3 s to start and close, then 20 s)'
    )
    for startup, workers in ((3.0, 2), (3.0, 4), (0.5, 8)):
        even = startup * workers / (workers - 1)  # C = S + C / W
        assert choose_engine(even, startup, workers).engine == 'in-process'
        assert choose_engine(even * 1.001, startup, workers).engine == 'local'
        assert choose_engine(even * 0.999, startup, workers).engine == 'in-process'
    alone = choose_engine(1e6, 3.0, 1)
    assert alone.engine == 'in-process' and alone.reason == (
        'a local cluster of 1 worker is never faster than this process'
    )


def no_local_cluster(monkeypatch):
    """Make starting a local cluster fail the test: the engine must not start one."""
    from torquefree_ros.campaigns import engine

    def refuse(workers):
        raise AssertionError(f'a local cluster of {workers} workers was started')

    monkeypatch.setattr(engine, 'local_cluster', refuse)


def test_a_tiny_campaign_with_the_default_engine_runs_in_process(monkeypatch):
    """
    What ``torquefree_campaign run`` does for a small campaign: it stays in this process.

    600 runs of 61 samples in chunks of 100: every chunk is computed here, no cluster is started,
    and the engine reported is this process, with its reason: the first chunk's time per run over
    the 500 runs left, against the cluster's start-up (a first chunk that also loads the kernels
    is confirmed by a second).
    """
    reference = run_campaign(torque_free_campaign(), scheduler='in-process')
    no_local_cluster(monkeypatch)
    computed, choices = computed_chunks(monkeypatch), []
    table = run_campaign(torque_free_campaign(), chunk_size=100, on_engine=choices.append)
    assert_same_table(reference, table)
    assert computed == [(start, start + 100) for start in range(0, 600, 100)]
    (choice,) = choices
    assert choice.engine == 'in-process' and choice.reason.startswith('about ')
    assert f'on a local cluster of {os.cpu_count()} workers' in choice.reason
    one = []  # a campaign of one chunk has nothing to share
    run_campaign(torque_free_campaign(40), chunk_size=100, on_engine=one.append)
    assert [(c.engine, c.reason) for c in one] == [('in-process', 'one chunk to compute')]


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason='one core: a cluster is never faster')
def test_the_default_engine_sends_what_outweighs_the_start_up_to_a_local_cluster(monkeypatch):
    """
    When the rest outweighs the cluster's start-up, the default engine is a worker per core.

    With no start-up to weigh, any compute goes to the cluster: the first chunk is timed here, a
    second confirms it, and the other chunks run on a local cluster of a worker per core (none
    computed in this process), giving the in-process table bit for bit.
    """
    from torquefree_ros.campaigns import engine

    reference = run_campaign(torque_free_campaign(), scheduler='in-process')
    started, real = [], engine.local_cluster
    monkeypatch.setattr(engine, 'LOCAL_CLUSTER_STARTUP', 0.0)
    monkeypatch.setattr(
        engine, 'local_cluster', lambda workers: (started.append(workers), real(workers))[1]
    )
    computed, choices = computed_chunks(monkeypatch), []
    table = run_campaign(torque_free_campaign(), chunk_size=100, on_engine=choices.append)
    assert_same_table(reference, table)
    assert computed == [(0, 100), (100, 200)] and started == [os.cpu_count()]
    (choice,) = choices
    assert (choice.engine, choice.workers) == ('local', os.cpu_count())
    cluster = f'on a local cluster of {os.cpu_count()} workers (0 s to start and close'
    assert cluster in choice.reason


def test_the_default_chunk_grows_with_the_runs_per_worker_within_its_bounds():
    """
    256 runs a chunk, more (up to 1024) while every worker still gets 8 chunks; memory caps it.

    The workers are known beforehand in-process (1), for a local cluster (``workers`` or a core
    each) and for a Client (its threads); not for an address. A bad ``workers`` says so.
    """
    from types import SimpleNamespace

    from torquefree_ros.campaigns.engine import chunk_runs, expected_workers

    def campaign(runs, samples=1001):
        return SimpleNamespace(runs=runs, samples=samples, steps_plant=False)

    assert chunk_runs(campaign(10_000)) == 256  # workers unknown
    assert chunk_runs(campaign(10_000), None, 2) == 625  # 10 000 / (8 * 2): 16 chunks, 8 a worker
    assert chunk_runs(campaign(10_000), None, 1) == 1024  # 10 000 / 8 = 1 250, capped
    assert chunk_runs(campaign(10_000), None, 8) == 256  # 10 000 / 64 = 157, raised to 256
    assert chunk_runs(campaign(1_000), None, 2) == 256  # 1 000 / 16 = 63, raised to 256
    # 128 MiB of samples: 2**27 // (100 001 samples * 15 numbers * 8 bytes) = 11 runs
    assert chunk_runs(campaign(10_000, samples=100_001), None, 2) == 11
    assert chunk_runs(campaign(10_000), 7, 2) == 7
    # a plant stepped with a controller: at most STEPPED_CHUNK_BODY_STEPS body-steps a chunk;
    # 1 000 000 // (1 702 * 10 + 1) plant samples = 58 runs (the library's bdot_detumble)
    assert chunk_runs(load_campaign('bdot_detumble'), None, 2) == 58
    assert expected_workers('in-process', None) == 1
    assert expected_workers('local', 3) == 3
    assert expected_workers(None, None) == (os.cpu_count() or 1)
    assert expected_workers('tcp://127.0.0.1:8786', None) is None
    client = SimpleNamespace(nthreads=lambda: {'tcp://a': 1, 'tcp://b': 2})
    assert expected_workers(client, None) == 3
    for bad in (0, -1, True, 'two', 2.0):
        with pytest.raises(ValueError, match='workers: expected a positive integer'):
            expected_workers('local', bad)


def test_chunks_grouped_in_tasks_give_the_same_table_parts_and_progress(cluster, tmp_path):
    """
    Many chunks on 2 workers go in fewer tasks; the table and each chunk's part and progress stay.

    The table is the in-process one bit for bit, ``progress`` is called once per chunk (the runs
    done growing by the chunk size), and an interrupted campaign keeps a part per finished chunk.
    """
    from torquefree_ros.campaigns.engine import chunks, tasks

    reference = run_campaign(torque_free_campaign(), scheduler='in-process')
    campaign = load_campaign(torque_free_campaign())
    assert len(tasks(chunks(campaign, 8), 2)) < len(chunks(campaign, 8)) == 600 // 8
    progress = []
    table = run_campaign(
        torque_free_campaign(),
        scheduler=cluster.scheduler_address,
        output=tmp_path / 'whole',
        chunk_size=8,
        progress=lambda done, total: progress.append(done),
    )
    assert_same_table(reference, table)
    assert_same_table(reference, pq.read_table(tmp_path / 'whole' / 'runs.parquet'))
    assert progress[0] == 0 and progress[-1] == 600 and len(progress) == 1 + 600 // 8
    assert np.all(np.diff(progress) == 8)
    output = tmp_path / 'interrupted'
    with pytest.raises(Interrupted):
        run_campaign(
            torque_free_campaign(),
            scheduler=cluster.scheduler_address,
            output=output,
            chunk_size=8,
            progress=interrupt_after(200),
        )
    names = [p.name for p in (output / 'parts').glob('runs-*.parquet')]
    assert names and all(int(n[15:24]) - int(n[5:14]) == 8 for n in names)
    assert_same_table(
        reference,
        run_campaign(
            torque_free_campaign(),
            scheduler=cluster.scheduler_address,
            output=output,
            chunk_size=50,
            resume=True,
        ),
    )


@contextlib.contextmanager
def dask_processes(workers: list):
    """
    Start ``dask scheduler`` and one ``dask worker`` process per argument list in ``workers``.

    What a cluster looks like, all on loopback; yields ``(address, worker processes)``. The
    scheduler's address is read from its log as it starts listening (its log is then drained, so
    that it never blocks on a full pipe). Every process is ended by its pid.
    """
    from distributed import Client

    environment = dict(os.environ, DASK_DISTRIBUTED__WORKER__DAEMON='False')
    scheduler, started = None, []
    try:
        scheduler = subprocess.Popen(
            [
                str(VENV_BIN / 'dask'),
                'scheduler',
                '--host',
                '127.0.0.1',
                '--port',
                '0',
                '--no-dashboard',
                '--dashboard-address',
                '127.0.0.1:0',
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            env=environment,
        )
        address = None
        for line in scheduler.stderr:  # its log, until it says where it listens
            if 'Scheduler at:' in line:
                address = line.split('Scheduler at:', 1)[1].strip()
                break
        assert address, 'the scheduler ended before it listened'
        # the rest of its log is read and dropped (a deque of length 0 consumes an iterator)
        threading.Thread(target=collections.deque, args=(scheduler.stderr, 0), daemon=True).start()
        for arguments in workers:
            started.append(
                subprocess.Popen(
                    [
                        str(VENV_BIN / 'dask'),
                        'worker',
                        address,
                        '--host',
                        '127.0.0.1',
                        '--nthreads',
                        '1',
                        '--no-dashboard',
                        *arguments,
                    ],
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                    env=environment,
                )
            )
        expected = sum(
            int(a[a.index('--nworkers') + 1]) if '--nworkers' in a else 1 for a in workers
        )
        with Client(address, timeout='60s') as client:
            client.wait_for_workers(expected, timeout=60)
        yield address, started
    # the workers first: a worker whose scheduler is gone may spend its timeout reconnecting
    finally:
        for group in (started, [scheduler] if scheduler else []):
            for process in group:
                if process.poll() is None:
                    process.terminate()
            for process in group:
                try:
                    process.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait()


def test_a_scheduler_and_workers_started_as_separate_processes_are_used_by_address():
    """
    The campaign pointed at a scheduler's address gives the in-process table.

    The workers run under a nanny, as ``dask worker`` starts them; the campaign reports the
    cluster it ran on.
    """
    choices = []
    with dask_processes([['--nworkers', '2']]) as (address, _):
        table = run_campaign(
            torque_free_campaign(300), scheduler=address, chunk_size=50, on_engine=choices.append
        )
    assert_same_table(run_campaign(torque_free_campaign(300), scheduler='in-process'), table)
    (choice,) = choices
    assert (choice.engine, choice.workers) == ('cluster', 2)
    assert str(choice) == f'cluster of 2 workers: as asked ({address})'


def test_a_worker_killed_mid_campaign_changes_nothing_in_the_table(tmp_path):
    """
    A worker killed while it computes a chunk mid-campaign changes nothing in the table.

    Two workers without nannies (each its own process). A worker plugin kills (SIGKILL) the worker
    process that starts computing the middle task of the campaign, the moment it starts it (the
    event itself, whatever the load on the machine), once: the scheduler gives that task, and
    whatever else the dead worker held, to the other. Every chunk arrives once, and the table is
    the in-process one bit for bit.
    """
    from distributed import Client
    from distributed.diagnostics.plugin import WorkerPlugin
    from torquefree_ros.campaigns.engine import chunks, tasks

    runs, size = 1024, 64
    data = torque_free_campaign(runs)
    data.update(duration=100.0, rate=10.0)
    reference = run_campaign(data, scheduler='in-process')
    groups = tasks(chunks(load_campaign(data), size), 2)
    middle = groups[len(groups) // 2][0][0]  # the first run of the middle task
    assert 0 < middle < runs
    # a task's key ends with its first run, zero-padded (engine._on_dask)
    suffix, marker = f'-{middle:09d}', tmp_path / 'killed'

    class KillTheWorkerThatStartsIt(WorkerPlugin):
        """On the first worker to start the middle task: note its pid, then SIGKILL it."""

        def transition(self, key, start, finish, **kwargs):
            if finish != 'executing' or not str(key).endswith(suffix):
                return
            try:  # once: the task run again elsewhere finds the marker
                handle = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            except FileExistsError:
                return
            os.write(handle, str(os.getpid()).encode())
            os.close(handle)
            os.kill(os.getpid(), signal.SIGKILL)

    with dask_processes([['--no-nanny'], ['--no-nanny']]) as (address, workers):
        pids = {process.pid: process for process in workers}
        calls = []
        with Client(address, timeout='30s') as observer:
            observer.register_plugin(KillTheWorkerThatStartsIt(), name='kill-mid-campaign')
            table = run_campaign(
                data,
                scheduler=address,
                chunk_size=size,
                progress=lambda done, total: calls.append(done),
            )
            survivors = observer.run_on_scheduler(
                lambda dask_scheduler: sorted(ws.pid for ws in dask_scheduler.workers.values())
            )
        pid = int(marker.read_text())
        assert pid in pids and pids[pid].wait(timeout=10) == -signal.SIGKILL
        assert survivors == sorted(set(pids) - {pid})  # the scheduler saw it go
    # every chunk once, none twice: the first call, then one a chunk
    assert calls[0] == 0 and calls[-1] == runs and len(calls) == 1 + runs // size
    assert np.all(np.diff(calls) == size)
    assert_same_table(reference, table)


def test_a_run_draws_from_its_own_seed_only():
    """
    Run i's inputs depend on (seed, i) only.

    The first runs of a longer campaign are the shorter one's, and run i's generator is
    SeedSequence(seed).spawn(runs)[i]'s.
    """
    short = run_campaign(torque_free_campaign(20), scheduler='in-process')
    long = run_campaign(torque_free_campaign(60), scheduler='in-process').slice(0, 20)
    for name in short.column_names:
        assert short.column(name).to_pylist() == long.column(name).to_pylist()
    spawned = np.random.SeedSequence(32).spawn(60)[17]
    assert run_generator(32, 17).random() == np.random.Generator(np.random.PCG64(spawned)).random()


def test_the_inputs_in_the_table_reproduce_each_run():
    """
    The drawn inputs are what ran.

    Propagating a row's body and initial state again gives its final rates.
    """
    table = run_campaign(torque_free_campaign(40), scheduler='in-process').to_pydict()
    moments = np.array([[table[f'body.moments[{k}]'][i] for k in range(3)] for i in range(40)])
    omega0 = np.array(
        [[table[f'initial.angular_velocity[{k}]'][i] for k in range(3)] for i in range(40)]
    )
    q0 = np.array([[table[f'initial.orientation[{k}]'][i] for k in range(4)] for i in range(40)])
    # the sweep: values[i % 3]
    assert omega0[:, 1].tolist() == [[0.0, 0.2, 0.4][i % 3] for i in range(40)]
    assert np.all(np.abs(omega0[:, 2] - 1.0) == 0)  # not dispersed: the scene's own
    omega, _ = propagate_batch(moments, omega0, q0, np.arange(61) / 5.0)
    assert np.array_equal(omega[:, -1, 0], table['final_wx']) and np.array_equal(
        omega[:, -1, 2], table['final_wz']
    )


# -- impossible bodies ----------------------------------------------------------------------------
def limit_body(invalid_body, tmp_path):
    scene = tmp_path / 'flat.yaml'
    scene.write_text(
        'body: {inertia: [3.0, 2.0, 1.0]}\ninitial: {angular_velocity: [0.1, 1.0, 0.1]}\n'
    )
    return {
        'scene': str(scene),
        'runs': 400,
        'seed': 3,
        'duration': 1.0,
        'rate': 2.0,
        'invalid_body': invalid_body,
        'dispersions': {'body.moments': {'relative': {'normal': {'sigma': 0.02}}}},
        'metrics': ['final_rates'],
    }


def test_a_nominal_body_on_the_triangle_limit_redraws_or_fails_as_the_file_says(tmp_path):
    """
    A nominal body on the triangle limit redraws or fails as the campaign file says.

    [3, 2, 1] is a flat plate: about half the draws of independent moments are no body at all.
    With moments 3 (1 + a), 2 (1 + b), 1 (1 + c), a, b, c ~ N(0, 0.02^2), the body is physical when
    2 b + c - 3 a >= 0, a normal of mean 0: half the draws. Over 400 runs the share's standard
    error is 2.5 %, so [0.4, 0.6] is 4 of them either side.
    """
    campaign = load_campaign(limit_body('fail', tmp_path))
    # measured when loaded (its first 400 runs, all of them here), kept in the metadata
    assert 0.4 < campaign.body_acceptance < 0.6
    failing = run_campaign(campaign, scheduler='in-process').to_pydict()
    bad = [i for i, s in enumerate(failing['status']) if s != 'ok']
    assert 0.4 < len(bad) / 400 < 0.6 and {failing['status'][i] for i in bad} == {'invalid_body'}
    assert all('triangle inequality' in failing['reason'][i] for i in bad)
    assert all(failing['final_wx'][i] is None for i in bad)
    redrawn = run_campaign(limit_body('redraw', tmp_path), scheduler='in-process').to_pydict()
    assert set(redrawn['status']) == {'ok'} and max(redrawn['redraws']) > 0
    m = np.array([[redrawn[f'body.moments[{k}]'][i] for k in range(3)] for i in range(400)])
    # every kept body is physical
    assert np.all(m.max(axis=1) <= (m.sum(axis=1) - m.max(axis=1)) * (1 + 1e-9))
    # a run that drew a physical body first is the same run either way (the body draws last)
    for i in range(400):
        if failing['status'][i] == 'ok':
            assert failing['body.moments[0]'][i] == redrawn['body.moments[0]'][i]


def test_a_run_that_runs_out_of_redraws_fails_with_the_count(tmp_path):
    data = limit_body('redraw', tmp_path)
    data['max_redraws'] = 0
    table = run_campaign(data, scheduler='in-process').to_pydict()
    reasons = [r for r in table['reason'] if r]
    assert reasons and all(r.endswith('(after 0 redraws)') for r in reasons)


# -- effects' numbers and vectors, vectors as a whole ---------------------------------------------
TORQUE = [0.01, -0.02, 0.015]  # effects[0]: a constant body-frame torque, N m
# effects[1]: a schedule, (start s, torque N m) a segment
SCHEDULE = [(0.0, [0.1, 0.0, 0.0]), (1.0, [0.0, 0.2, 0.0]), (2.0, [0.0, 0.0, -0.3])]


def torque_scene(tmp_path) -> Path:
    """
    Write a sphere (I = 1) at rest under body-frame torques: a constant one and a schedule.

    For a sphere w x I w = 0, so w' = the torques: a rate is their integral, in closed form.
    """
    scene = tmp_path / 'torques.yaml'
    scene.write_text(
        yaml.safe_dump(
            {
                'body': {'inertia': [1.0, 1.0, 1.0]},
                'initial': {'angular_velocity': [0.0, 0.0, 0.0]},
                'accuracy': 1e-10,
                'effects': [
                    {'external_torque': {'torque': TORQUE}},
                    {
                        'external_torque': {
                            'schedule': [
                                {'start': start, 'torque': torque} for start, torque in SCHEDULE
                            ]
                        }
                    },
                ],
            }
        )
    )
    return scene


def torque_campaign(tmp_path, runs, dispersions, duration=3.0):
    return {
        'scene': str(torque_scene(tmp_path)),
        'runs': runs,
        'seed': 39,
        'duration': duration,
        'rate': 2.0,
        'dispersions': dispersions,
        'metrics': ['final_rates'],
    }


def drawn(data, path: str) -> np.ndarray:
    """Every run's drawn value of ``path`` (the draws alone: no run is propagated)."""
    from torquefree_ros.campaigns import engine

    campaign = load_campaign(data)
    return np.array([engine.draw_run(campaign, run).values[path] for run in range(campaign.runs)])


# the statistical checks: a Kolmogorov-Smirnov test at the 0.1 % level, which a correct sampler
# fails for 1 seed in 1000; the seeds are fixed, so each check gives the same answer every time
KS_LEVEL = 1e-3
DRAWS = 4000


def angles_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles between rows of ``a`` and ``b`` (atan2 of |a x b| and a . b: exact near 0 too)."""
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))


def test_an_effect_vector_per_component_and_by_magnitude_draws_its_distributions(tmp_path):
    """
    A schedule item's torque per component, and the constant torque's magnitude, as a whole.

    Per component: x absolute normal (sigma 0.01 N m), y kept, z relative uniform [-0.1, 0.2]. As
    a whole: |torque| relative normal (sigma 0.1), the direction kept to rounding.
    """
    from scipy import stats

    item = 'effects[1].external_torque.schedule[2].torque'
    whole = 'effects[0].external_torque.torque'
    data = torque_campaign(
        tmp_path,
        DRAWS,
        {
            item: [
                {'absolute': {'normal': {'sigma': 0.01}}},
                None,
                {'relative': {'uniform': {'low': -0.1, 'high': 0.2}}},
            ],
            whole: {'magnitude': {'relative': {'normal': {'sigma': 0.1}}}},
        },
    )
    torques = drawn(data, item)
    nominal = np.array(SCHEDULE[2][1])
    assert stats.kstest(torques[:, 0] - nominal[0], stats.norm(0.0, 0.01).cdf).pvalue > KS_LEVEL
    assert np.all(torques[:, 1] == nominal[1])
    d = torques[:, 2] / nominal[2] - 1.0
    assert stats.kstest(d, stats.uniform(-0.1, 0.3).cdf).pvalue > KS_LEVEL
    assert d.min() >= -0.1 - 1e-15 and d.max() <= 0.2 + 1e-15  # the division's rounding

    vectors = drawn(data, whole)
    size = np.linalg.norm(TORQUE)
    ratio = np.linalg.norm(vectors, axis=1) / size - 1.0
    assert stats.kstest(ratio, stats.norm(0.0, 0.1).cdf).pvalue > KS_LEVEL
    # the same direction: the nominal unit vector scaled, a few rounding errors of 1e-16 rad
    assert np.max(angles_between(vectors, np.array(TORQUE))) < 1e-15


def test_a_cone_turns_a_vector_uniformly_within_its_half_angle_keeping_its_magnitude(tmp_path):
    """
    ``direction: {cone: {half_angle: A}}``: every drawn torque within A of the nominal one.

    Uniform on the cap: cos(angle) uniform on [cos A, 1] (Archimedes' hat-box theorem) and the
    azimuth about the nominal direction uniform, measured here in a basis of the test's own.
    """
    from scipy import stats

    half = 0.2
    data = torque_campaign(
        tmp_path,
        DRAWS,
        {'effects[0].external_torque.torque': {'direction': {'cone': {'half_angle': half}}}},
    )
    vectors = drawn(data, 'effects[0].external_torque.torque')
    nominal = np.array(TORQUE)
    # the magnitude kept, to a few rounding errors (2.2e-16 each)
    np.testing.assert_allclose(
        np.linalg.norm(vectors, axis=1), np.linalg.norm(nominal), rtol=1e-15, atol=0
    )
    angle = angles_between(vectors, nominal)
    assert angle.max() <= half * (1 + 1e-14)  # rounding of the angle's own computation
    assert angle.max() > 0.99 * half  # the cone is filled to its edge
    cosine = stats.uniform(math.cos(half), 1.0 - math.cos(half))
    assert stats.kstest(np.cos(angle), cosine.cdf).pvalue > KS_LEVEL
    axis = nominal / np.linalg.norm(nominal)
    first = np.cross(axis, [0.0, 0.0, 1.0])
    first /= np.linalg.norm(first)
    second = np.cross(axis, first)
    azimuth = np.arctan2(vectors @ second, vectors @ first)
    assert stats.kstest(azimuth, stats.uniform(-math.pi, 2 * math.pi).cdf).pvalue > KS_LEVEL


def test_an_initial_rate_as_a_whole_and_a_negative_magnitude_fails_its_run():
    """
    ``initial.angular_velocity`` turned by a small rotation, its magnitude dispersed.

    A rotation vector v ~ N(0, sigma^2 I) turns a direction by |v_perp|, Rayleigh(sigma), to
    O(sigma^2) relative (1e-4 here; 4000 draws resolve about 3e-2 of the distribution). An absolute
    magnitude dispersion as wide as the nominal magnitude draws a negative one in 16 % of the runs
    (P(Z < -1)): those runs fail with the drawn value, the others run.
    """
    from scipy import stats

    sigma = 0.01
    data = {
        'scene': 'dzhanibekov',
        'runs': DRAWS,
        'seed': 38,
        'duration': 0.0,
        'rate': 1.0,
        'dispersions': {
            'initial.angular_velocity': {'direction': {'small_rotation': {'sigma': sigma}}}
        },
        'metrics': ['final_rates'],
    }
    nominal = np.array(load_campaign(data).scene.angular_velocity)
    rates = drawn(data, 'initial.angular_velocity')
    np.testing.assert_allclose(
        np.linalg.norm(rates, axis=1), np.linalg.norm(nominal), rtol=1e-15, atol=0
    )
    angle = angles_between(rates, nominal)
    assert stats.kstest(angle, stats.rayleigh(scale=sigma).cdf).pvalue > KS_LEVEL

    size = float(np.linalg.norm(nominal))
    data['runs'] = 400
    data['dispersions'] = {
        'initial.angular_velocity': {'magnitude': {'absolute': {'normal': {'sigma': size}}}}
    }
    table = run_campaign(data, scheduler='in-process').to_pydict()
    rates = np.array([table[f'initial.angular_velocity[{k}]'] for k in range(3)]).T
    negative = rates @ nominal < 0  # a negative magnitude points the other way
    status = np.array(table['status'])
    assert 0.1 < negative.mean() < 0.22  # 16 %, within 4 standard errors of 400 runs (1.8 %)
    assert np.all(status[negative] == 'invalid_scene') and np.all(status[~negative] == 'ok')
    for run in np.flatnonzero(negative)[:5]:
        assert table['reason'][run] == (
            'initial.angular_velocity: the drawn magnitude must be >= 0, got '
            f'{-np.linalg.norm(rates[run]):.6g}'
        )
        assert table['final_wx'][run] is None
    np.testing.assert_array_equal(np.array(table['final_wx'])[~negative], rates[~negative, 0])


def test_index_paths_reach_their_list_item_and_the_runs_feel_the_drawn_torques(tmp_path):
    """
    Index paths move their schedule item only; every run feels the drawn torques.

    ``schedule[1].start`` and ``schedule[2].torque`` are dispersed, and the constant torque turned
    in a cone and scaled. Each run's own scene holds the drawn values at those places and the
    nominal ones elsewhere, and its final rate is the closed form: the sphere's w(T) = torque0 T +
    tau_a s1 + tau_b (s2 - s1) + tau_c (T - s2), within the integrator's 1e-10 accuracy (1e-8
    allowed). The runs draw from their own seeds only: the same table in other chunks, and a
    shorter campaign's runs are the first ones of a longer one.
    """
    from torquefree_ros.campaigns import engine

    dispersions = {
        'effects[1].external_torque.schedule[1].start': {
            'absolute': {'uniform': {'low': -0.2, 'high': 0.2}}
        },
        'effects[1].external_torque.schedule[2].torque': {'absolute': {'normal': {'sigma': 0.05}}},
        'effects[0].external_torque.torque': {
            'direction': {'cone': {'half_angle': 0.3}},
            'magnitude': {'relative': {'uniform': {'low': -0.5, 'high': 0.5}}},
        },
    }
    data = torque_campaign(tmp_path, 12, dispersions)
    table = run_campaign(data, scheduler='in-process')
    assert set(table.column('status').to_pylist()) == {'ok'}
    rows = table.to_pydict()
    campaign = load_campaign(data)
    for run in range(12):
        torque0 = np.array(
            [rows[f'effects[0].external_torque.torque[{k}]'][run] for k in range(3)]
        )
        tau_c = np.array(
            [rows[f'effects[1].external_torque.schedule[2].torque[{k}]'][run] for k in range(3)]
        )
        s1 = rows['effects[1].external_torque.schedule[1].start'][run]
        (_, tau_a), (_, tau_b), (s2, _) = SCHEDULE
        schedule = engine._scene_of(campaign, engine.draw_run(campaign, run)).effects[1]
        assert [segment['start'] for segment in schedule.values['schedule']] == [0.0, s1, s2]
        assert [list(segment['torque']) for segment in schedule.values['schedule']] == [
            tau_a,
            tau_b,
            tau_c.tolist(),
        ]
        expected = torque0 * 3.0 + np.array(tau_a) * s1 + np.array(tau_b) * (s2 - s1)
        expected += tau_c * (3.0 - s2)
        final = np.array([rows[f'final_w{a}'][run] for a in 'xyz'])
        np.testing.assert_allclose(final, expected, rtol=0, atol=1e-8)
    assert_same_table(table, run_campaign(data, scheduler='in-process', chunk_size=5))
    shorter = run_campaign(dict(data, runs=5), scheduler='in-process').to_pydict()
    for name, values in shorter.items():
        assert values == rows[name][:5], name


SCHEDULE_FILES = {
    'an item past the list': (
        {'effects[1].external_torque.schedule[5].torque': {'absolute': {'normal': {'sigma': 1}}}},
        'dispersions.effects[1].external_torque.schedule[5].torque: outside the scene: '
        'external_torque.schedule has 3 items (external_torque.schedule[0] to '
        'external_torque.schedule[2])',
    ),
    'a key an item lacks': (
        {'effects[1].external_torque.schedule[0].torq': {'absolute': {'normal': {'sigma': 1}}}},
        'dispersions.effects[1].external_torque.schedule[0].torq: outside the scene: '
        "external_torque.schedule[0] has no key 'torq'; did you mean 'torque'? "
        '(keys: start, torque)',
    ),
    'a component past the vector': (
        {'effects[0].external_torque.torque[3]': {'absolute': {'normal': {'sigma': 1}}}},
        'dispersions.effects[0].external_torque.torque[3]: outside the scene: '
        'external_torque.torque has 3 items',
    ),
    'a key into a vector': (
        {'effects[0].external_torque.torque.x': {'absolute': {'normal': {'sigma': 1}}}},
        'dispersions.effects[0].external_torque.torque.x: outside the scene: '
        'external_torque.torque is [0.01, -0.02, 0.015], not a mapping with a key .x',
    ),
    'an index into a number': (
        {'effects[1].external_torque.schedule[1].start[0]': {'replace': {'values': [1]}}},
        'dispersions.effects[1].external_torque.schedule[1].start[0]: outside the scene: '
        'external_torque.schedule[1].start is 1.0, not a list to index with [k]',
    ),
    'a list of mappings': (
        {'effects[1].external_torque.schedule': {'absolute': {'normal': {'sigma': 1}}}},
        'dispersions.effects[1].external_torque.schedule: only a number or a list of numbers can '
        'be dispersed; external_torque.schedule is a list of 3 mappings: disperse a number of '
        'one by its index, such as external_torque.schedule[0].start',
    ),
    'a word': (
        {'effects[0].external_torque.frame': {'replace': {'values': [1]}}},
        'dispersions.effects[0].external_torque.frame: only a number or a list of numbers can be '
        "dispersed; external_torque.frame is 'body'",
    ),
    'a vector the scene leaves out': (
        {'effects[1].external_torque.torque': {'absolute': {'normal': {'sigma': 1}}}},
        'dispersions.effects[1].external_torque.torque: the scene gives no '
        'external_torque.torque: write one in it to disperse it',
    ),
    'a part of a default': (
        {'effects[0].external_torque.frame[0]': {'replace': {'values': [1]}}},
        'dispersions.effects[0].external_torque.frame[0]: the scene does not give '
        'external_torque.frame (its default is used): write it in the scene file to disperse a '
        'part of it, or disperse it whole',
    ),
    'a wrong number of components': (
        {'effects[1].external_torque.schedule[2].torque': [None, None]},
        'dispersions.effects[1].external_torque.schedule[2].torque: expected one dispersion '
        '(every component) or a list of 3 (one per component, null for none), got a list of 2',
    ),
    'a number twice': (
        {
            'effects[0].external_torque.torque': {'absolute': {'normal': {'sigma': 1}}},
            'effects[0].external_torque.torque[1]': {'absolute': {'normal': {'sigma': 1}}},
        },
        'dispersions.effects[0].external_torque.torque[1]: disperses what '
        'dispersions.effects[0].external_torque.torque disperses already; disperse a number once',
    ),
    'a cone wider than the sphere': (
        {'effects[0].external_torque.torque': {'direction': {'cone': {'half_angle': 4}}}},
        'dispersions.effects[0].external_torque.torque.direction.cone.half_angle: must be <= '
        '3.14159 rad, got 4',
    ),
    'a misspelt whole-vector key': (
        {'effects[0].external_torque.torque': {'directon': {'cone': {'half_angle': 0.1}}}},
        'dispersions.effects[0].external_torque.torque: unknown mode or whole-vector key '
        "'directon'; did you mean 'direction'?",
    ),
    'a whole-vector key beside a mode': (
        {
            'effects[0].external_torque.torque': {
                'direction': {'cone': {'half_angle': 0.1}},
                'relative': {'normal': {'sigma': 0.1}},
            }
        },
        'dispersions.effects[0].external_torque.torque.relative: unknown key (allowed: '
        'direction, misalignment, magnitude)',
    ),
    'an unknown direction': (
        {'effects[0].external_torque.torque': {'direction': {'uniform': {}}}},
        'dispersions.effects[0].external_torque.torque.direction: unknown direction dispersion '
        "'uniform' (known: cone, small_rotation)",
    ),
    'a zero vector as a whole': (
        {'initial.angular_velocity': {'magnitude': {'relative': {'normal': {'sigma': 0.1}}}}},
        'dispersions.initial.angular_velocity: the nominal vector is zero: it has no direction or '
        'magnitude to disperse; disperse it per component',
    ),
    'the moments as a whole': (
        {'body.moments': {'direction': {'cone': {'half_angle': 0.1}}}},
        'dispersions.body.moments: a direction, a misalignment or a magnitude is for a vector in '
        'space; '
        'body.moments takes one dispersion (every component) or a list of 3 (one per component)',
    ),
}


@pytest.mark.parametrize('case', sorted(SCHEDULE_FILES))
def test_a_bad_path_or_shape_into_an_effect_names_the_file_and_the_field(case, tmp_path):
    dispersions, expected = SCHEDULE_FILES[case]
    path = tmp_path / 'bad.yaml'
    path.write_text(yaml.safe_dump(torque_campaign(tmp_path, 10, dispersions)))
    with pytest.raises(CampaignError) as error:
        load_campaign(path)
    assert str(error.value).startswith(f'{path}: {expected}'), str(error.value)


# -- bad campaign files ---------------------------------------------------------------------------
BAD_FILES = {
    'unknown distribution': (
        {'body.moments': {'relative': {'gaussian': {'sigma': 0.1}}}},
        "dispersions.body.moments.relative: unknown distribution 'gaussian' "
        '(known: normal, truncated_normal',
    ),
    'negative sigma': (
        {'initial.angular_velocity': {'absolute': {'normal': {'sigma': -0.1}}}},
        'dispersions.initial.angular_velocity.absolute.normal.sigma: must be >= 0',
    ),
    'no valid body': (
        {'body.moments': {'relative': {'uniform': {'low': -3.0, 'high': -1.5}}}},
        'dispersions.body.moments: gives no physical body',
    ),
    'effect index outside the scene': (
        {'effects[5].damper.damping': {'relative': {'normal': {'sigma': 0.1}}}},
        'dispersions.effects[5].damper.damping: outside the scene: it has 3 effects',
    ),
    'another effect': (
        {'effects[1].damper.damping': {'relative': {'normal': {'sigma': 0.1}}}},
        "dispersions.effects[1].damper.damping: outside the scene: effects[1] is tf, not 'damper'",
    ),
    'unknown parameter': (
        {'effects[0].damper.dampin': {'relative': {'normal': {'sigma': 0.1}}}},
        "has no parameter 'dampin'; did you mean 'damping'?",
    ),
    'unknown target': (
        {'body.mass': {'relative': {'normal': {'sigma': 0.1}}}},
        'dispersions.body.mass: not a target',
    ),
    'wrong component count': (
        {'initial.angular_velocity': [{'absolute': {'normal': {'sigma': 0.1}}}]},
        'a list of 3 (one per component',
    ),
    'empty truncation': (
        {
            'initial.angular_velocity': {
                'absolute': {'truncated_normal': {'sigma': 0.1, 'low': 5.0, 'high': 6.0}}
            }
        },
        'holds no probability',
    ),
    'unknown mode': (
        {'body.moments': {'relativ': {'normal': {'sigma': 0.1}}}},
        "did you mean 'relative'?",
    ),
}


@pytest.mark.parametrize('case', sorted(BAD_FILES))
def test_a_bad_campaign_file_names_the_file_and_the_field(case, tmp_path):
    dispersions, expected = BAD_FILES[case]
    path = tmp_path / 'bad.yaml'
    path.write_text(
        yaml.safe_dump(
            {
                'scene': 'explorer1',
                'runs': 10,
                'seed': 1,
                'duration': 1,
                'rate': 1,
                'dispersions': dispersions,
            }
        )
    )
    with pytest.raises(CampaignError) as error:
        load_campaign(path)
    assert str(error.value).startswith(f'{path}: ')
    assert expected in str(error.value)


@pytest.mark.parametrize(
    'change, expected',
    [
        ({'metrics': ['final_rates', 'settle_time']}, 'metrics[1].settle_time.threshold: missing'),
        ({'metrics': ['flipz']}, "metrics[0]: unknown metric 'flipz'; did you mean 'flips'?"),
        ({'metrics': ['flips', 'flips']}, 'metrics[1]: flips is already metrics[0]'),
        ({'runs': 0}, 'runs: must lie in'),
        (
            {'scene': 'no_such_scene'},
            "scene: scene: 'no_such_scene' is neither a file nor a library scene",
        ),
        ({'invalid_body': 'retry'}, 'invalid_body: expected one of redraw, fail'),
        ({'seeds': 1}, "seeds: unknown key; did you mean 'seed'?"),
    ],
)
def test_bad_top_level_fields(change, expected, tmp_path):
    data = {'scene': 'dzhanibekov', 'runs': 10, 'seed': 1, 'duration': 1, 'rate': 1}
    data.update(change)
    path = tmp_path / 'bad.yaml'
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(CampaignError, match='^' + str(path).replace('.', r'\.') + ': ') as error:
        load_campaign(path)
    assert expected in str(error.value)


# -- metrics against known answers ----------------------------------------------------------------
def samples_of(inertia, omega0, times, q0=(0.0, 0.0, 0.0, 1.0)):
    omega, q = propagate_batch([inertia], [omega0], [q0], times)
    body = RigidBody.from_inertia(inertia)
    return Samples(
        times,
        omega,
        q,
        np.empty(omega.shape[:2] + (0,)),
        body.tensor[None],
        body.moments[None],
        body.principal_axes[None],
    )


def test_cone_angle_of_a_symmetric_top_is_its_closed_form():
    """
    The cone angle of an oblate top (I_T = 1, I_3 = 2) is its closed form.

    H keeps tan(theta) = I_T w_t / (I_3 w_3) from the symmetry axis.
    """
    samples = samples_of([1.0, 1.0, 2.0], [0.3, 0.4, 1.0], np.linspace(0.0, 20.0, 401))
    expected = math.atan2(1.0 * 0.5, 2.0 * 1.0)
    got = METRICS['cone_angle'].function(samples, axis='major')[0]
    assert abs(got - expected) < 1e-14  # a few ULPs of atan2 on exact rates (|H_B| constant)
    assert abs(METRICS['cone_angle'].function(samples, axis='z')[0] - expected) < 1e-14


def test_flips_of_a_dzhanibekov_body_over_a_known_number_of_flip_periods():
    """
    Over K flip periods, a Dzhanibekov body's nut reverses K times.

    Spun about the intermediate axis, the nut reverses once a flip period (classify gives it); over
    K periods starting mid-dwell, K reversals, half a period clear of either end.
    """
    inertia, omega0 = [1.0, 2.0, 3.0], [0.001, 5.0, 0.001]
    period = RigidBody.from_inertia(inertia).classify(omega0).flip_period
    assert 'flip period' in RigidBody.from_inertia(inertia).classify(omega0).summary()
    for K in (1, 4, 7):
        samples = samples_of(inertia, omega0, np.linspace(0.0, K * period, 200 * K + 1))
        assert METRICS['flips'].function(samples, margin=30.0)[0] == K
    # near the major axis: no flip
    stable = samples_of(inertia, [0.3, 0.2, 5.0], np.linspace(0.0, 60.0, 601))
    assert METRICS['flips'].function(stable, margin=30.0)[0] == 0


def test_drifts_of_the_exact_solution_are_rounding():
    samples = samples_of(
        [1.0, 2.0, 2.5], [0.3, 1.0, 0.2], np.linspace(0.0, 100.0, 1001), (0.1, 0.2, 0.3, 0.927)
    )
    # the exact solution conserves both to rounding
    assert METRICS['energy_drift'].function(samples)[0] < 1e-13
    assert METRICS['momentum_drift'].function(samples)[0] < 1e-13


def test_settle_time_and_drifts_under_a_constant_torque_against_the_closed_form(tmp_path):
    """
    Settle time and drifts of a sphere under a constant torque are the closed form's.

    A sphere (I = 1) spun at 1 rad/s about x under -0.1 N m about x: w_x = 1 - 0.1 t. |w| < 0.555
    from t > 4.45 s, first sample 4.5 s at 10 Hz (0.005 rad/s clear of the threshold); at 8 s: T
    drops by 1 - 0.2^2 = 0.96 of T_0, H_N (along x, fixed) by 0.8 of |H_0|; the integrator's 1e-10
    accuracy is far inside the 1e-8 allowed.
    """
    scene = tmp_path / 'brake.yaml'
    scene.write_text(
        'body: {inertia: [1.0, 1.0, 1.0]}\ninitial: {angular_velocity: [1.0, 0.0, 0.0]}\n'
        'effects: [{external_torque: {torque: [-0.1, 0.0, 0.0]}}]\naccuracy: 1.0e-10\n'
    )
    data = {
        'scene': str(scene),
        'runs': 1,
        'seed': 0,
        'duration': 8.0,
        'rate': 10.0,
        'metrics': [
            {'settle_time': {'threshold': 0.555}},
            'energy_drift',
            'momentum_drift',
            'final_rates',
        ],
    }
    row = run_campaign(data, scheduler='in-process').to_pylist()[0]
    assert row['settle_time'] == pytest.approx(4.5, abs=1e-12)
    assert row['energy_drift'] == pytest.approx(0.96, abs=1e-8)
    assert row['momentum_drift'] == pytest.approx(0.8, abs=1e-8)
    assert row['final_wx'] == pytest.approx(0.2, abs=1e-8)
    data['duration'] = 20.0  # w_x = -1 at the end: |w| is back over the threshold
    assert math.isnan(run_campaign(data, scheduler='in-process').to_pylist()[0]['settle_time'])


def test_attitude_error_from_the_nominal_run_is_the_drawn_inertial_rotation():
    """
    The attitude error from the nominal run is the drawn rotation's angle at every sample.

    A torque-free motion turned by an inertial rotation r stays r ⊗ q_nominal(t).
    """
    data = {
        'scene': 'dzhanibekov',
        'runs': 30,
        'seed': 5,
        'duration': 20.0,
        'rate': 10.0,
        'dispersions': {'initial.orientation': {'small_rotation': {'sigma': 0.05}}},
        'metrics': ['nominal_attitude_error'],
    }
    table = run_campaign(data, scheduler='in-process').to_pydict()
    q0 = np.array([[table[f'initial.orientation[{k}]'][i] for k in range(4)] for i in range(30)])
    # nominal q0 is identity
    drawn = 2.0 * np.arctan2(np.linalg.norm(q0[:, :3], axis=1), np.abs(q0[:, 3]))
    # rounding over 200 samples
    assert np.max(np.abs(np.array(table['nominal_attitude_error']) - drawn)) < 1e-12


def test_a_metric_added_as_a_python_function():
    @metric('peak_rate_test', unit='rad/s')
    def peak_rate(samples):
        """Return the largest |w| of the run."""
        return samples.rate_norm().max(axis=1)

    try:
        data = {
            'scene': 'dzhanibekov',
            'runs': 5,
            'seed': 1,
            'duration': 2.0,
            'rate': 10.0,
            'dispersions': {'initial.angular_velocity': {'absolute': {'normal': {'sigma': 0.1}}}},
            'metrics': ['peak_rate_test', 'final_rates'],
        }
        table = run_campaign(data, scheduler='in-process')
        assert table.column_names[-4:] == ['peak_rate_test', 'final_wx', 'final_wy', 'final_wz']
        # |w0| = 5 and the peak includes t = 0: at least 5 - |delta|, and |delta| < 0.5 is 5 sigma
        assert all(v >= 4.5 for v in table.column('peak_rate_test').to_pylist())
    finally:
        del METRICS['peak_rate_test']


# -- results, library, command line ---------------------------------------------------------------
def test_the_parquet_file_holds_the_table_the_campaign_and_the_versions(tmp_path):
    path = tmp_path / 'c.yaml'
    path.write_text(yaml.safe_dump(torque_free_campaign(30)))
    table = run_campaign(path, scheduler='in-process', output=tmp_path / 'out')
    back = pq.read_table(tmp_path / 'out' / 'runs.parquet')
    assert_same_table(table, back)
    meta = back.schema.metadata
    assert meta[b'torquefree_ros.campaign'].decode() == path.read_text()
    assert b'"numpy": "' + np.__version__.encode() in meta[b'torquefree_ros.versions']
    with pytest.raises(FileExistsError, match='--overwrite'):
        run_campaign(path, scheduler='in-process', output=tmp_path / 'out')


def test_the_library_campaigns_load_and_run_shortened():
    assert {'explorer1_damper', 'dzhanibekov_rates', 'wheel_spin_up'} <= set(library_campaigns())
    for name in sorted(library_campaigns()):
        campaign = load_campaign(name)
        data = yaml.safe_load(campaign.text)
        data.update(runs=12, duration=min(data['duration'], 30.0))
        table = run_campaign(data, scheduler='in-process')
        assert table.num_rows == 12 and set(table.column('status').to_pylist()) == {'ok'}


def test_the_command_line_runs_a_file_and_refuses_a_bad_one_with_status_2(tmp_path, capsys):
    good = tmp_path / 'good.yaml'
    good.write_text(yaml.safe_dump(torque_free_campaign(20)))
    assert (
        campaign_cli.main(
            ['run', str(good), '--output', str(tmp_path / 'out'), '--scheduler', 'in-process']
        )
        == 0
    )
    said = capsys.readouterr()
    assert '/runs.parquet: 20 runs (20 ok, 0 failed); 20 computed in-process in ' in said.out
    # after the note on the bodies near the triangle limit
    assert said.err.endswith('\ntorquefree_campaign: engine: in-process: as asked\n')
    assert pq.read_table(tmp_path / 'out' / 'runs.parquet').num_rows == 20
    # by default: 20 runs are one chunk (256 runs at least), which stays in this process
    assert campaign_cli.main(['run', str(good), '--output', str(tmp_path / 'default')]) == 0
    said = capsys.readouterr()
    assert '20 computed in-process in ' in said.out
    assert said.err.endswith('\ntorquefree_campaign: engine: in-process: one chunk to compute\n')
    bad = tmp_path / 'bad.yaml'
    bad.write_text(
        'scene: explorer1\nruns: 3\nseed: 1\nduration: 1\nrate: 1\n'
        'dispersions:\n  effects[0].damper.damping: {relative: {normal: {sigma: -1}}}\n'
    )
    assert campaign_cli.main(['run', str(bad), '--output', str(tmp_path / 'o2')]) == 2
    assert (
        f'{bad}: dispersions.effects[0].damper.damping.relative.normal.sigma: must be >= 0'
        in capsys.readouterr().err
    )
    with pytest.raises(SystemExit) as exit_:
        campaign_cli.main(['run', str(good), '--output', str(tmp_path / 'o3'), '--workers', '0'])
    assert exit_.value.code == 2


# -- resuming an interrupted campaign -------------------------------------------------------------
class Interrupted(Exception):
    """What a test raises to stop a campaign part way (as Ctrl-C would)."""


def interrupt_after(runs):
    def progress(done, total):
        if done >= runs:
            raise Interrupted

    return progress


def computed_chunks(monkeypatch):
    """Collect the (start, stop) of every chunk the in-process engine computes from now on."""
    from torquefree_ros.campaigns import engine

    computed, original = [], engine.run_chunk
    monkeypatch.setattr(
        engine,
        'run_chunk',
        lambda campaign, start, stop: (
            computed.append((start, stop)),
            original(campaign, start, stop),
        )[1],
    )
    return computed


def test_an_interrupted_campaign_resumes_computing_only_the_missing_runs(tmp_path, monkeypatch):
    """
    A resumed campaign computes exactly the missing runs, and the table is the uninterrupted one.

    Interrupted after 3 of 8 chunks, a finished part lost besides (a hole): the resumed run, in
    other chunks, computes exactly the runs no part holds, and the table is the uninterrupted one
    bit for bit.
    """
    reference = run_campaign(torque_free_campaign(300), scheduler='in-process')
    output = tmp_path / 'out'
    with pytest.raises(Interrupted):
        run_campaign(
            torque_free_campaign(300),
            scheduler='in-process',
            output=output,
            chunk_size=40,
            progress=interrupt_after(120),
        )
    parts = sorted(p.name for p in (output / 'parts').glob('*.parquet'))
    assert parts == [
        'runs-000000000-000000040.parquet',
        'runs-000000040-000000080.parquet',
        'runs-000000080-000000120.parquet',
    ]
    assert not (output / 'runs.parquet').exists()
    (output / 'parts' / parts[1]).unlink()
    with pytest.raises(
        FileExistsError, match='80 of 300 runs .* --resume continues it, --overwrite starts over'
    ):
        run_campaign(torque_free_campaign(300), scheduler='in-process', output=output)

    computed, progress = computed_chunks(monkeypatch), []
    table = run_campaign(
        torque_free_campaign(300),
        scheduler='in-process',
        output=output,
        chunk_size=100,
        resume=True,
        progress=lambda done, total: progress.append(done),
    )
    # the hole (40, 80), then (120, 300) in chunks of at most 100
    assert computed == [(40, 80), (120, 220), (220, 300)]
    assert progress == [80, 120, 220, 300]  # starts from the runs kept
    assert_same_table(reference, table)
    assert_same_table(reference, pq.read_table(output / 'runs.parquet'))
    assert not (output / 'parts').exists()  # the parts are gone once the table is whole
    computed.clear()  # resuming a finished campaign computes nothing and returns its table
    choices = []
    assert_same_table(
        reference,
        run_campaign(
            torque_free_campaign(300), output=output, resume=True, on_engine=choices.append
        ),
    )
    assert computed == [] and choices == []  # no engine ran


def test_a_campaign_interrupted_on_workers_resumes_on_workers(tmp_path, cluster):
    """
    A campaign interrupted on the cluster and resumed on it computes only the missing runs.

    Stopped after its first chunks on the cluster, resumed on it: the runs computed are those
    missing.
    """
    reference = run_campaign(damper_campaign(), scheduler='in-process')
    output = tmp_path / 'out'
    with pytest.raises(Interrupted):
        run_campaign(
            damper_campaign(),
            scheduler=cluster.scheduler_address,
            output=output,
            chunk_size=8,
            progress=interrupt_after(16),
        )
    kept = sum(
        int(p.name[15:24]) - int(p.name[5:14]) for p in (output / 'parts').glob('runs-*.parquet')
    )
    # at least the 16 runs done before the interruption, and not all 60
    assert 16 <= kept < 60
    progress = []
    table = run_campaign(
        damper_campaign(),
        scheduler=cluster.scheduler_address,
        output=output,
        chunk_size=8,
        resume=True,
        progress=lambda done, total: progress.append(done),
    )
    assert (
        progress[0] == kept
        and progress[-1] == 60
        and len(progress) == 1 + math.ceil((60 - kept) / 8)
    )
    assert_same_table(reference, table)


def test_resuming_refuses_another_campaign_scene_or_versions(tmp_path, monkeypatch):
    from torquefree_ros.campaigns import results
    from torquefree_ros.campaigns.store import ResumeError

    scene = tmp_path / 'body.yaml'
    scene.write_text(
        'body: {inertia: [1.0, 2.0, 2.5]}\ninitial: {angular_velocity: [0.3, 1.0, 0.2]}\n'
    )
    data = {
        'scene': str(scene),
        'runs': 40,
        'seed': 4,
        'duration': 2.0,
        'rate': 5.0,
        'metrics': ['final_rates'],
        'dispersions': {'initial.angular_velocity': {'absolute': {'normal': {'sigma': 0.01}}}},
    }
    output = tmp_path / 'out'
    with pytest.raises(Interrupted):
        run_campaign(
            data,
            scheduler='in-process',
            output=output,
            chunk_size=10,
            progress=interrupt_after(10),
        )
    manifest = output / 'parts' / 'manifest.json'
    with pytest.raises(
        ResumeError,
        match=r'cannot resume: its campaign file differs from <mapping> at line \d+ '
        r"\('seed: 4', now 'seed: 5'\)\. --overwrite starts over",
    ):
        run_campaign(dict(data, seed=5), scheduler='in-process', output=output, resume=True)
    scene.write_text(
        'body: {inertia: [1.0, 2.0, 2.6]}\ninitial: {angular_velocity: [0.3, 1.0, 0.2]}\n'
    )
    with pytest.raises(
        ResumeError, match=f'^{manifest}: cannot resume: its scene \\({scene}\\) differs'
    ):
        run_campaign(data, scheduler='in-process', output=output, resume=True)
    scene.write_text(
        'body: {inertia: [1.0, 2.0, 2.5]}\ninitial: {angular_velocity: [0.3, 1.0, 0.2]}\n'
    )
    real = results.versions()
    monkeypatch.setattr(results, 'versions', lambda: dict(real, numpy='0.0.1'))
    with pytest.raises(
        ResumeError,
        match=f'it was made with numpy {real["numpy"]} \\(now 0.0.1\\), and runs made '
        "by other versions need not be bit for bit this run's",
    ):
        run_campaign(data, scheduler='in-process', output=output, resume=True)
    monkeypatch.undo()
    # a torn part (a crash before its bytes reached the disk) is computed again; overwrite starts
    # over
    (output / 'parts' / 'runs-000000000-000000010.parquet').write_bytes(b'PAR1 torn')
    table = run_campaign(data, scheduler='in-process', output=output, resume=True)
    assert_same_table(run_campaign(data, scheduler='in-process'), table)
    with pytest.raises(FileExistsError, match='a finished campaign.*--resume returns it'):
        run_campaign(data, scheduler='in-process', output=output)
    run_campaign(dict(data, seed=5), scheduler='in-process', output=output, overwrite=True)
    metadata = pq.read_table(output / 'runs.parquet').schema.metadata
    assert yaml.safe_load(metadata[b'torquefree_ros.campaign'])['seed'] == 5


def test_the_command_line_resumes_and_says_what_it_computed(tmp_path, capsys):
    path = tmp_path / 'c.yaml'
    path.write_text(yaml.safe_dump(torque_free_campaign(60)))
    output = tmp_path / 'out'
    with pytest.raises(Interrupted):
        run_campaign(
            path,
            scheduler='in-process',
            output=output,
            chunk_size=20,
            progress=interrupt_after(20),
        )
    arguments = ['run', str(path), '--output', str(output), '--scheduler', 'in-process']
    assert campaign_cli.main(arguments) == 2
    assert '--resume continues it' in capsys.readouterr().err
    assert campaign_cli.main(arguments + ['--resume']) == 0
    assert '60 runs (60 ok, 0 failed, 20 resumed); 40 computed in' in capsys.readouterr().out
    assert campaign_cli.main(arguments + ['--resume']) == 0
    assert 'finished before, nothing computed' in capsys.readouterr().out
    with pytest.raises(SystemExit):
        campaign_cli.main(arguments + ['--resume', '--overwrite'])
    assert 'not allowed with argument' in capsys.readouterr().err
    assert_same_table(
        run_campaign(path, scheduler='in-process'), pq.read_table(output / 'runs.parquet')
    )


# -- the progress line ----------------------------------------------------------------------------
def test_the_progress_line_counts_runs_speed_and_eta():
    # the ETA is the runs left over the speed: 750 / 50 = 15 s
    assert (
        campaign_cli.progress_line(250, 1000, 50.0)
        == '250/1,000 runs (25 %), 50.0 runs/s, ETA 0:15'
    )
    assert (  # 400 / 25 = 16 s
        campaign_cli.progress_line(600, 1000, 25.0, 500)
        == '600/1,000 runs (60 %, 500 resumed), 25.0 runs/s, ETA 0:16'
    )
    assert campaign_cli.progress_line(0, 10_000, 0.0).endswith('0.0 runs/s, ETA --')
    # 85 000 / 10 = 8 500 s = 2 h 21 min 40 s
    assert campaign_cli.progress_line(5000, 90_000, 10.0).endswith('ETA 2:21:40')
    assert campaign_cli.progress_line(250, 1000, 50.0, 0, 'local cluster of 2 workers') == (
        '250/1,000 runs (25 %), 50.0 runs/s, ETA 0:15, local cluster of 2 workers'
    )


def test_the_progress_line_is_written_on_a_terminal_only_and_at_most_twice_a_second():
    """
    The progress line of a resumed campaign whose first chunk comes in after a slow start.

    The campaign has 100 runs kept and its first chunk comes in after 2 s: the speed is counted
    from that chunk on, the line rewritten at most every 0.5 s, and always at the end. The engine,
    once settled, is said on a line of its own and named on the progress line.
    """
    import io

    from torquefree_ros.campaigns.engine import EngineChoice

    class Terminal(io.StringIO):
        """A text stream that says it is a terminal."""

        def isatty(self):
            return True

    now = [0.0]
    terminal = Terminal()
    progress = campaign_cli.RunProgress(terminal, clock=lambda: now[0])
    for done, at in ((100, 0.0), (110, 2.0), (120, 2.2), (130, 2.6), (140, 2.7), (160, 3.0)):
        now[0] = at
        progress(done, 160)
        if done == 120:
            progress.engine(EngineChoice('local', 'as asked', 2))
    progress.close()
    lines = terminal.getvalue().split('\r')
    assert lines[1:] == [
        # the start: 10 runs in 2 s, 50 left at 5 runs/s
        '110/160 runs (69 %, 100 resumed), 5.0 runs/s, ETA 0:10\033[K',
        'torquefree_campaign: engine: local cluster of 2 workers: as asked\033[K\n',
        # 20 runs in the 0.6 s since the first chunk (2.0 s); 30 left
        '130/160 runs (81 %, 100 resumed), 33.3 runs/s, ETA 0:01, local cluster of 2 workers'
        '\033[K',
        # 50 runs in 1.0 s
        '160/160 runs (100 %, 100 resumed), 50.0 runs/s, ETA 0:00, local cluster of 2 workers'
        '\033[K',
        '\033[K',
    ]
    piped = io.StringIO()
    quiet = campaign_cli.RunProgress(piped)
    quiet(0, 10), quiet(10, 10), quiet.close()
    assert piped.getvalue() == ''
    forced = io.StringIO()
    shown = campaign_cli.RunProgress(forced, enabled=True)
    shown(0, 10), shown(10, 10)
    assert '10/10 runs (100 %)' in forced.getvalue()


def test_the_command_line_progress_can_be_forced(tmp_path, capsys):
    path = tmp_path / 'c.yaml'
    path.write_text(yaml.safe_dump(torque_free_campaign(30)))
    assert (
        campaign_cli.main(
            [
                'run',
                str(path),
                '--output',
                str(tmp_path / 'out'),
                '--scheduler',
                'in-process',
                '--chunk',
                '10',
                '--progress',
                'always',
            ]
        )
        == 0
    )
    err = capsys.readouterr().err
    assert '\r30/30 runs (100 %), ' in err and ' runs/s, ETA 0:00, in-process\033[K' in err
    # asked for, the engine is said before the first chunk: before any progress line
    engine = err.index('\ntorquefree_campaign: engine: in-process: as asked\n')
    assert engine < err.index('\r')


# -- the report -----------------------------------------------------------------------------------
def markdown_rows(text: str, header: str) -> dict:
    """
    Return the rows of the Markdown table whose header row starts with ``header``.

    As a dict: first cell -> cells.
    """
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(header))
    rows = {}
    for line in lines[start + 2:]:
        if not line.startswith('|'):
            break
        cells = [cell.strip() for cell in line.strip('|').split(' | ')]
        rows[cells[0]] = cells[1:]
    return rows


def test_the_report_writes_its_files_and_its_numbers_are_the_tables(tmp_path):
    """
    The report's numbers are the table's, checked against numpy.

    A campaign with failed runs (a damping drawn negative): the statuses and their reasons, each
    metric's min, median, p95 and max, and the worst runs, against numpy on the table.
    """
    from torquefree_ros.campaigns.report import write_report

    output = tmp_path / 'out'
    data = damper_campaign(80)
    # |w0| = 6 rad/s dispersed: some runs never settle
    data['metrics'].append({'settle_time': {'threshold': 6.0}})
    table = run_campaign(data, scheduler='in-process', output=output)
    written = write_report(output)
    assert [p.name for p in written] == ['summary.md', 'histograms.png']
    assert all(p.parent == output / 'report' for p in written)
    assert (
        written[1].read_bytes()[:8] == b'\x89PNG\r\n\x1a\n' and written[1].stat().st_size > 10_000
    )
    text = written[0].read_text()
    data = table.to_pydict()
    status = np.array(data['status'])

    runs = markdown_rows(text, '| status |')
    assert set(runs) == set(status)
    for name, (count, share, reasons) in runs.items():
        assert int(count.replace(',', '')) == np.count_nonzero(status == name)
        share_expected = 100 * np.count_nonzero(status == name) / 80
        # one decimal
        assert float(share.rstrip(' %')) == pytest.approx(share_expected, abs=0.05 + 1e-12)
    failed = [i for i, s in enumerate(data['status']) if s == 'invalid_scene']
    # one kind of reason, its drawn number left out
    assert failed and all(
        data['reason'][i].startswith('effects[0].damper.damping: must be > 0 N m s, got -')
        for i in failed
    )
    assert runs['invalid_scene'][2] == (
        f'{len(failed)}× effects[0].damper.damping: must be > 0 N m s, got … (run {failed[0]})'
    )

    metrics = markdown_rows(text, '| metric | unit | runs |')
    columns = [
        'final_wx',
        'final_wy',
        'final_wz',
        'cone_angle',
        'energy_drift',
        'nominal_attitude_error',
        'settle_time',
    ]
    assert list(metrics) == columns
    ok = status == 'ok'
    settle = np.array([np.nan if v is None else v for v in data['settle_time']])[ok]
    assert 0 < np.count_nonzero(np.isnan(settle)) < settle.size  # undefined values, counted apart
    for column in columns:
        values = np.array([np.nan if v is None else v for v in data[column]], dtype=float)[ok]
        finite = values[np.isfinite(values)]
        unit, count, undefined, *numbers = metrics[column]
        assert int(count.replace(',', '')) == finite.size
        assert int(undefined.replace(',', '')) == values.size - finite.size
        expected = [finite.min(), np.median(finite), np.percentile(finite, 95), finite.max()]
        # written to 6 digits
        assert np.allclose([float(x) for x in numbers], expected, rtol=5e-6, atol=0)

    worst = markdown_rows(text, '| metric | run | value |')
    assert list(worst) == columns
    for column in columns:
        values = np.array([np.nan if v is None else v for v in data[column]], dtype=float)
        run = int(np.nanargmax(np.abs(values)))
        assert int(worst[column][0]) == run and float(worst[column][1]) == pytest.approx(
            values[run], rel=5e-6
        )
        damping = data['effects[0].damper.damping'][run]
        assert f'`effects[0].damper.damping` = {damping:.6g}' in worst[column][2]
        drawn = ', '.join(f'{data[f"initial.angular_velocity[{k}]"][run]:.6g}' for k in range(3))
        assert f'`initial.angular_velocity` = [{drawn}]' in worst[column][2]
    assert (
        'No trajectories kept (the campaign file has no `trajectories` option), '
        'so no percentile envelopes' in text
    )
    assert not (output / 'trajectories').exists()

    other = write_report(output, tmp_path / 'elsewhere')  # --output
    assert other[0] == tmp_path / 'elsewhere' / 'summary.md' and other[0].read_text() == text


def test_the_report_refuses_a_directory_without_a_campaign_table_naming_it(tmp_path, capsys):
    from torquefree_ros.campaigns.report import ReportError, write_report

    missing = tmp_path / 'nowhere'
    with pytest.raises(ReportError, match=f'^{missing}: no such directory$'):
        write_report(missing)
    plain = tmp_path / 'plain.txt'
    plain.write_text('x')
    with pytest.raises(ReportError, match=f'^{plain}: not a directory'):
        write_report(plain)
    with pytest.raises(
        ReportError, match=f"^{tmp_path}: no runs.parquet \\(not a campaign's output directory\\)$"
    ):
        write_report(tmp_path)
    unfinished = tmp_path / 'unfinished'
    with pytest.raises(Interrupted):
        run_campaign(
            torque_free_campaign(40),
            scheduler='in-process',
            output=unfinished,
            chunk_size=10,
            progress=interrupt_after(10),
        )
    with pytest.raises(
        ReportError, match=f'^{unfinished}: the campaign is not finished .* --resume finishes it$'
    ):
        write_report(unfinished)
    garbage = tmp_path / 'garbage'
    garbage.mkdir()
    (garbage / 'runs.parquet').write_bytes(b'not parquet')
    with pytest.raises(
        ReportError, match=f'^{garbage / "runs.parquet"}: cannot be read as Parquet'
    ):
        write_report(garbage)
    foreign = tmp_path / 'foreign'
    foreign.mkdir()
    pq.write_table(pa.table({'x': [1.0]}), foreign / 'runs.parquet')
    with pytest.raises(ReportError, match="not a campaign's table"):
        write_report(foreign)
    assert campaign_cli.main(['report', str(missing)]) == 2
    assert capsys.readouterr().err == f'torquefree_campaign: {missing}: no such directory\n'


def test_the_command_line_report(tmp_path, capsys):
    output = tmp_path / 'out'
    run_campaign(torque_free_campaign(30), scheduler='in-process', output=output)
    assert campaign_cli.main(['report', str(output), '--output', str(tmp_path / 'r')]) == 0
    assert capsys.readouterr().out.split() == [
        str(tmp_path / 'r' / 'summary.md'),
        str(tmp_path / 'r' / 'histograms.png'),
    ]
    # flips: no unit, all 30 runs finished, none undefined (a count always is)
    assert '| flips | – | 30 | 0 |' in (tmp_path / 'r' / 'summary.md').read_text()


def test_an_output_directory_with_a_damaged_manifest_or_stray_parts_is_refused(tmp_path):
    from torquefree_ros.campaigns.store import ResumeError

    output = tmp_path / 'out'
    with pytest.raises(Interrupted):
        run_campaign(
            torque_free_campaign(40),
            scheduler='in-process',
            output=output,
            chunk_size=10,
            progress=interrupt_after(10),
        )
    manifest = output / 'parts' / 'manifest.json'
    manifest.write_text('{not json')
    with pytest.raises(
        ResumeError, match=f'^{manifest}: cannot be read .*--overwrite starts over$'
    ):
        run_campaign(torque_free_campaign(40), scheduler='in-process', output=output, resume=True)
    manifest.unlink()
    with pytest.raises(
        FileExistsError, match='holds part files but no manifest.json .*--overwrite starts over'
    ):
        run_campaign(torque_free_campaign(40), scheduler='in-process', output=output, resume=True)
    plain = tmp_path / 'plain'
    plain.write_text('x')
    with pytest.raises(NotADirectoryError, match=f'^{plain}: exists and is not a directory$'):
        run_campaign(torque_free_campaign(40), scheduler='in-process', output=plain)
    table = run_campaign(
        torque_free_campaign(40), scheduler='in-process', output=output, overwrite=True
    )
    assert_same_table(run_campaign(torque_free_campaign(40), scheduler='in-process'), table)
    assert sorted(p.name for p in output.iterdir()) == ['campaign.yaml', 'runs.parquet']


# -- trajectories ---------------------------------------------------------------------------------
def trajectories_of(directory) -> pa.Table:
    """DIR/trajectories opened as a notebook would (pyarrow.dataset), rows by run then time."""
    import pyarrow.dataset as ds

    return (
        ds.dataset(directory / 'trajectories', format='parquet')
        .to_table()
        .sort_by([('run', 'ascending'), ('t', 'ascending')])
    )


def assert_same_trajectories(a: pa.Table, b: pa.Table) -> None:
    assert a.column_names == b.column_names and a.num_rows == b.num_rows
    for name in a.column_names:
        x, y = a.column(name).to_numpy(), b.column(name).to_numpy()
        assert np.array_equal(x.view(np.int64), y.view(np.int64)), name  # every bit


def test_trajectories_are_the_batch_propagation_at_the_kept_times_everywhere_and_after_a_resume(
    tmp_path, cluster
):
    """
    Kept trajectories are the batch propagation at the kept times, everywhere and after a resume.

    Every 4th sample of each run (12 s at 5 Hz: t = 0, 0.8, ..., 12): the batch propagation of the
    table's inputs at those times, bit for bit; the same rows from 1 and 2 workers and after a
    resume whose interruption left a trajectory part without its results part.
    """
    data = dict(torque_free_campaign(90), trajectories={'every': 4})
    reference_dir = tmp_path / 'in-process'
    table = run_campaign(data, scheduler='in-process', output=reference_dir, chunk_size=32)
    assert sorted(p.name for p in (reference_dir / 'trajectories').iterdir()) == [
        'runs-000000000-000000032.parquet',
        'runs-000000032-000000064.parquet',
        'runs-000000064-000000090.parquet',
    ]
    reference = trajectories_of(reference_dir)
    assert reference.column_names == ['run', 't', 'w_x', 'w_y', 'w_z', 'q_x', 'q_y', 'q_z', 'q_w']
    times = np.arange(61)[::4] / 5.0
    assert reference.num_rows == 90 * times.size  # 16 kept samples of 61
    assert np.array_equal(reference.column('t').to_numpy(), np.tile(times, 90))
    assert reference.column('run').to_pylist() == [run for run in range(90) for _ in times]
    run_campaign(
        dict(torque_free_campaign(90), trajectories={'rate': 1.25}),
        scheduler='in-process',
        output=tmp_path / 'by-rate',
    )
    # {rate: 1.25} is {every: 4}
    assert_same_trajectories(reference, trajectories_of(tmp_path / 'by-rate'))
    rows = table.to_pydict()
    for run in (0, 41, 89):  # again, one at a time, from the table's inputs: the same numbers
        moments = [[rows[f'body.moments[{k}]'][run] for k in range(3)]]
        omega0 = [[rows[f'initial.angular_velocity[{k}]'][run] for k in range(3)]]
        q0 = [[rows[f'initial.orientation[{k}]'][run] for k in range(4)]]
        omega, q = propagate_batch(
            np.array(moments), np.array(omega0), np.array(q0), np.arange(61) / 5.0
        )
        mine = reference.slice(run * 16, 16)
        assert np.array_equal(
            np.column_stack([mine.column(f'w_{a}').to_numpy() for a in 'xyz']), omega[0, ::4]
        )
        assert np.array_equal(
            np.column_stack([mine.column(f'q_{a}').to_numpy() for a in 'xyzw']), q[0, ::4]
        )
    for scheduler, workers, size in ((cluster.scheduler_address, None, 16), ('local', 1, 45)):
        output = tmp_path / f'workers-{size}'
        assert_same_table(
            table,
            run_campaign(
                data, scheduler=scheduler, workers=workers, output=output, chunk_size=size
            ),
        )
        assert_same_trajectories(reference, trajectories_of(output))

    output = tmp_path / 'resumed'
    with pytest.raises(Interrupted):
        run_campaign(
            data,
            scheduler='in-process',
            output=output,
            chunk_size=20,
            progress=interrupt_after(60),
        )
    (
        output / 'parts' / 'runs-000000040-000000060.parquet'
    ).unlink()  # died between the trajectory part and this
    assert (output / 'trajectories' / 'runs-000000040-000000060.parquet').exists()
    assert_same_table(
        table,
        run_campaign(data, scheduler='in-process', output=output, chunk_size=25, resume=True),
    )
    assert_same_trajectories(reference, trajectories_of(output))
    assert sorted(p.name for p in (output / 'trajectories').iterdir()) == [
        'runs-000000000-000000020.parquet',
        'runs-000000020-000000040.parquet',
        'runs-000000040-000000065.parquet',
        'runs-000000065-000000090.parquet',
    ]
    # a resume that finds a results part without its trajectory part computes that chunk again
    with pytest.raises(Interrupted):
        run_campaign(
            data,
            scheduler='in-process',
            output=output,
            chunk_size=30,
            overwrite=True,
            progress=interrupt_after(60),
        )
    assert not (output / 'runs.parquet').exists()
    (output / 'trajectories' / 'runs-000000030-000000060.parquet').unlink()
    assert_same_table(
        table, run_campaign(data, scheduler='in-process', output=output, resume=True)
    )
    assert_same_trajectories(reference, trajectories_of(output))


def test_trajectories_of_a_scene_with_effects_keep_its_states_and_no_failed_run_and_are_plotted(
    tmp_path, capsys
):
    """
    Kept trajectories of explorer1 (a damper, 3 states) hold its states and no failed run.

    Some runs fail: the kept rows are the finished runs', equal to the run's scene propagator at
    the kept times; the report's envelopes are numpy's percentiles of |w|.
    """
    import pyarrow.compute as pc
    from torquefree_ros.campaigns import engine
    from torquefree_ros.campaigns.report import rate_envelopes, write_report

    data = dict(damper_campaign(24), trajectories={'rate': 0.2})  # 30 s at 1 Hz: t = 0, 5, ..., 30
    output = tmp_path / 'out'
    table = run_campaign(data, scheduler='in-process', output=output, chunk_size=10)
    status = table.column('status').to_pylist()
    ok = [run for run, s in enumerate(status) if s == 'ok']
    assert 0 < len(ok) < 24
    kept = trajectories_of(output)
    assert kept.column_names[9:] == ['damper[0]', 'damper[1]', 'damper[2]']
    assert sorted(set(kept.column('run').to_pylist())) == ok  # failed runs have no rows
    campaign = load_campaign(data)
    times = np.arange(31) / 1.0
    for run in ok[:2]:
        scene = engine._scene_of(campaign, engine.draw_run(campaign, run))
        omega, q, x = scene.propagator().states(times)
        mine = kept.filter(pc.equal(kept.column('run'), run))
        assert np.array_equal(mine.column('t').to_numpy(), times[::5])
        found = np.column_stack([mine.column(name).to_numpy() for name in kept.column_names[2:]])
        # the plant's samples are the scene propagator's (CONTRACT.md): compared within 1e-12 rad/s
        np.testing.assert_allclose(
            found, np.concatenate([omega, q, x], axis=1)[::5], rtol=0, atol=1e-12
        )

    envelopes = rate_envelopes(output)
    w = np.column_stack([kept.column(f'w_{a}').to_numpy() for a in 'xyz'])
    magnitude = np.sqrt((w**2).sum(axis=1)).reshape(len(ok), 7)
    assert np.array_equal(envelopes['times'], times[::5]) and envelopes['runs'].tolist() == ok
    for p in (5, 50, 95):
        np.testing.assert_allclose(
            envelopes['percentiles'][p], np.percentile(magnitude, p, axis=0), rtol=1e-14
        )
    assert envelopes['worst_run'] == ok[int(np.argmax(magnitude[:, -1]))]
    written = write_report(output)
    assert [p.name for p in written] == ['summary.md', 'histograms.png', 'envelopes.png']
    assert (
        written[2].read_bytes()[:8] == b'\x89PNG\r\n\x1a\n' and written[2].stat().st_size > 10_000
    )
    text = written[0].read_text()
    assert (
        'Trajectories kept: every 5th sample (0.2 Hz, 7 samples a run) of each finished run '
        f'({len(ok)} runs)' in text
    )
    assert f'and the worst run, run {envelopes["worst_run"]} (by the largest final |w|)' in text
    assert '![percentile envelopes of |w|](envelopes.png)' in text
    # the worst run by a named metric, from the command line
    assert (
        campaign_cli.main(
            ['report', str(output), '--output', str(tmp_path / 'r'), '--worst', 'cone_angle']
        )
        == 0
    )
    cone = table.column('cone_angle').to_pylist()
    worst = max(ok, key=lambda run: (abs(cone[run]), -run))
    assert (
        f'run {worst} (by the largest |cone_angle|)' in (tmp_path / 'r' / 'summary.md').read_text()
    )
    assert capsys.readouterr().out.split()[-1] == str(tmp_path / 'r' / 'envelopes.png')
    assert campaign_cli.main(['report', str(output), '--worst', 'cone']) == 2
    assert "worst: 'cone' is not a metric column of the campaign" in capsys.readouterr().err


# the campaign: 12 s at 5 Hz, samples 0 to 60
@pytest.mark.parametrize(
    'value, expected',
    [
        ({'every': 0}, 'trajectories.every: must lie in [1, 60], got 0'),
        ({'every': 61}, 'trajectories.every: must lie in [1, 60], got 61'),
        ({'every': 2.5}, 'trajectories.every: expected an integer, got 2.5'),
        ({'rate': 0}, 'trajectories.rate: must be > 0 Hz, got 0'),
        ({'rate': 10}, "trajectories.rate: must be <= the campaign's rate, 5 Hz, got 10"),
        (
            {'rate': 2},
            "trajectories.rate: 2 Hz must divide the campaign's rate 5 Hz a whole number of times",
        ),
        ({'rate': 0.05}, 'trajectories.rate: 0.05 Hz keeps only the first sample of 61'),
        ({'evry': 2}, "trajectories.evry: unknown key; did you mean 'every'?"),
        (
            {'every': 2, 'rate': 1},
            'trajectories: expected {every: N} (keep every Nth sample) or {rate: HZ}',
        ),
        (True, 'trajectories: expected {every: N}'),
    ],
)
def test_a_bad_trajectories_value_names_the_file_and_the_field(value, expected, tmp_path):
    data = {
        'scene': 'dzhanibekov',
        'runs': 10,
        'seed': 1,
        'duration': 12,
        'rate': 5,
        'trajectories': value,
    }
    path = tmp_path / 'bad.yaml'
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(CampaignError) as error:
        load_campaign(path)
    assert str(error.value).startswith(f'{path}: {expected}'), str(error.value)
