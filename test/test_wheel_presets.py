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
Reaction wheel presets: a wheel's ``preset`` fills its datasheet fields; what is given wins.

The expected numbers are the datasheets' own (momentum capacity, top speed in rpm, torque),
converted here, not read back from the table.
"""

from __future__ import annotations

import math

import pytest
from torquefree_ros.core.effects.wheel_presets import PRESETS
from torquefree_ros.core.scene.loader import scene_from_mapping, SceneError

RPM = math.pi / 30.0

# name: (momentum N m s, top speed rpm, max torque N m, Coulomb N m), by the datasheets
DATASHEETS = {
    'bct_rwp015': (0.015, 6000.0, 0.004, 5.0e-5),
    'nanoavionics_rw0': (0.020, 6500.0, 0.0032, 5.0e-5),
    'honeywell_hr12_12': (12.0, 6000.0, 0.200, 5.0e-4),
    'honeywell_hr16_100': (100.0, 6000.0, 0.200, 5.0e-4),
}


def wheels_scene(*wheels):
    return scene_from_mapping(
        {
            'body': {'inertia': [400.0, 300.0, 250.0]},
            'initial': {'angular_velocity': [0.0, 0.0, 0.0]},
            'effects': [{'reaction_wheels': {'wheels': list(wheels)}}],
        }
    )


@pytest.mark.parametrize('name', sorted(DATASHEETS))
def test_a_preset_loads_its_datasheet_values(name):
    """Js = H_max / top speed and the limits, to 2 rounding units (one division, one product)."""
    momentum, rpm, torque, coulomb = DATASHEETS[name]
    (row,) = wheels_scene({'preset': name, 'axis': [0.0, 0.0, 1.0]}).effects[0].rows
    top = rpm * RPM
    assert row[5] == pytest.approx(top, rel=4.5e-16)
    assert row[3] == pytest.approx(momentum / top, rel=4.5e-16)
    assert row[4] == torque and row[8] == coulomb
    assert PRESETS[name].source  # every row names its datasheet


def test_a_field_given_beside_a_preset_wins():
    effect = wheels_scene(
        {'preset': 'bct_rwp015', 'axis': [1.0, 0.0, 0.0], 'max_torque': 0.001, 'coulomb': 0.0},
        {'preset': 'bct_rwp015', 'axis': [0.0, 1.0, 0.0], 'spin_inertia': 3.0e-5},
    ).effects[0]
    first, second = effect.rows
    assert first[4] == 0.001 and first[8] == 0.0  # given
    assert first[3] == PRESETS['bct_rwp015'].spin_inertia  # the preset's
    assert second[3] == 3.0e-5 and second[4] == 0.004


def test_an_unknown_preset_is_refused_with_its_path_and_the_known_names():
    with pytest.raises(SceneError) as error:
        wheels_scene(
            {'preset': 'bct_rwp015', 'axis': [1.0, 0.0, 0.0]},
            {'preset': 'bct_rwp0150', 'axis': [0.0, 1.0, 0.0]},
        )
    message = str(error.value)
    assert 'effects[0].reaction_wheels.wheels[1].preset: expected one of' in message
    assert all(name in message for name in PRESETS)


def test_a_wheel_without_preset_still_needs_its_fields():
    with pytest.raises(SceneError) as error:
        wheels_scene({'axis': [1.0, 0.0, 0.0], 'max_torque': 0.01, 'max_speed': 100.0})
    assert 'effects[0].reaction_wheels.wheels[0].spin_inertia: missing' in str(error.value)
