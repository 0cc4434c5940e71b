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
A batch's dipoles checked and applied for every body at once (``Plant.step(dipole=...)``).

Bodies whose rods differ (their strengths, their axes' scale, a skewed fourth rod) apply, bit for
bit, the dipole each body alone applies, saturated or not; a refused dipole names the first body
the node's rules refuse, with their reason, and changes no body.
"""

import numpy as np
import pytest
from torquefree_ros import Plant
from torquefree_ros.core.scene.loader import scene_from_mapping

RATE = 1.0
ORBIT = {
    'epoch': '2026-03-20T12:00:00Z',
    'semi_major_axis': 6878137.0,
    'eccentricity': 0.0,
    'inclination': 1.6999506914424771,
}


def _scene(strength, scale, max_command=5.0, omega=(0.1, -0.1, 0.1)):
    rods = [
        {'axis': [scale, 0.0, 0.0], 'max_dipole': 0.2 * strength},
        {'axis': [0.0, 1.0, 0.0], 'max_dipole': 0.2},
        {'axis': [0.0, 0.0, 1.0], 'max_dipole': 0.15 * strength},
        {'axis': [1.0, scale, 1.0], 'max_dipole': 0.1 / strength},
    ]
    return scene_from_mapping(
        {
            'body': {'inertia': [0.020, 0.021, 0.005]},
            'initial': {'angular_velocity': list(omega)},
            'orbit': ORBIT,
            'effects': [{'magnetorquers': {'rods': rods, 'max_command': max_command}}],
            'accuracy': 1e-10,
        }
    )


SCENES = [_scene(1.0, 1.0), _scene(0.7, 3.0), _scene(1.3, 0.5, max_command=0.5)]


def test_bodies_with_their_own_rods_apply_each_its_own_dipole():
    rng = np.random.default_rng(11)
    batch = Plant(SCENES, RATE)
    alone = [Plant(scene, RATE) for scene in SCENES]
    # up to twice the rods' limits (some rods saturate, body by body), within max_command 0.5
    dipoles = np.clip(0.2 * rng.standard_normal((12, len(SCENES), 3)), -0.45, 0.45)
    for step in dipoles:
        states = batch.step(dipole=step)
        for b, plant in enumerate(alone):
            for got, expected in zip(states, plant.step(dipole=step[b])):
                np.testing.assert_array_equal(got[b], expected)


@pytest.mark.parametrize(
    'dipole, reason',
    [
        ([[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, np.nan, 0.0]],
         r'dipole: not finite: a NaN or infinite component \(body 2\): \[0.0, nan, 0.0\]'),
        # body 1 not finite, body 2 too large: the first body refused is named
        ([[0.1, 0.0, 0.0], [np.inf, 0.0, 0.0], [0.0, 0.0, 0.7]],
         r'dipole: not finite: .* \(body 1\): \[inf, 0.0, 0.0\]'),
        ([[0.1, 0.0, 0.0], [0.0, 0.3, 0.0], [0.0, 0.0, -0.7]],
         r'dipole: too large: a dipole component exceeds max_command 0.5 A m\^2 \(body 2\)'),
    ],
)
def test_a_refused_body_is_named_and_no_body_changes(dipole, reason):
    batch = Plant(SCENES, RATE)
    batch.step(dipole=[[0.1, 0.0, 0.0]] * len(SCENES))
    before = batch.state
    with pytest.raises(ValueError, match=reason):
        batch.step(dipole=dipole)
    assert batch.k == 1
    for now, then in zip(batch.state, before):
        np.testing.assert_array_equal(now, then)
    # the command before the refusal still holds for every body, as for a plant never refused
    again = Plant(SCENES, RATE)
    again.step(dipole=[[0.1, 0.0, 0.0]] * len(SCENES))
    np.testing.assert_array_equal(batch.step().omega_B, again.step().omega_B)
