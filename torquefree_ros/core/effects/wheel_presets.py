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
Reaction wheel presets: published wheels by name (a wheel's ``preset: NAME`` in a scene).

A preset fills a wheel's ``spin_inertia``, ``max_torque``, ``max_speed`` and ``coulomb``; any of
them written beside the preset wins. Each row names its datasheet and that datasheet's date. A
datasheet gives the momentum capacity ``H_max`` at the top speed, not the spin inertia: ``Js =
H_max / max_speed``, as Basilisk's ``simIncludeRW.rwFactory`` derives it. Datasheets do not give
the friction: the Coulomb levels are Basilisk's own estimates for these wheels
(``src/utilities/simIncludeRW.py``, the factory every Basilisk user takes wheels from), so that the
two simulators start from the same wheel; a scene that knows better writes its own ``coulomb``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

RPM = 2.0 * math.pi / 60.0  # rad/s per rpm


class WheelPreset(NamedTuple):
    """One published wheel: its numbers in SI units and where they come from."""

    momentum: float  # N m s at max_speed (the datasheet's capacity)
    max_speed: float  # rad/s
    max_torque: float  # N m
    coulomb: float  # N m (an estimate: see the module's docstring)
    source: str

    @property
    def spin_inertia(self) -> float:
        """Return ``Js = momentum / max_speed``, kg m^2."""
        return self.momentum / self.max_speed

    def fields(self) -> dict:
        """Return the wheel fields it fills, by their scene names."""
        return {
            'spin_inertia': self.spin_inertia,
            'max_torque': self.max_torque,
            'max_speed': self.max_speed,
            'coulomb': self.coulomb,
        }


#: preset name -> wheel
PRESETS: dict[str, WheelPreset] = {
    # Blue Canyon Technologies RWP015: 0.015 N m s, 4 mN m, 6000 rpm
    'bct_rwp015': WheelPreset(
        0.015,
        6000.0 * RPM,
        0.004,
        5.0e-5,
        'Blue Canyon Technologies, "Reaction Wheels" datasheet '
        '(BCT_DataSheet_Components_ReactionWheels_F2.pdf, October 2019)',
    ),
    # NanoAvionics RW0: 20 mN m s, 3.2 mN m, 6500 rpm
    'nanoavionics_rw0': WheelPreset(
        0.020,
        6500.0 * RPM,
        0.0032,
        5.0e-5,
        'NanoAvionics, "CubeSat Reaction Wheels Control System SatBus 4RW0" product page '
        '(undated; its numbers as Basilisk simIncludeRW.py carries them, read 2026-11-28)',
    ),
    # Honeywell HR12 in its 12 N m s size: 0.2 N m, 6000 rpm
    'honeywell_hr12_12': WheelPreset(
        12.0,
        6000.0 * RPM,
        0.200,
        5.0e-4,
        'Honeywell, "Constellation Series Reaction Wheels" datasheet (undated PDF; its numbers '
        'as Basilisk simIncludeRW.py carries them, read 2026-11-28)',
    ),
    # Honeywell HR16 in its 100 N m s size: 0.2 N m, 6000 rpm
    'honeywell_hr16_100': WheelPreset(
        100.0,
        6000.0 * RPM,
        0.200,
        5.0e-4,
        'Honeywell, "Constellation Series Reaction Wheels" datasheet (undated PDF; its numbers '
        'as Basilisk simIncludeRW.py carries them, read 2026-11-28)',
    ),
}


def with_preset(wheel: dict) -> dict:
    """
    Return a wheel's scene mapping with its preset's fields filled in where it gives none.

    ``wheel`` as written in the scene (its ``preset`` already checked to be a known name, or
    absent: then it is returned as it is).
    """
    name = wheel.get('preset') if isinstance(wheel, dict) else None
    if name is None:
        return wheel
    return {**PRESETS[name].fields(), **wheel}


__all__ = ['PRESETS', 'RPM', 'WheelPreset', 'with_preset']
