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

The free body's reference is ``hard_cases.json``, made by ``tools/make_reference.py``: mpmath
Taylor series at 45 digits. The free gyrostat's (a ``rotor``, or coasting ``reaction_wheels``) is
``gyrostat_cases.json``, made by ``tools/make_gyrostat_reference.py``: mpmath Taylor series at 40
digits; its cases are named here with the prefix :data:`GYROSTAT_PREFIX` (both files hold a
``long_horizon_1e5``) and carry their effects as scene mappings.
"""

from __future__ import annotations

from dataclasses import dataclass
import json
from pathlib import Path

import numpy as np

REFERENCE_FILE = Path(__file__).with_name('hard_cases.json')
GYROSTAT_REFERENCE_FILE = Path(__file__).with_name('gyrostat_cases.json')
GYROSTAT_PREFIX = 'gyrostat/'

#: the free body's cases of the full report, one plot panel each
FREE_BODY_CASES = (
    'near_separatrix_above_1e-6',
    'near_separatrix_below_1e-6',
    'dzhanibekov_1e-8',
    'near_axisymmetric_1e-9',
    'flat_plate',
    'thin_rod_1e6',
    'fast_spin_1e3',
    'long_horizon_1e5',
)
#: the free gyrostat's cases of the full report: the library scene's rotor, a dominant rotor, next
#: to a separatrix, coasting wheels on two axes, a long horizon, and a rotor off every principal
#: axis (the exact gyrostat's oblique form)
GYROSTAT_CASES = tuple(
    GYROSTAT_PREFIX + name
    for name in (
        'library_gyrostat',
        'dominant_h',
        'separatrix_off_pole_above_1e-10',
        'wheels_coasting_two_axes',
        'long_horizon_1e5',
        'oblique_rotor',
    )
)
BENCH_CASES = FREE_BODY_CASES + GYROSTAT_CASES
#: the smoke run's cases (the test suite's)
SMOKE_CASES = ('flat_plate', 'near_separatrix_above_1e-6')
#: a quick run's gyrostat cases (``--smoke --case ...``: a rotor and coasting wheels)
GYROSTAT_SMOKE_CASES = (
    GYROSTAT_PREFIX + 'library_gyrostat',
    GYROSTAT_PREFIX + 'wheels_coasting_two_axes',
)


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
    #: the motion effects as a scene's ``effects`` list (empty: the free body)
    effects: tuple = ()
    #: ``|h| / min(I_s)``: the rate the gyrostat's momentum adds to the motion's (rad/s)
    momentum_rate: float = 0.0

    @property
    def horizon(self) -> float:
        return float(self.times[-1])

    @property
    def rotation_period(self) -> float:
        """
        Return ``2 pi / |w0|``: the unit of the fixed-step methods' step sweep.

        A gyrostat's ``2 pi / (|w0| + |h| / min(I_s))``: a dominant ``h`` sets the motion's
        fastest rate, not ``w0``.
        """
        return 2.0 * np.pi / (float(np.linalg.norm(self.angular_velocity)) + self.momentum_rate)

    def scene_mapping(self) -> dict:
        """Return the case as a scene mapping (body, initial state, effects)."""
        return {
            'body': {'inertia': self.inertia.tolist()},
            'initial': {
                'angular_velocity': self.angular_velocity.tolist(),
                'orientation': self.orientation.tolist(),
            },
            'effects': [dict(effect) for effect in self.effects],
        }

    def describe_effects(self) -> str:
        """Return one sentence naming the case's effects (empty for the free body)."""
        parts = []
        for effect in self.effects:
            if 'rotor' in effect:
                rotor = effect['rotor']
                parts.append(f'a rotor of {rotor["momentum"]:g} N m s along {rotor["axis"]}')
            else:
                wheels = effect['reaction_wheels']['wheels']
                parts.append(
                    'coasting reaction wheels (no motor torque, no friction): '
                    + ', '.join(
                        f'Js {w["spin_inertia"]:g} kg m² at {w["speed"]:g} rad/s about {w["axis"]}'
                        for w in wheels
                    )
                )
        return '; '.join(parts)


_KEYS = ('inertia', 'angular_velocity', 'orientation', 'times', 'omega', 'q', 'attitude_floor')


def load_cases(names=BENCH_CASES) -> list[Case]:
    cases = {c['name']: c for c in json.loads(REFERENCE_FILE.read_text())['cases']}
    gyrostats = {
        GYROSTAT_PREFIX + c['name']: c
        for c in json.loads(GYROSTAT_REFERENCE_FILE.read_text())['cases']
    }
    unknown = [name for name in names if name not in cases and name not in gyrostats]
    if unknown:
        known = ', '.join([*cases, *gyrostats])
        raise ValueError(f'case: unknown case {unknown[0]!r} (known: {known})')
    return [
        Case(name, *(np.asarray(cases[name][key], float) for key in _KEYS))
        if name in cases
        else _gyrostat_case(name, gyrostats[name])
        for name in names
    ]


def _gyrostat_case(name: str, record: dict) -> Case:
    """
    Return a gyrostat case: its ``rotor`` or coasting ``reaction_wheels`` as scene effects.

    The wheels' gyrostat (``I_s = I - sum Js g g^T``, ``h = sum h_i g_i``) is in the reference.
    """
    if 'wheels' in record:
        effects = ({'reaction_wheels': {'wheels': record['wheels']}},)
        moments = np.asarray(record['gyrostat_inertia'], float)
        h = float(np.linalg.norm(record['gyrostat_momentum']))
    else:
        effects = ({'rotor': record['rotor']},)
        moments = np.asarray(record['inertia'], float)
        h = abs(float(record['rotor']['momentum']))
    return Case(
        name,
        *(np.asarray(record[key], float) for key in _KEYS),
        effects=effects,
        momentum_rate=h / float(moments.min()),
    )
