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
The engine: runs in chunks, in this process or on Dask workers.

A task is a chunk of consecutive runs (:func:`run_chunk`): every run of the chunk draws its inputs
from its own generator, the physical ones go through one batch call (``propagate_batch`` for a
torque-free scene, the batched ``Plant`` for a scene with motion effects), and the metrics are
computed over the chunk's arrays. A run that cannot be made (an impossible body, an effect
parameter its scene refuses, an integrator that gives up) is a row with its status and reason; when
a batch call fails, its runs go one by one (a body of a batch is bit for bit the body alone), so
the failure is pinned on its run and the table does not depend on chunking.

Engines (:func:`execute`): ``"in-process"`` runs the chunks one after the other here; ``"local"``
starts a ``distributed.LocalCluster`` of worker processes on this machine (one per core by default,
one thread each, loopback only) for the campaign and closes it after; an address
(``tcp://host:port``) or a ``distributed.Client`` uses an existing cluster. ``None`` picks the
one that finishes first: it times the first chunk here and sends the rest to a local cluster only
when their estimated compute outweighs what the cluster adds (:func:`choose_engine`,
:data:`LOCAL_CLUSTER_STARTUP`); :class:`EngineChoice` says which ran and why. On Dask,
consecutive chunks go as one task (:func:`tasks`: fewer tasks the more chunks a worker, smaller
ones near the end), each chunk's columns coming back apart. A worker process loads
the compiled kernels once (they are module state), not once per chunk. Inside a chunk the runs go a
block at a time (:data:`BLOCK_SAMPLES`): the arrays stay small.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
import math
import os
import time
import uuid

import numpy as np

from .controllers import closed_loop, law_values, sensor_seed
from .dispersions import EffectTarget, OrbitTarget, RefusedDraw, run_generator
from .metrics import Samples
from ..core import propagate_batch
from ..core.body.rigid_body import RigidBody
from ..core.propagators.dynamics import Dynamics
from ..core.scene.loader import Scene, scene_from_mapping, SceneError

# A chunk's runs by default (chunk_runs): DEFAULT_CHUNK_RUNS, or more (up to MAX_CHUNK_RUNS) while
# every one of a known number of workers still gets CHUNKS_PER_WORKER chunks. Each chunk costs the
# client a part file and a share of a task (~1 ms of CPU), which on a small machine is taken from
# the workers: measured on 2 cores, 10 000 runs on 2 workers ran 1.77x the runs/s of 1 worker in
# 40 chunks of 256 (the client's CPU 0.17 s), 1.84x in 20 of 512 (0.14 s).
DEFAULT_CHUNK_RUNS = 256
MAX_CHUNK_RUNS = 1024
CHUNKS_PER_WORKER = 8
CHUNK_BYTES = 128 * 2**20  # samples held by one chunk at most (then fewer runs a chunk)
# A plant stepped sample by sample (a controller, sensors read) costs about the same per
# body-sample whatever the batch (measured on 2 cores, the bdot_detumble campaign: 24 to 26 us a
# body-step in batches of 32 to 256 runs; most of it each body's own Python work in the plant and
# its sensors): its chunks hold at most this many body-steps (about 25 s of CPU), so that the
# default engine, which times two chunks here before it starts a cluster, hands the rest over
# early.
STEPPED_CHUNK_BODY_STEPS = 1_000_000
# Inside a chunk, runs are propagated and measured a block of at most this many body-samples at a
# time (the same numbers: every run is computed on its own): a block's arrays (2 MB a quaternion
# array) stay in cache and far under the mmap threshold below, whatever the chunk's size and the
# runs' length.
BLOCK_SAMPLES = 65_536
# On Dask, consecutive chunks go as one task (tasks()): at most 1 / (TASKS_PER_WORKER * workers) of
# the chunks a task, and a (TAPER * workers)-th of those left near the end. Measured on 2 cores,
# 10 000 runs in 40 chunks on 2 workers: this process's CPU 0.32 s with a task a chunk, 0.16 to
# 0.20 s in 13 tasks; the two workers end within a few hundredths of a second of each other.
TASKS_PER_WORKER = 4
TAPER = 2
# glibc's allocator for a local cluster's workers. Its default thresholds move with what was freed
# last, and a block's arrays then keep going back to the kernel and faulting in afresh: measured,
# 10 000 runs of 1 001 samples in one process took 0.5 to 1.6 s of system time beside 2.5 s of user
# time, depending on the process's history; with these fixed thresholds, none.
MALLOC_ENVIRONMENT = {
    'MALLOC_MMAP_THRESHOLD_': str(32 * 2**20),
    'MALLOC_TRIM_THRESHOLD_': str(128 * 2**20),
}
OK, INVALID_BODY, INVALID_SCENE, FAILED = 'ok', 'invalid_body', 'invalid_scene', 'failed'
# a chunk's entry (not a column of the table) holding its runs' decimated samples,
# when the campaign keeps them
TRAJECTORIES = '__trajectories__'


def block_runs(campaign) -> int:
    """
    Return how many runs are propagated and measured together inside a chunk.

    A plant stepped sample by sample (a controller, sensors read) takes the whole chunk as one
    batch: its cost is a sample's Python work, shared by every body of the batch.
    """
    if campaign.steps_plant:
        return MAX_CHUNK_RUNS
    return max(1, BLOCK_SAMPLES // campaign.samples)


def chunk_runs(campaign, requested: int | None = None, workers: int | None = None) -> int:
    """
    Return the runs of a chunk: ``requested``, or the default for ``workers`` (None: unknown).

    The default is :data:`DEFAULT_CHUNK_RUNS`, larger (up to :data:`MAX_CHUNK_RUNS`) while each of
    ``workers`` still gets :data:`CHUNKS_PER_WORKER` chunks, and smaller when a chunk's samples
    would pass :data:`CHUNK_BYTES`. The table does not depend on it.
    """
    if requested is not None:
        if isinstance(requested, bool) or not isinstance(requested, int) or requested < 1:
            raise ValueError(f'chunk_size: expected a positive integer, got {requested!r}')
        return requested
    runs = DEFAULT_CHUNK_RUNS
    if workers:
        share = -(-campaign.runs // (CHUNKS_PER_WORKER * workers))
        runs = max(runs, min(MAX_CHUNK_RUNS, share))
    if campaign.steps_plant:
        runs = max(1, min(runs, STEPPED_CHUNK_BODY_STEPS // plant_steps(campaign)))
    width = 7 + 8  # rates, attitude and a few effect states, float64
    return max(1, min(runs, CHUNK_BYTES // (campaign.samples * width * 8)))


def plant_steps(campaign) -> int:
    """Return a run's plant samples when the plant steps (at the controller's rate)."""
    controller = campaign.controller
    every = controller.every(campaign.rate) if controller else 1
    return (campaign.samples - 1) * every + 1


def check_workers(workers) -> None:
    if workers is not None and (
        isinstance(workers, bool) or not isinstance(workers, int) or workers < 1
    ):
        raise ValueError(f'workers: expected a positive integer, got {workers!r}')


def expected_workers(scheduler, workers: int | None) -> int | None:
    """
    Return how many workers a campaign on ``scheduler`` will have, when it is known beforehand.

    In-process: 1; a local cluster: ``workers`` or one per core; a ``distributed.Client``: its
    worker threads now; a scheduler's address: None (not asked before the campaign starts).
    """
    check_workers(workers)
    if scheduler == 'in-process':
        return 1
    if scheduler is None or scheduler == 'local':
        return workers or os.cpu_count() or 1
    if isinstance(scheduler, str):
        return None
    return sum(scheduler.nthreads().values()) or None


def chunks(campaign, size: int) -> list[tuple[int, int]]:
    return [(start, min(start + size, campaign.runs)) for start in range(0, campaign.runs, size)]


# -- one run's inputs -----------------------------------------------------------------------------
@dataclass
class Draw:
    run: int
    values: dict  # target path -> drawn array
    inertia: np.ndarray | None = None  # what the scene takes: 3 moments or 6 tensor elements
    omega: np.ndarray | None = None
    q: np.ndarray | None = None
    redraws: int = 0
    status: str = OK
    reason: str | None = None
    body: RigidBody | None = None
    scene: Scene | None = None  # the run's scene, for a scene with effects


def body_from_draw(campaign, values: np.ndarray) -> np.ndarray:
    """Return the scene's inertia numbers for drawn ``values`` of the body target."""
    target = campaign.body_target
    if target.path == 'body.inertia' or len(campaign.scene.inertia) == 3:
        return values
    # a tensor scene keeps its axes
    axes = RigidBody.from_inertia(campaign.scene.inertia).principal_axes
    tensor = (axes * values) @ axes.T
    return np.array(
        [tensor[0, 0], tensor[1, 1], tensor[2, 2], tensor[0, 1], tensor[0, 2], tensor[1, 2]]
    )


def draw_run(campaign, run: int) -> Draw:
    rng = run_generator(campaign.seed, run)
    scene = campaign.scene
    draw = Draw(run, {})
    for target in campaign.targets:
        try:
            draw.values[target.path] = target.draw(rng, run)
        except RefusedDraw as refused:  # the run fails; its other targets still draw theirs
            draw.values[target.path] = refused.values
            if draw.status == OK:
                draw.status, draw.reason = INVALID_SCENE, refused.reason
    draw.omega = draw.values.get(
        'initial.angular_velocity', np.asarray(scene.angular_velocity, dtype=float)
    )
    draw.q = draw.values.get('initial.orientation', np.asarray(scene.orientation, dtype=float))
    target = campaign.body_target
    if target is None:
        draw.inertia = np.asarray(scene.inertia, dtype=float)
        draw.body = RigidBody.from_inertia(draw.inertia)
        return draw
    while True:
        values = target.draw(rng, run)
        draw.values[target.path] = values
        draw.inertia = body_from_draw(campaign, values)
        try:
            draw.body = RigidBody.from_inertia(draw.inertia, 'inertia')
            return draw
        except ValueError as error:
            if draw.status != OK:  # failed already: no redraw
                return draw
            if campaign.invalid_body == 'fail' or draw.redraws >= campaign.max_redraws:
                draw.status, draw.reason = INVALID_BODY, str(error)
                if campaign.invalid_body == 'redraw':
                    draw.reason += f' (after {draw.redraws} redraws)'
                return draw
            draw.redraws += 1


def scene_document(campaign, draw: Draw) -> dict:
    """
    Return the run's scene as a scene file's mapping: the campaign's scene with the drawn values.

    The body is written as its inertia (3 moments or 6 tensor elements), the initial state whole,
    and each effect, fault or orbit element a target draws at its place; the rest is the scene
    file's own. Written out as YAML (``yaml.safe_dump``, which writes a float so that it reads back
    the same) and loaded, it is the run's scene.
    """
    document = {
        key: copy.deepcopy(value)
        for key, value in campaign.scene_document.items()
        if key not in ('sweep',)
    }
    document['body'] = {'inertia': [float(x) for x in draw.inertia]}
    document['initial'] = {
        'angular_velocity': [float(x) for x in draw.omega],
        'orientation': [float(x) for x in draw.q],
    }
    document['effects'] = document.get('effects') or []
    for target in campaign.targets:
        if isinstance(target, (EffectTarget, OrbitTarget)):
            target.place(document, draw.values[target.path])
    if campaign.sensor_seeds == 'per_run':
        _place_sensor_seeds(campaign, document, draw.run)
    return document


def _place_sensor_seeds(campaign, document: dict, run: int) -> None:
    """Write run ``run``'s seed into each output that takes one (``sensor_seeds: per_run``)."""
    from ..core.effects.base import EFFECTS, OutputEffect

    outputs = 0
    effects = document['effects'] = list(document['effects'])
    for index, entry in enumerate(effects):
        ((name, parameters),) = entry.items()
        kind = EFFECTS.get(name)
        if kind is None or not issubclass(kind, OutputEffect):
            continue
        if 'seed' in kind.parameters:
            parameters = dict(parameters or {})
            parameters['seed'] = sensor_seed(campaign.seed, run, outputs)
            effects[index] = {name: parameters}
        outputs += 1


def run_scene(campaign, run: int) -> dict:
    """
    Return run ``run``'s scene as a scene file's mapping (see :func:`scene_document`).

    A run whose draw makes no body (``invalid_body``) or none of a whole vector (a negative
    magnitude) raises ``ValueError`` with its reason; a mapping the scene's checks refuse
    (``invalid_scene``) is returned as drawn: loading it raises the run's reason.
    """
    draw = draw_run(campaign, run)
    if draw.status != OK:
        raise ValueError(f'run {run}: {draw.status}: {draw.reason}')
    return scene_document(campaign, draw)


def _scene_of(campaign, draw: Draw):
    """Build the run's scene (:func:`scene_document`), checked as a scene file is."""
    return scene_from_mapping(scene_document(campaign, draw), source=f'run {draw.run}')


# -- a chunk --------------------------------------------------------------------------------------
def run_chunk(campaign, start: int, stop: int) -> dict:
    """
    Run ``start .. stop - 1``; return a dict of columns.

    The columns are numpy arrays (``status`` and ``reason`` lists), and under :data:`TRAJECTORIES`
    the finished runs' kept samples (a dict of columns) when the campaign keeps them.
    """
    # the same on every worker
    with np.errstate(divide='ignore', invalid='ignore', over='ignore', under='ignore'):
        return _run_chunk(campaign, start, stop)


def _run_chunk(campaign, start: int, stop: int) -> dict:
    draws = [draw_run(campaign, run) for run in range(start, stop)]
    times = np.arange(campaign.samples) / campaign.rate
    scenes = {}
    if campaign.builds_run_scenes:
        # every run's scene is checked as a scene file is, also where only its outputs, faults or
        # orbit are drawn (a torque-free motion, propagated without it)
        for draw in draws:
            if draw.status == OK:
                try:
                    draw.scene = _scene_of(campaign, draw)
                except SceneError as error:
                    draw.status, draw.reason = INVALID_SCENE, str(error).split(': ', 1)[-1]
                    continue
                if campaign.runs_plant:
                    scenes[draw.run] = draw.scene
    ready = [draw for draw in draws if draw.status == OK]
    nominal = _nominal(campaign, times) if campaign.needs_nominal and ready else None
    ok, blocks, size = [], [], block_runs(campaign)
    # the decimated samples of the finished runs, by block
    kept = [] if campaign.trajectory_every else None
    for low in range(0, len(ready), size):  # a block at a time: see BLOCK_SAMPLES
        block = ready[low: low + size]
        trajectories = _propagate(campaign, block, scenes, times)
        finished = [draw for draw in block if draw.status == OK]
        if finished:
            blocks.append(_metrics(campaign, finished, trajectories, times, nominal))
            ok += finished
            if kept is not None:  # after the metrics: a run a metric failed on has no trajectory
                kept += [
                    (
                        draw.run,
                        *(a[:: campaign.trajectory_every] for a in trajectories[draw.run][:3]),
                    )
                    for draw in finished
                    if draw.status == OK
                ]
    columns = {
        'run': np.arange(start, stop, dtype=np.int64),
        'redraws': np.array([d.redraws for d in draws], dtype=np.int64),
    }
    for target in campaign.targets + ((campaign.body_target,) if campaign.body_target else ()):
        values = np.array([d.values[target.path] for d in draws]).reshape(len(draws), -1)
        for k, column in enumerate(target.columns):
            columns[column] = values[:, k]
    metric_values = (
        {
            column: np.concatenate([block[column] for block in blocks])
            for column in campaign.metric_columns
        }
        if blocks
        else {}
    )
    index = {draw.run - start: i for i, draw in enumerate(ok)}
    rows = np.array(sorted(index), dtype=np.int64)
    picked = np.array([index[r] for r in rows], dtype=np.int64)
    for use in campaign.metrics:
        for column in use.columns:
            array = np.zeros(len(draws), dtype=use.metric.dtype)
            if rows.size:
                array[rows] = metric_values[column][picked]
            columns[column] = array
    columns['status'] = [d.status for d in draws]
    columns['reason'] = [d.reason for d in draws]
    if kept is not None:
        columns[TRAJECTORIES] = _trajectory_columns(campaign, kept)
    return columns


def _trajectory_columns(campaign, kept: list) -> dict:
    """
    Return the chunk's kept samples as columns, by run then time.

    The columns are :attr:`Campaign.trajectory_columns`.
    """
    t = campaign.trajectory_times
    names = campaign.trajectory_columns
    if not kept:
        return {name: np.empty(0, dtype=np.int64 if name == 'run' else float) for name in names}
    run = np.repeat(np.array([k[0] for k in kept], dtype=np.int64), t.size)
    values = np.concatenate(
        [np.concatenate([omega, q, internal], axis=1) for _, omega, q, internal in kept]
    )
    columns = {'run': run, 't': np.tile(t, len(kept))}
    for k, name in enumerate(names[2:]):
        columns[name] = np.ascontiguousarray(values[:, k])
    return columns


def _propagate(campaign, ok: list, scenes: dict, times: np.ndarray) -> dict:
    """
    Propagate the runs: run -> (omega (M, 3), q (M, 4), internal (M, s)).

    A run that fails gets its status and reason.
    """
    if not ok:
        return {}
    try:
        arrays = _batch(campaign, ok, scenes, times)
        return {draw.run: _run_of(arrays, i) for i, draw in enumerate(ok)}
    except (ValueError, RuntimeError, ArithmeticError):
        pass
    result = {}
    for draw in ok:  # one by one: the failure is pinned on its run
        try:
            arrays = _batch(campaign, [draw], scenes, times)
            result[draw.run] = _run_of(arrays, 0)
        except (ValueError, RuntimeError, ArithmeticError) as error:
            draw.status, draw.reason = FAILED, str(error)
    return result


def _run_of(arrays, i: int) -> tuple:
    """Return run ``i``'s part of a batch's arrays (and of a dict of them, recorded ones)."""
    return tuple(
        {key: value[i] for key, value in a.items()} if isinstance(a, dict) else a[i]
        for a in arrays
    )


def _batch(campaign, draws: list, scenes: dict, times: np.ndarray):
    if campaign.steps_plant:
        return closed_loop(
            campaign, [scenes[d.run] for d in draws], law_values(campaign, draws)
        )
    if campaign.scene.torque_free:
        omega, q = propagate_batch(
            np.array([d.inertia for d in draws]),
            np.array([d.omega for d in draws]),
            np.array([d.q for d in draws]),
            times,
        )
        return omega, q, np.empty(omega.shape[:2] + (0,))
    from ..plant import Plant

    plant = Plant([scenes[d.run] for d in draws], campaign.rate)
    first = plant.state
    rest = plant.run(campaign.duration)
    # the rates, attitudes and effects' states (the wheels' speeds are in the last)
    return tuple(
        np.concatenate([a0[:, None, :], a], axis=1) for a0, a in zip(first[:3], rest[:3])
    )


def _nominal(campaign, times) -> Samples:
    scene = campaign.scene
    draw = Draw(
        -1,
        {},
        np.asarray(scene.inertia, dtype=float),
        np.asarray(scene.angular_velocity, dtype=float),
        np.asarray(scene.orientation, dtype=float),
        body=RigidBody.from_inertia(scene.inertia),
        scene=None if not campaign.runs_plant else scene,
    )
    scenes = {-1: scene} if campaign.runs_plant else {}
    return _samples(times, [draw], *_batch(campaign, [draw], scenes, times))


def _samples(times, draws, omega, q, internal, recorded=None, nominal=None) -> Samples:
    return Samples(
        times,
        omega,
        q,
        internal,
        np.array([d.body.tensor for d in draws]),
        np.array([d.body.moments for d in draws]),
        np.array([d.body.principal_axes for d in draws]),
        nominal,
        # each run's body with its effects: the invariants count what the effects carry
        _systems(draws),
        recorded,
    )


def _systems(draws) -> tuple | None:
    """Return each run's body with its motion effects, or None for a torque-free scene."""
    if draws[0].scene is None or draws[0].scene.torque_free:
        return None
    return tuple(Dynamics(d.body, d.scene.effects) for d in draws)


def _metrics(campaign, ok: list, trajectories: dict, times, nominal) -> dict:
    stacked = [np.stack([trajectories[d.run][k] for d in ok]) for k in range(3)]
    if campaign.steps_plant:
        recorded = trajectories[ok[0].run][3]
        stacked.append(
            {key: np.stack([trajectories[d.run][3][key] for d in ok]) for key in recorded}
        )
    samples = _samples(times, ok, *stacked, nominal=nominal)
    result = {}
    for use in campaign.metrics:
        try:
            result.update(use.evaluate(samples))
        except Exception:  # noqa: BLE001 - a metric's bug is pinned on the runs it fails on
            result.update(_metric_one_by_one(use, ok, stacked, times, nominal))
    return result


def _metric_one_by_one(use, ok, stacked, times, nominal) -> dict:
    columns = {column: np.zeros(len(ok), dtype=use.metric.dtype) for column in use.columns}
    for i, draw in enumerate(ok):
        try:
            values = use.evaluate(
                _samples(
                    times,
                    [draw],
                    *(
                        {k: v[i: i + 1] for k, v in a.items()} if isinstance(a, dict)
                        else a[i: i + 1]
                        for a in stacked
                    ),
                    nominal=nominal,
                )
            )
        except Exception as error:  # noqa: BLE001
            draw.status, draw.reason = (
                FAILED,
                f'metric {use.metric.name}: {type(error).__name__}: {error}',
            )
            continue
        for column, array in values.items():
            columns[column][i] = array[0]
    return columns


# -- engines --------------------------------------------------------------------------------------
# What a local cluster adds to a campaign's wall time besides its share of the compute: starting
# its worker processes, each worker's first imports and kernels, and closing it. The default engine
# weighs it against the compute it would share (choose_engine); tools/bench_campaign.py measures
# it on the machine at hand (docs/bench/campaign.md).
LOCAL_CLUSTER_STARTUP = 3.0  # s


@dataclass(frozen=True)
class EngineChoice:
    """The engine that runs a campaign's chunks, and why: what a campaign reports once."""

    engine: str  # 'in-process', 'local' (a local cluster) or 'cluster' (an existing one)
    reason: str
    workers: int | None = None  # a cluster's worker threads (one per local worker process)

    @property
    def label(self) -> str:
        """Return the engine in a few words: ``in-process``, ``local cluster of 2 workers``."""
        if self.engine == 'in-process':
            return 'in-process'
        count = f'{self.workers} worker{"s" if self.workers != 1 else ""}'
        return f'local cluster of {count}' if self.engine == 'local' else f'cluster of {count}'

    def __str__(self) -> str:
        return f'{self.label}: {self.reason}'


def _seconds(value: float) -> str:
    return f'{value:.2g} s' if value < 10 else f'{value:,.0f} s'


def choose_engine(
    estimated_compute_s: float, cluster_startup_s: float, workers: int
) -> EngineChoice:
    """
    Pick the engine that finishes first: this process, or a local cluster of ``workers``.

    This process takes ``estimated_compute_s``; a local cluster ``cluster_startup_s`` (start-up,
    warm-up and close), then the compute shared by its workers, at best ``estimated_compute_s /
    workers``. A tie stays in this process: a cluster would bring nothing.
    """
    if workers <= 1:
        return EngineChoice(
            'in-process', 'a local cluster of 1 worker is never faster than this process'
        )
    share = estimated_compute_s / workers
    on_cluster = cluster_startup_s + share
    what = (
        f'about {_seconds(estimated_compute_s)} of compute left, against '
        f'{_seconds(on_cluster)} on a local cluster of {workers} workers '
        f'({_seconds(cluster_startup_s)} to start and close, then {_seconds(share)})'
    )
    if estimated_compute_s <= on_cluster:
        return EngineChoice('in-process', what)
    return EngineChoice('local', what, workers)


def execute(
    campaign,
    ranges=None,
    scheduler=None,
    workers: int | None = None,
    on_chunk=None,
    on_engine=None,
) -> list[dict]:
    """
    Run the chunks; return every chunk's columns, in the order of ``ranges``.

    ``ranges`` holds ``(start, stop)`` pairs; default: the whole campaign in chunks of
    :func:`chunk_runs`. ``on_chunk(start, stop, columns)`` is called in this process as each chunk
    completes (in completion order; on Dask, a task's chunks one after the other in run order as
    the task completes), once per chunk, even when Dask runs a chunk again because its worker was
    lost (a chunk's columns depend only on the campaign and its runs). ``on_engine(choice)`` is
    called once with the :class:`EngineChoice`, when the engine is settled.

    ``scheduler=None`` runs the first chunk here, timed (CPU time): when its time per run, over
    the runs left, comes to more than a local cluster would take (:func:`choose_engine`), the rest
    goes to a local cluster, else it stays here. A first chunk in a process also loads the
    kernels, so a choice of the cluster is confirmed by a second chunk timed here. The chunks
    timed count: none is computed twice.
    """
    if ranges is None:
        parts = chunks(campaign, chunk_runs(campaign, None, expected_workers(scheduler, workers)))
    else:
        parts = list(ranges)
    check_workers(workers)
    if scheduler is None:
        return _automatic(campaign, parts, workers, on_chunk, on_engine)
    if scheduler == 'in-process':
        if on_engine:
            on_engine(EngineChoice('in-process', 'as asked'))
        return _in_process(campaign, parts, on_chunk)
    return _on_dask(campaign, parts, scheduler, workers, on_chunk, on_engine)


def _in_process(campaign, parts, on_chunk) -> list[dict]:
    results = []
    for start, stop in parts:
        results.append(run_chunk(campaign, start, stop))
        if on_chunk:
            on_chunk(start, stop, results[-1])
    return results


def _automatic(campaign, parts, workers, on_chunk, on_engine) -> list[dict]:
    """Run the first chunks here, timed, then the rest where it finishes first."""
    if not parts:
        return []
    workers = expected_workers('local', workers)
    # the fastest chunk's CPU seconds per run: CPU time, like the cluster's start-up (a constant),
    # does not grow with the load other processes put on the machine
    results, per_run = [], math.inf
    for index, (start, stop) in enumerate(parts):
        began = time.process_time()
        results.append(run_chunk(campaign, start, stop))
        per_run = min(per_run, (time.process_time() - began) / (stop - start))
        if on_chunk:
            on_chunk(start, stop, results[-1])
        rest = parts[index + 1:]
        if not rest:
            break
        choice = choose_engine(
            per_run * sum(b - a for a, b in rest), LOCAL_CLUSTER_STARTUP, workers
        )
        if choice.engine == 'in-process':
            if on_engine:
                on_engine(choice)
            return results + _in_process(campaign, rest, on_chunk)
        if index >= 1:
            if on_engine:
                on_engine(choice)
            return results + _on_dask(campaign, rest, 'local', workers, on_chunk)
    if on_engine:
        on_engine(
            EngineChoice(
                'in-process',
                'one chunk to compute'
                if len(parts) == 1
                else 'two chunks to compute, both timed here',
            )
        )
    return results


def run_chunks(campaign, ranges) -> list[dict]:
    """Run consecutive chunks (one Dask task); return each chunk's columns (:func:`run_chunk`)."""
    return [run_chunk(campaign, start, stop) for start, stop in ranges]


def tasks(parts: list, workers: int) -> list[list]:
    """
    Group consecutive chunks into Dask tasks for a cluster of ``workers`` threads, in order.

    A task costs this process (the scheduler of a local cluster, the client) a few ms of CPU, which
    on a small machine is taken from the workers: a task holds at most ``1 / (TASKS_PER_WORKER *
    workers)`` of the chunks, and less as the campaign nears its end (a ``TAPER * workers``-th of
    the chunks left, at least one), so that the workers finish together. Without a known number of
    workers (0: none connected yet), a task is a chunk.
    """
    if workers < 1:
        return [[part] for part in parts]
    largest = max(1, len(parts) // (TASKS_PER_WORKER * workers))
    groups, low = [], 0
    while low < len(parts):
        size = min(largest, -(-(len(parts) - low) // (TAPER * workers)))
        groups.append(parts[low: low + size])
        low += size
    return groups


def local_cluster(workers: int):
    """
    Start a ``distributed.LocalCluster`` of worker processes on this machine, one thread each.

    Everything is on loopback: the scheduler's HTTP server (health routes; no dashboard) on a free
    port of 127.0.0.1, not on 8787 of every interface. A script that starts one must be guarded by
    ``if __name__ == "__main__":`` (workers are spawned processes that import the script's main
    module).
    """
    import dask
    from distributed import LocalCluster

    # Dask spawns workers with MALLOC_TRIM_THRESHOLD_=65536, which also freezes glibc's mmap
    # threshold: every array of a chunk is then fresh pages from the kernel, and a chunk takes
    # twice as long (measured: 0.155 s against 0.076 s for 256 runs of 1001 samples). Both
    # thresholds are set instead (MALLOC_ENVIRONMENT). The thread limits stay.
    environment = {
        key: value
        for key, value in dask.config.get('distributed.nanny.pre-spawn-environ').items()
        if key != 'MALLOC_TRIM_THRESHOLD_'
    }
    environment.update(MALLOC_ENVIRONMENT)
    with dask.config.set({'distributed.nanny.pre-spawn-environ': environment}):
        return LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            host='127.0.0.1',
            dashboard_address=None,
            scheduler_kwargs={'dashboard': False, 'dashboard_address': '127.0.0.1:0'},
        )


def _on_dask(campaign, parts, scheduler, workers, on_chunk, on_engine=None) -> list[dict]:
    from distributed import as_completed, Client

    cluster = None
    if isinstance(scheduler, Client):
        client, own_client = scheduler, False
    elif scheduler == 'local':
        workers = expected_workers('local', workers)
        cluster = local_cluster(workers)
        client, own_client = Client(cluster), True
    elif isinstance(scheduler, str):
        if workers is not None:
            raise ValueError(
                'workers: only for the local cluster; an existing cluster has its own workers'
            )
        client, own_client = Client(scheduler, timeout='30s'), True
    else:
        raise ValueError(
            "scheduler: expected None, 'in-process', 'local', an address or a "
            f'distributed.Client, got {scheduler!r}'
        )
    try:
        token = uuid.uuid4().hex[:12]
        if cluster is None:  # an existing cluster: its worker threads now
            workers = sum(client.nthreads().values())
        if on_engine:
            on_engine(
                EngineChoice('local', 'as asked', workers)
                if cluster is not None
                else EngineChoice('cluster', f'as asked ({client.scheduler.address})', workers)
            )
        groups = tasks(parts, workers)
        # one message for the whole campaign; a task's key names its first run (zero-padded: the
        # keys sort in run order, which is the order the tasks are given out)
        futures = client.map(
            run_chunks,
            [campaign] * len(groups),
            groups,
            key=[f'torquefree-campaign-{token}-{group[0][0]:09d}' for group in groups],
            pure=False,
            retries=2,
        )
        index_of = {future: index for index, future in enumerate(futures)}
        done = {}
        # as_completed yields each future once; a task whose worker died is run again by the
        # scheduler (its result, if already computed and lost with the worker, too) before its
        # future completes. It watches on this client's loop: by default it takes the default
        # client's, another one when the process holds several clients, and a future reset after a
        # lost worker then waits on the wrong loop.
        for future in as_completed(futures, loop=client.loop):
            index = index_of[future]
            done[index] = future.result()
            future.release()
            if on_chunk:
                for (start, stop), columns in zip(groups[index], done[index]):
                    on_chunk(start, stop, columns)
        return [columns for index in range(len(groups)) for columns in done[index]]
    finally:
        if own_client:
            client.close()
        if cluster is not None:
            cluster.close()
