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
Monte Carlo campaigns: one scene dispersed over thousands of runs, a row of metrics per run.

The room, in the order a campaign flows through it:

* :mod:`.spec` — the **campaign file** (YAML, checked like a scene: every error names the file and
  the field path): the base scene (by name, by file, or written inline), the runs, the seed, the
  time grid, the dispersions, what to do with an impossible body, the metrics.
* :mod:`.dispersions` — **dispersions** (Basilisk's vocabulary): per target of the scene (the
  body's moments or tensor, the initial rate, the attitude, any number or vector of an effect or
  an output by its path, list items by index, a sensor fault's numbers, the orbit's Keplerian
  elements), a mode (relative, absolute, replace) and a distribution (normal,
  uniform, truncated normal, a list of values for a sweep); a vector per component or as a whole
  (its direction turned within a cone or by a small rotation, a wheel's axis tilted by a
  misalignment, its magnitude dispersed). Run ``i``
  draws from ``SeedSequence(seed).spawn(runs)[i]`` only.
* :mod:`.metrics` — **metrics**: what a run keeps (final rates, settle time, cone angle, flips,
  energy and momentum drift of the whole system, attitude error from the nominal run, the wheels'
  momentum peak, each wheel's peak and saturation time, a sensor's peak reading, the rods' duty),
  one registry and a decorator
  (:func:`metric`) for adding one as a Python function.
* :mod:`.controllers` — **closed loop**: a ``controller:`` law (the built-in ``bdot``, or a user's
  ``package.module:factory``) run per run at its own rate on the batched ``Plant``, reading its
  sensors and commanding it; per-run sensor seeds (``sensor_seeds: per_run``).
* :mod:`.engine` — the **engine**: chunks of runs through the batch paths (``propagate_batch``, the
  batched ``Plant``, stepped with its sensors read for a controller), in this process or on Dask
  workers (by default whichever finishes first: the first chunk timed here against a local
  cluster's start-up; or an existing cluster by address); a run that fails is a row with its
  reason, never the end of the campaign.
* :mod:`.results` — **results**: one table (pyarrow, written as Parquet), a row per run with its
  drawn inputs, metrics and status, and the campaign file and versions in its metadata.

* :mod:`.store` — the **output directory**: each finished chunk as a part file as it completes,
  then the table; an interrupted campaign resumes from its parts; the decimated trajectories, when
  asked, as Parquet parts a notebook opens lazily (``pyarrow.dataset``; ``dask.dataframe`` with
  pandas installed).
* :mod:`.report` — the **report**: histograms of the metrics, the worst runs, percentile envelopes
  of ``|w|`` over time when trajectories were kept, a Markdown summary.

``run_campaign(path_or_mapping)`` is the Python API; ``torquefree_campaign run`` and ``report`` the
command line. The table is the same, bit for bit, in-process, on 1 or 2 workers, with another chunk
size, or resumed after an interruption.
"""

from __future__ import annotations

from .metrics import Metric, metric, METRICS, Samples
from .spec import Campaign, CampaignError, library_campaigns, load_campaign


def run_scene(path_or_mapping, run: int) -> dict:
    """
    Return run ``run``'s scene as a scene file's mapping: the campaign's scene with its draws.

    Written out (``yaml.safe_dump``) and loaded as a scene, it is the scene the run ran: its body,
    initial state, effects, outputs, faults and orbit (see ``engine.scene_document``).
    """
    from .engine import run_scene as scene_of_run

    return scene_of_run(load_campaign(path_or_mapping), run)


def run_campaign(
    path_or_mapping,
    scheduler=None,
    workers: int | None = None,
    output=None,
    *,
    chunk_size: int | None = None,
    overwrite: bool = False,
    resume: bool = False,
    progress=None,
    on_engine=None,
):
    """
    Run a campaign and return its table (``pyarrow.Table``, see :mod:`.results`).

    The campaign is a file, a library campaign's name, a mapping or a :class:`Campaign`.

    ``scheduler``: ``None`` (whichever finishes first, this process or a local cluster: the first
    chunk is timed here, and the rest goes to a local cluster only when its estimated compute
    outweighs the cluster's start-up, see ``engine.choose_engine``), ``"in-process"``,
    ``"local"``, a Dask scheduler's address or a ``distributed.Client``; ``workers``: the local
    cluster's worker processes (default: one per core); ``chunk_size``: runs per chunk, a part
    file and a progress step (default: ``engine.chunk_runs``, by the number of workers; the table
    does not depend on it; on Dask a task runs several consecutive chunks);
    ``progress(done_runs, total_runs)``: called once before the first chunk (``done_runs`` = the
    runs a resumed campaign already holds) and after each chunk; ``on_engine(choice)``: called
    once, when the engine is settled, with an ``engine.EngineChoice`` (``engine``:
    ``"in-process"``, ``"local"`` or ``"cluster"``; ``workers``; ``reason``; ``str(choice)`` says
    it in a line); not called when nothing is left to compute. The table does not depend on the
    engine.

    ``output``: a directory (see :mod:`.store`) that keeps each finished chunk as it completes and
    then the table as ``runs.parquet``. It must not hold a campaign yet, unless ``overwrite``
    (start over) or ``resume``: continue the campaign it holds, computing only the runs no finished
    chunk holds (the result is bit for bit the uninterrupted run's table); the campaign file, its
    scene and the versions must be the same (:class:`.store.ResumeError` says what differs).
    Resuming a finished campaign returns its table. A campaign file that asks for ``trajectories``
    has its finished runs' kept samples written to ``output/trajectories/`` (see :mod:`.store`);
    without ``output`` they are not computed.
    """
    from .engine import chunk_runs, chunks, execute, expected_workers, TRAJECTORIES
    from .results import build_table
    from .store import CampaignDirectory

    campaign = load_campaign(path_or_mapping)
    size = chunk_runs(campaign, chunk_size, expected_workers(scheduler, workers))
    # what the chunks run: the same runs, without trajectories when there is nowhere to write them
    computed = campaign
    if output is None:
        if campaign.trajectory_every:
            from dataclasses import replace

            computed = replace(campaign, trajectory_every=None)
        store, ranges, parts = None, chunks(campaign, size), {}
    else:
        store = CampaignDirectory.prepare(output, campaign, overwrite=overwrite, resume=resume)
        if store.finished_table is not None:
            if progress:
                progress(campaign.runs, campaign.runs)
            return store.finished_table
        ranges, parts = store.missing(size), {}
    done = store.done_runs if store else 0
    if progress:
        progress(done, campaign.runs)

    def finished(start, stop, columns):
        nonlocal done
        trajectories = columns.pop(TRAJECTORIES, None)
        if store:
            # first: a results part on disk has its trajectory part beside it
            if trajectories is not None:
                store.write_trajectories(start, stop, trajectories)
            store.write_part(start, stop, columns)
        parts[start] = columns
        done += stop - start
        if progress:
            progress(done, campaign.runs)

    if ranges:
        execute(computed, ranges, scheduler, workers, finished, on_engine)
    if store:
        for start in store.parts:
            if start not in parts:
                parts[start] = store.read_part(start)
    table = build_table(campaign, [parts[start] for start in sorted(parts)])
    if store:
        store.finish(table)
    return table


__all__ = [
    'METRICS',
    'Campaign',
    'CampaignError',
    'Metric',
    'Samples',
    'library_campaigns',
    'load_campaign',
    'metric',
    'run_campaign',
    'run_scene',
]
