"""Monte Carlo campaigns: one scene dispersed over thousands of runs, a row of metrics per run.

The room, in the order a campaign flows through it:

* :mod:`.spec` — the **campaign file** (YAML, checked like a scene: every error names the file and
  the field path): the base scene, the runs, the seed, the time grid, the dispersions, what to do
  with an impossible body, the metrics.
* :mod:`.dispersions` — **dispersions** (Basilisk's vocabulary): per target of the scene (the body's
  moments or tensor, the initial rate per axis, the attitude, any number parameter of an effect),
  a mode (relative, absolute, replace) and a distribution (normal, uniform, truncated normal, a list
  of values for a sweep). Run ``i`` draws from ``SeedSequence(seed).spawn(runs)[i]`` only.
* :mod:`.metrics` — **metrics**: what a run keeps (final rates, settle time, cone angle, flips,
  energy and momentum drift, attitude error from the nominal run), one registry and a decorator
  (:func:`metric`) for adding one as a Python function.
* :mod:`.engine` — the **engine**: chunks of runs through the batch paths (``propagate_batch``, the
  batched ``Plant``), in this process or on Dask workers (a local cluster by default, or an existing
  cluster by address); a run that fails is a row with its reason, never the end of the campaign.
* :mod:`.results` — **results**: one table (pyarrow, written as Parquet), a row per run with its
  drawn inputs, metrics and status, and the campaign file and versions in its metadata.

``run_campaign(path_or_mapping)`` is the Python API; ``torquefree_campaign run`` the command line.
The table is the same, bit for bit, in-process, on 1 or 2 workers, or with another chunk size.
"""

from __future__ import annotations

from .metrics import METRICS, Metric, Samples, metric
from .spec import Campaign, CampaignError, library_campaigns, load_campaign


def run_campaign(path_or_mapping, scheduler=None, workers: int | None = None, output=None, *,
                 chunk_size: int | None = None, overwrite: bool = False, progress=None):
    """Run a campaign (a file, a library campaign's name, a mapping or a :class:`Campaign`) and return
    its table (``pyarrow.Table``, see :mod:`.results`). ``scheduler``: ``None`` (a local cluster, or
    this process for a campaign of one chunk), ``"in-process"``, ``"local"``, a Dask scheduler's
    address or a ``distributed.Client``; ``workers``: the local cluster's worker processes (default:
    one per core); ``output``: a directory to write ``runs.parquet`` into; ``chunk_size``: runs per
    task (the table does not depend on it); ``progress(done_runs, total_runs)``."""
    from .engine import execute
    from .results import build_table, write_results

    campaign = load_campaign(path_or_mapping)
    table = build_table(campaign, execute(campaign, scheduler, workers, chunk_size, progress))
    if output is not None:
        write_results(table, campaign, output, overwrite)
    return table


__all__ = ["METRICS", "Campaign", "CampaignError", "Metric", "Samples", "library_campaigns", "load_campaign",
           "metric", "run_campaign"]
