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
What every benchmark script prints and keeps, and the bodies the batch benchmarks share.

The lines it measured, under a header with the command that made them, the date and the machine,
written to ``--output`` (committed under ``docs/bench/``) so that every figure the README quotes
has its source. The batch benchmarks (``bench_plant.py``, ``bench_sensors.py``) run seeded
dispersions of one body with a damper under a commanded torque.
"""

from __future__ import annotations

import datetime
import os
from pathlib import Path
import platform
import shlex
import statistics
import sys
import time


def machine() -> str:
    model = ''
    try:
        for line in Path('/proc/cpuinfo').read_text().splitlines():
            if line.startswith('model name'):
                model = line.split(':', 1)[1].strip()
                break
    except OSError:
        pass
    import numpy

    return (
        f'{model or platform.machine()}, {os.cpu_count()} cores, {platform.platform()}; '
        f'Python {platform.python_version()}, numpy {numpy.__version__}'
    )


def fastest(function, calls: int, clock=time.perf_counter) -> float:
    """
    Return the least disturbed time of ``calls`` runs of ``function()``.

    The least disturbed of ``calls`` runs on a shared machine, in seconds of ``clock``.
    """
    best = float('inf')
    for _ in range(calls):
        started = clock()
        function()
        best = min(best, clock() - started)
    return best


def spread(values) -> str:
    """``median (min–max)`` of repeated measurements, three significant digits."""
    values = sorted(values)
    return f'{_number(statistics.median(values))} ({_number(values[0])}–{_number(values[-1])})'


def _number(value: float) -> str:
    if abs(value) >= 1000:
        return f'{float(f"{value:.3g}"):,.0f}'
    return f'{value:.3g}'


def dispersed_bodies(
    count: int,
    *,
    seed: int,
    inertia,
    angular_velocity,
    inertia_spread: float,
    rate_spread: float,
    body_by_body: bool = False,
):
    """
    Return ``count`` seeded bodies about a nominal one: inertias and rates, each ``(count, 3)``.

    An inertia is the nominal times ``1 + inertia_spread N``, a rate the nominal plus
    ``rate_spread N`` (rad/s), the N standard normals of ``numpy.random.default_rng(seed)`` drawn
    all the inertias' first, then all the rates', or ``body_by_body``: each body's inertia, then
    its rates.
    """
    import numpy as np

    rng = np.random.default_rng(seed)
    if body_by_body:
        draws = rng.standard_normal((count, 2, 3))
        inertia_draws, rate_draws = draws[:, 0], draws[:, 1]
    else:
        inertia_draws = rng.standard_normal((count, 3))
        rate_draws = rng.standard_normal((count, 3))
    return (
        np.asarray(inertia, float) * (1 + inertia_spread * inertia_draws),
        np.asarray(angular_velocity, float) + rate_spread * rate_draws,
    )


def commanded_scene(inertia, angular_velocity, damper: dict, effects=(), **fields):
    """
    Return a body with a damper under a commanded torque (at most 1 N m), DOP853 at 1e-10.

    ``damper``: the damper's parameters; ``effects`` follow the two; ``fields``: further scene
    fields (``orbit``).
    """
    from torquefree_ros.core.scene.loader import scene_from_mapping

    return scene_from_mapping(
        {
            'body': {'inertia': [float(x) for x in inertia]},
            'initial': {'angular_velocity': [float(x) for x in angular_velocity]},
            'effects': [
                {'damper': damper},
                {'torque_command': {'max_torque': 1.0}},
                *effects,
            ],
            'accuracy': 1e-10,
            **fields,
        }
    )


class Report:

    def __init__(self, title: str, command: str):
        self.lines: list[str] = []
        argv = ' '.join(shlex.quote(a) for a in sys.argv[1:])
        self.add(f'# {title}')
        self.add('')
        script = Path(sys.argv[0]).as_posix()
        self.add(f'- command: `{command}` (`{script}{" " + argv if argv else ""}`)')
        self.add(f'- date: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC')
        self.add(f'- machine: {machine()}')
        self.add('')

    def add(self, line: str = '') -> None:
        print(line, flush=True)
        self.lines.append(line)

    def save(self, path: str | None) -> None:
        if path:
            Path(path).write_text('\n'.join(self.lines) + '\n')
