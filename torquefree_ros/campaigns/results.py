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
Results: one table, a row per run (pyarrow; written as Parquet).

Columns, in order: ``run`` (int64), ``status`` (``ok | invalid_body | invalid_scene | failed``),
``reason`` (null when ok), ``redraws`` (int64), the drawn inputs (float64, one column per
component, named by target path: ``body.moments[0]``, ``initial.orientation[3]``,
``effects[0].damper.damping``), then the metrics' columns (null for a run that did not finish; NaN
where a metric is undefined for a run that did). The schema's metadata holds the campaign file's
text (``torquefree_ros.campaign``), the scene it dispersed (``torquefree_ros.scene``, the scene
file's mapping as JSON), what the campaign measured when loaded and the trajectories it keeps
(``torquefree_ros.campaign_summary``, JSON) and the versions that made the table
(``torquefree_ros.versions``, JSON); nothing in it depends on the engine, so the same campaign
gives the same table, metadata included, in-process, on any cluster, or resumed. The table is
written by :mod:`.store` (``DIR/runs.parquet``, assembled from per-chunk parts).
"""

from __future__ import annotations

from importlib import metadata as importlib_metadata
import json
import platform

import numpy as np

RESULTS_FILE = 'runs.parquet'
CAMPAIGN_FILE = 'campaign.yaml'
_VERSIONED = ('numpy', 'scipy', 'numba', 'pyarrow', 'dask', 'distributed', 'PyYAML')


def versions() -> dict:
    from ..version import __version__

    found = {'torquefree_ros': __version__, 'python': platform.python_version()}
    for name in _VERSIONED:
        try:
            found[name] = importlib_metadata.version(name)
        except importlib_metadata.PackageNotFoundError:
            found[name] = None
    return found


def provenance(campaign) -> dict:
    """
    Return what a campaign's runs are made of: its file's text, its scene and the versions.

    The scene is the scene file's mapping, so that an edited scene file is noticed. Runs of equal
    provenance are equal bit for bit.
    """
    scene = json.loads(json.dumps(campaign.scene_document, sort_keys=True, default=str))
    return {'campaign': campaign.text, 'scene': scene, 'versions': versions()}


def build_table(campaign, parts: list[dict]):
    import pyarrow as pa

    def joined(name):
        return np.concatenate([part[name] for part in parts]) if parts else np.empty(0)

    status = [s for part in parts for s in part['status']]
    failed = np.array([s != 'ok' for s in status], dtype=bool)
    arrays = {
        'run': pa.array(joined('run'), pa.int64()),
        'status': pa.array(status, pa.string()),
        'reason': pa.array([r for part in parts for r in part['reason']], pa.string()),
        'redraws': pa.array(joined('redraws'), pa.int64()),
    }
    for column in campaign.input_columns:
        arrays[column] = pa.array(joined(column), pa.float64())
    for use in campaign.metrics:
        kind = pa.int64() if use.metric.dtype == 'int64' else pa.float64()
        for column in use.columns:
            arrays[column] = pa.array(joined(column), kind, mask=failed)
    summary = {
        'source': campaign.source,
        'scene': campaign.scene.source,
        'runs': campaign.runs,
        'seed': campaign.seed,
        'duration': campaign.duration,
        'rate': campaign.rate,
        'samples': campaign.samples,
        'body_acceptance': campaign.body_acceptance,
        'trajectories': (
            {
                'every': campaign.trajectory_every,
                'rate': campaign.rate / campaign.trajectory_every,
                'samples': int(campaign.trajectory_times.size),
                'columns': list(campaign.trajectory_columns),
            }
            if campaign.trajectory_every
            else None
        ),
        'metrics': {
            use.metric.name: {
                'columns': list(use.columns),
                'unit': use.metric.unit,
                'parameters': _plain(use.values),
            }
            for use in campaign.metrics
        },
    }
    made_of = provenance(campaign)
    meta = {
        b'torquefree_ros.campaign': campaign.text.encode('utf-8'),
        b'torquefree_ros.scene': json.dumps(made_of['scene'], sort_keys=True).encode('utf-8'),
        b'torquefree_ros.campaign_summary': json.dumps(summary, sort_keys=True).encode('utf-8'),
        b'torquefree_ros.versions': json.dumps(made_of['versions'], sort_keys=True).encode(
            'utf-8'
        ),
    }
    return pa.table(arrays).replace_schema_metadata(meta)


def _plain(values: dict) -> dict:
    return {k: (list(v) if isinstance(v, (tuple, np.ndarray)) else v) for k, v in values.items()}
