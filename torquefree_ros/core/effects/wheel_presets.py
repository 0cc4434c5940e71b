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

A preset fills a wheel's ``spin_inertia``, ``max_torque`` and ``max_speed``, and its ``coulomb``
where its source gives one; any of them written beside the preset wins. A wheel's documents give
the momentum capacity ``H_max`` and either the top speed (then ``Js = H_max / max_speed``, as
Basilisk's ``simIncludeRW.rwFactory`` derives it) or the rotor's inertia about the spin axis (then
the top speed is ``H_max / Js``). A row's ``source`` names what its numbers rest on, and a row
rests on one of two things:

- the manufacturer's own documents, read for this table (``rocketlab_rw_0_06``): every number is
  theirs, and where they give no friction the preset leaves ``coulomb`` to the wheel (default 0);
- Basilisk's ``src/utilities/simIncludeRW.py`` (the factory Basilisk users take wheels from), for
  the four others: the datasheet it cites has no public copy at hand whose figures can be read (the
  source says so, "no public datasheet found", and names that datasheet as Basilisk cites it), so
  the row carries Basilisk's numbers unchecked; the Coulomb level is Basilisk's own estimate (it
  names no source for it), so the two simulators start from the same wheel.

Rocket Lab's other wheels make no preset here: their documents give the momentum and the torque
but neither a top speed nor the rotor's inertia, so either would have to be invented. Read for
this table, as found in the public repository mrpappas/lab-rat (Vault-Assets/PDFs/):

- RW-0.003, RW-0.01 and RW-0.03: data sheets Version 3.0, 2024-08-02; "3 mNms RW-0.003" ICD Rev.
  1.1, 2021-08-05 (mass only); "RW-0.01 / RW-0.03" mechanical and electrical ICD Rev. 2.0,
  2021-08-03 (masses and mass centres only);
- RW4-0.2/0.4: "RW-0.2/0.4 Data Sheet" Version 3.0, 2024-08-02; "400 mNms RW-0.4" ICD Rev. 1.4,
  2023-10-20 (masses and mass centres; "a detailed mechanical ICD can be provided upon request");
- RW4-1.0: data sheets Version 3.0, 2024-08-02, and 3.1, 2025-01-31; "RW-1.0 ICD" Rev. 1.5,
  2024-04-22 (file RL-RW4-2.0-ICD-v1.5.pdf; mass and mass centre only);
- RW4-5.0: "RW4-5.0 Data Sheet" Version 1.2, 2025-03-20; "RW-5.0 Interface Control Document"
  RL-TOR-ICD-00033 v1.0, released 24/11/13 (no mass properties);
- RW4-12: "RW4-12 Data Sheet" Version 3.0, 2024-08-02 (no ICD found).

Their ICDs name the rotor inertia and the speed limit only as parameters the wheel's software
holds (``INERTIA``, ``LIMIT_SPEED``, ``FAULT_OVERSPEED``), with no value, and every torque box and
power curve in the data sheets is plotted against momentum, not speed.

A scene that knows better writes its own fields beside the preset.
"""

from __future__ import annotations

import math
from typing import NamedTuple

RPM = 2.0 * math.pi / 60.0  # rad/s per rpm


class WheelPreset(NamedTuple):
    """One published wheel: its numbers in SI units and what they rest on."""

    momentum: float  # N m s, the capacity H_max at the top speed
    max_speed: float | None  # rad/s, where the source gives the top speed (else H_max / Js)
    max_torque: float  # N m
    coulomb: float | None  # N m, where the source gives one (None: the wheel's own, default 0)
    source: str
    rotor_inertia: float | None = None  # kg m^2 about the spin axis, where the source gives it

    @property
    def spin_inertia(self) -> float:
        """Return ``Js``, kg m^2: the rotor's inertia where given, else ``H_max / max_speed``."""
        if self.rotor_inertia is not None:
            return self.rotor_inertia
        return self.momentum / self.max_speed

    @property
    def top_speed(self) -> float:
        """Return the top speed, rad/s: the source's where given, else ``H_max / Js``."""
        if self.max_speed is not None:
            return self.max_speed
        return self.momentum / self.rotor_inertia

    def fields(self) -> dict:
        """Return the wheel fields it fills, by their scene names."""
        filled = {
            'spin_inertia': self.spin_inertia,
            'max_torque': self.max_torque,
            'max_speed': self.top_speed,
        }
        if self.coulomb is not None:
            filled['coulomb'] = self.coulomb
        return filled


_BASILISK = "Basilisk's src/utilities/simIncludeRW.py (AVSLab/basilisk at babdff7a, 2026-07-24)"

#: preset name -> wheel
PRESETS: dict[str, WheelPreset] = {
    # 0.015 N m s, 6000 rpm, 4 mN m; Coulomb 50 uN m
    'bct_rwp015': WheelPreset(
        0.015,
        6000.0 * RPM,
        0.004,
        5.0e-5,
        f'Blue Canyon Technologies RWp015, the numbers as {_BASILISK} carries them in '
        "BCT_RWP015 ('Not complete; fields not listed are estimates', not saying which are "
        "listed, so the 6000 rpm, and with it Js, may be Basilisk's estimate), citing BCT's "
        '"Reaction Wheels" datasheet (BCT_DataSheet_Components_ReactionWheels_F2.pdf, October '
        '2019, https://storage.googleapis.com/blue-canyon-tech-news/1/2019/10/'
        'BCT_DataSheet_Components_ReactionWheels_F2.pdf); no public datasheet found: not '
        "checked against it; Coulomb is Basilisk's estimate",
    ),
    # 20 mN m s, 6500 rpm, 3.2 mN m; Coulomb 50 uN m
    'nanoavionics_rw0': WheelPreset(
        0.020,
        6500.0 * RPM,
        0.0032,
        5.0e-5,
        f'NanoAvionics RW0, the numbers as {_BASILISK} carries them in NanoAvionics_RW0 (added '
        '2025-10-13), citing the NanoAvionics web page "CubeSat Reaction Wheels Control System '
        'SatBus 4RW0" (undated, https://nanoavionics.com/cubesat-components/'
        'cubesat-reaction-wheels-control-system-satbus-4rw/, its address carrying '
        '?utm_source=chatgpt.com as cited); no public datasheet found whose figures could be '
        'read (the one copy found of the data sheet "Reaction Wheels" NA-4RW0-G0-R9, Rev. 9, '
        '2019-09-19, a Scribd page, shows its revision sheet, not its tables): not checked '
        'against it; Coulomb is the Basilisk estimate (its "Guestimate")',
    ),
    # 12 N m s (the smallest of 12, 25, 50), 6000 rpm, 0.2 N m; Coulomb 0.5 mN m
    'honeywell_hr12_12': WheelPreset(
        12.0,
        6000.0 * RPM,
        0.200,
        5.0e-4,
        f'Honeywell HR12 in its 12 N m s size, the numbers as {_BASILISK} carries them in '
        'Honeywell_HR12, citing the Honeywell "Constellation Series Reaction Wheels" datasheet '
        '(undated, http://www51.honeywell.com/aero/common/documents/'
        'Constellation_Series_Reaction_Wheels.pdf); no public datasheet found: not checked '
        "against it; Coulomb is Basilisk's estimate",
    ),
    # 100 N m s (the largest of 50, 75, 100), 6000 rpm, 0.2 N m; Coulomb 0.5 mN m
    'honeywell_hr16_100': WheelPreset(
        100.0,
        6000.0 * RPM,
        0.200,
        5.0e-4,
        f'Honeywell HR16 in its 100 N m s size, the numbers as {_BASILISK} carries them in '
        'Honeywell_HR16, citing the Honeywell "Constellation Series Reaction Wheels" datasheet '
        '(undated, http://www51.honeywell.com/aero/common/documents/'
        'Constellation_Series_Reaction_Wheels.pdf); no public datasheet found: not checked '
        "against it; Coulomb is Basilisk's estimate",
    ),
    # 0.18 N m s peak at 28 V, rotor 8.66e-5 kg m^2 (so 2079 rad/s, 19 848 rpm), 20 mN m; no
    # friction figure. Its torque box at 28 V holds about 20 mN m out to about 0.17 N m s, so a
    # constant limit up to the peak fits it. Its steady-state input power (0.5 W at 0.06 N m s,
    # 0.9 W at 0.12 N m s) bounds the drag torque at those speeds (input power >= drag torque x
    # speed) by 0.72 and 0.65 mN m.
    'rocketlab_rw_0_06': WheelPreset(
        0.18,
        None,
        0.020,
        None,
        'Rocket Lab (Sinclair Interplanetary) RW-0.06, read from "Reaction Wheel RW-0.06 Data '
        'Sheet" (Version 3.0, 2024-08-02: momentum peak 0.18 N m s at 28 V, torque 20 mN m) and '
        '"Reaction Wheel 60 mNms RW-0.06 Interface Control Document" (Rev. 2.0, 2021-06-28, '
        'Table 2: RW3-0.06 rotor inertia Izz 8.66e-5 kg m^2 about the spin axis), as found in the '
        'public repository mrpappas/lab-rat (Vault-Assets/PDFs/RW-0.06-Datasheet-v3.0.pdf, '
        '60-Nms-RW3-0.06-ICD.pdf; Rocket Lab lists its wheels at https://www.rocketlabusa.com/'
        'space-systems/satellite-components/reaction-wheels/); they give no friction, so the '
        "wheel's own coulomb applies",
        rotor_inertia=8.66e-5,
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
