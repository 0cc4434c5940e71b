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
Reaction wheel presets: a wheel's ``preset`` fills its documented fields; what is given wins.

The expected numbers are transcribed here from the documents each row rests on (momentum
capacity, top speed in rpm or rotor inertia, torque, Coulomb level), independently of the table,
and converted here, not read back from it. Only ``rocketlab_rw_0_06`` rests on the manufacturer's
documents; for the four others no public datasheet is at hand, so their figures are Basilisk's, and
their sources must say so and name the datasheet Basilisk cites.
"""

from __future__ import annotations

import math
import re

import pytest
from torquefree_ros.core.effects.actuators import motor_torque
from torquefree_ros.core.effects.wheel_presets import PRESETS
from torquefree_ros.core.scene.loader import scene_from_mapping, SceneError

RPM = math.pi / 30.0

# name: (momentum N m s, top speed rpm or None, rotor inertia kg m^2 or None, torque N m,
#        Coulomb N m or None where the document gives none), each from the document beside it
DOCUMENTS = {
    # Basilisk src/utilities/simIncludeRW.py at babdff7a (2026-07-24), BCT_RWP015:
    # maxMomentum = 0.015, Omega_max = 6000.0 rpm, u_max = 0.004, fCoulomb = 0.00005 (the BCT
    # datasheet it cites, BCT_DataSheet_Components_ReactionWheels_F2.pdf: no public copy at hand)
    'bct_rwp015': (0.015, 6000.0, None, 0.004, 5.0e-5),
    # the same file, NanoAvionics_RW0: maxMomentum = 20.0e-3, Omega_max = 6500.0 rpm,
    # u_max = 3.2e-3, fCoulomb = 0.00005 (data sheet NA-4RW0-G0-R9: its tables not at hand)
    'nanoavionics_rw0': (20.0e-3, 6500.0, None, 3.2e-3, 5.0e-5),
    # the same file, Honeywell_HR12 with maxMomentum = 12 (its small size): Omega_max = 6000.0 rpm,
    # u_max = 0.200, fCoulomb = 0.0005 (Constellation_Series_Reaction_Wheels.pdf: no public copy)
    'honeywell_hr12_12': (12.0, 6000.0, None, 0.200, 0.0005),
    # the same file, Honeywell_HR16 with maxMomentum = 100 (its large size): Omega_max = 6000.0
    # rpm, u_max = 0.200, fCoulomb = 0.0005 (the same Honeywell datasheet: no public copy)
    'honeywell_hr16_100': (100.0, 6000.0, None, 0.200, 0.0005),
    # Rocket Lab "RW-0.06 Data Sheet", Version 3.0, 2024-08-02: "Peak: +-0.18 Nms (at 28 V)",
    # "+-20 mNm at 0.12 Nms (at 28 V)", no friction figure; "60 mNms RW-0.06 Interface Control
    # Document", Rev. 2.0, 2021-06-28, Table 2: rotor inertia Izz 8.66 x 10^-5 kg-m2 (Z the spin
    # axis, its Figure 1)
    'rocketlab_rw_0_06': (0.18, None, 8.66e-5, 20.0e-3, None),
}
#: the rows whose numbers rest on Basilisk's table, not on a document read for this one
FROM_BASILISK = {'bct_rwp015', 'nanoavionics_rw0', 'honeywell_hr12_12', 'honeywell_hr16_100'}
#: what each row's source must name: the document read, or the datasheet Basilisk cites (its
#: address as Basilisk gives it), so a reader can find what the numbers should be checked against
CITED = {
    'bct_rwp015': (
        'storage.googleapis.com/blue-canyon-tech-news/1/2019/10/'
        'BCT_DataSheet_Components_ReactionWheels_F2.pdf',
    ),
    'nanoavionics_rw0': (
        'nanoavionics.com/cubesat-components/cubesat-reaction-wheels-control-system-satbus-4rw/',
        'NA-4RW0-G0-R9',
    ),
    'honeywell_hr12_12': (
        'www51.honeywell.com/aero/common/documents/Constellation_Series_Reaction_Wheels.pdf',
        'HR12',
    ),
    'honeywell_hr16_100': (
        'www51.honeywell.com/aero/common/documents/Constellation_Series_Reaction_Wheels.pdf',
        'HR16',
    ),
    'rocketlab_rw_0_06': (
        'RW-0.06 Data Sheet" (Version 3.0, 2024-08-02',
        'Interface Control Document" (Rev. 2.0, 2021-06-28',
        'rocketlabusa.com',
    ),
}


def wheels_scene(*wheels):
    return scene_from_mapping(
        {
            'body': {'inertia': [400.0, 300.0, 250.0]},
            'initial': {'angular_velocity': [0.0, 0.0, 0.0]},
            'effects': [{'reaction_wheels': {'wheels': list(wheels)}}],
        }
    )


def test_every_preset_has_its_documents_transcribed_here():
    assert set(DOCUMENTS) == set(PRESETS) == set(CITED)


@pytest.mark.parametrize('name', sorted(DOCUMENTS))
def test_a_preset_loads_its_documents_values(name):
    """Js and the top speed from the document's pair, to 2 rounding units (product, division)."""
    momentum, rpm, rotor_inertia, torque, coulomb = DOCUMENTS[name]
    (row,) = wheels_scene({'preset': name, 'axis': [0.0, 0.0, 1.0]}).effects[0].rows
    if rpm is not None:  # the document gives the top speed: Js = H_max / top speed
        top = rpm * RPM
        spin_inertia = momentum / top
    else:  # the document gives the rotor: the top speed is where it holds H_max
        spin_inertia = rotor_inertia
        top = momentum / rotor_inertia
    assert row[5] == pytest.approx(top, rel=4.5e-16)
    assert row[3] == pytest.approx(spin_inertia, rel=4.5e-16)
    assert row[4] == torque
    assert row[8] == (0.0 if coulomb is None else coulomb)  # none given: the wheel's default 0


@pytest.mark.parametrize('name', sorted(DOCUMENTS))
def test_a_preset_stores_its_capacity_at_its_top_speed(name):
    """Js x top speed is the document's H_max, to 2 rounding units (a division, then a product)."""
    (row,) = wheels_scene({'preset': name, 'axis': [1.0, 0.0, 0.0]}).effects[0].rows
    assert row[3] * row[5] == pytest.approx(DOCUMENTS[name][0], rel=4.5e-16)


@pytest.mark.parametrize('name', sorted(DOCUMENTS))
def test_a_preset_wheels_motor_stops_at_its_documents_torque_and_capacity(name):
    """
    The motor of a preset's wheel gives the document's torque and no momentum past its H_max.

    Asked ten times the document's torque either way at rest it gives exactly that torque (a
    clip, no arithmetic); at the document's top speed (``H_max / Js``, its stored momentum the
    document's ``H_max``) it gives nothing more in the spin's direction and the full torque
    against it, so the motor never stores more than the document's capacity.
    """
    momentum, rpm, rotor_inertia, torque, _ = DOCUMENTS[name]
    top = rpm * RPM if rpm is not None else momentum / rotor_inertia
    (row,) = wheels_scene({'preset': name, 'axis': [0.0, 1.0, 0.0]}).effects[0].rows
    limits = (row[4], row[5], row[6])  # max_torque, max_speed, speed_band as loaded
    assert motor_torque(0.0, 10.0 * torque, *limits) == torque
    assert motor_torque(0.0, -10.0 * torque, *limits) == -torque
    at_capacity = top * (1.0 + 1.0e-15)  # past the loaded top speed's rounding, by a few units
    assert motor_torque(at_capacity, 10.0 * torque, *limits) == 0.0
    assert motor_torque(-at_capacity, -10.0 * torque, *limits) == 0.0
    assert motor_torque(at_capacity, -10.0 * torque, *limits) == -torque  # braking: unlimited


@pytest.mark.parametrize('name', sorted(DOCUMENTS))
def test_a_preset_names_what_its_numbers_rest_on(name):
    source = PRESETS[name].source
    assert re.search(r'\b(19|20)\d\d\b', source)  # a dated document
    rests_on_basilisk = (
        'simIncludeRW.py' in source
        and 'no public datasheet found' in source
        and 'not checked' in source
    )
    assert rests_on_basilisk == (name in FROM_BASILISK)
    assert all(cited in source for cited in CITED[name])


def test_a_preset_without_a_friction_figure_leaves_the_wheels_own():
    """The RW-0.06 documents give no friction: the wheel's coulomb is its own, default 0."""
    effect = wheels_scene(
        {'preset': 'rocketlab_rw_0_06', 'axis': [1.0, 0.0, 0.0]},
        {'preset': 'rocketlab_rw_0_06', 'axis': [0.0, 1.0, 0.0], 'coulomb': 2.0e-4},
    ).effects[0]
    first, second = effect.rows
    assert first[8] == 0.0 and second[8] == 2.0e-4
    assert 'coulomb' not in PRESETS['rocketlab_rw_0_06'].fields()


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
