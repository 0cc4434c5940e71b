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
The published bench cases: hard cases of the dynamics tests with their high-precision reference.

The reference is ``hard_cases.json``, made by ``tools/make_reference.py``: mpmath Taylor series at
45 digits.
"""

from __future__ import annotations

from dataclasses import dataclass
import json
from pathlib import Path

import numpy as np

REFERENCE_FILE = Path(__file__).with_name('hard_cases.json')

#: the cases of the full report, one plot panel each
BENCH_CASES = (
    'near_separatrix_above_1e-6',
    'near_separatrix_below_1e-6',
    'dzhanibekov_1e-8',
    'near_axisymmetric_1e-9',
    'flat_plate',
    'thin_rod_1e6',
    'fast_spin_1e3',
    'long_horizon_1e5',
)
#: the smoke run's cases (the test suite's)
SMOKE_CASES = ('flat_plate', 'near_separatrix_above_1e-6')


@dataclass(frozen=True)
class Case:
    name: str
    inertia: np.ndarray
    angular_velocity: np.ndarray
    orientation: np.ndarray
    times: np.ndarray  # reference sample times (s)
    omega: np.ndarray  # reference body rates at ``times``
    q: np.ndarray  # reference attitudes at ``times``
    attitude_floor: np.ndarray  # what float64 itself allows, per sample (rad)

    @property
    def horizon(self) -> float:
        return float(self.times[-1])

    @property
    def rotation_period(self) -> float:
        """``2 pi / |w0|``: the unit of the fixed-step methods' step sweep."""
        return 2.0 * np.pi / float(np.linalg.norm(self.angular_velocity))


def load_cases(names=BENCH_CASES) -> list[Case]:
    cases = {c['name']: c for c in json.loads(REFERENCE_FILE.read_text())['cases']}
    unknown = [name for name in names if name not in cases]
    if unknown:
        raise ValueError(f'case: unknown case {unknown[0]!r} (known: {", ".join(cases)})')
    return [
        Case(
            name,
            *(
                np.asarray(cases[name][key], float)
                for key in (
                    'inertia',
                    'angular_velocity',
                    'orientation',
                    'times',
                    'omega',
                    'q',
                    'attitude_floor',
                )
            ),
        )
        for name in names
    ]
