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
The sun-pointing controller of sun_pointing_controller.py on the library's sun_pointing scene.

It runs through the test kit's pytest fixture, ``torquefree_sim``, in lock-step (the kit's
default): every sample is answered before the next is computed.
"""

from geometry_msgs.msg import Vector3Stamped
import numpy as np
import pytest
from sensor_msgs.msg import JointState
from sun_pointing_controller import SunPointingController, SunPointingLaw

RATE = 2.0  # Hz
SPAN = 300.0  # s: in sunlight throughout (the first eclipse begins at 1764 s)
POINTED = 200.0  # s: from here on the panel normal is within TOLERANCE of the Sun
TOLERANCE = 1.0  # deg
FINAL = 0.01  # deg: the angle at the end of the span


@pytest.mark.torquefree_sim(scene='sun_pointing', publish_rate=RATE)
def test_the_panels_face_the_sun_within_a_degree_from_200_s(torquefree_sim):
    """
    From 120 deg off, the panel normal within 1 deg of the Sun from 200 s on, 0.01 deg at 300 s.

    With omega_n 0.05 rad/s and zeta 1 the linear loop's error falls as (1 + omega_n t)
    exp(-omega_n t) once near the Sun; the first minute turns the body through the large angle,
    where ``|n x s| = sin theta`` is not ``theta``. Measured here, and on the plant with the same
    law at 2 Hz alike: last above 1 deg at 173 s, above 0.1 deg at 226.5 s, 0.0035 deg at 300 s:
    the bounds (200 s, 0.01 deg) leave about 15 % of the time and three times the angle, for a
    change of the integrator's accuracy or the friction model. The readings are unit vectors
    throughout (sunlight: no zero vector), and the motor torques stay within the wheels' 4 mN m
    (the law scales them to it, then adds the 0.05 mN m of friction it compensates).
    """
    sim = torquefree_sim
    sim.add_node(SunPointingController(context=sim.context))
    suns = sim.tap('sun_sensor', Vector3Stamped)
    commands = sim.tap('wheel_command', JointState)
    samples = sim.advance(int(SPAN * RATE) + 1)  # 0 .. SPAN s
    assert sim.node.stepping.state().missed_steps == 0  # every sample answered in time
    suns.wait(len(samples))
    commands.wait(len(samples) - 1)
    law = SunPointingLaw('sun_pointing')
    t = np.array([s.t for s in samples])
    readings = np.array([[m.vector.x, m.vector.y, m.vector.z] for m in suns.messages])
    np.testing.assert_allclose(np.linalg.norm(readings, axis=1), 1.0, rtol=0, atol=1e-15)
    angle = np.degrees(np.arccos(np.clip(readings @ law.normal, -1.0, 1.0)))
    assert 120.0 < angle[0] < 121.0  # the scene's start: the Sun 120.4 deg off the normal
    assert angle[t >= POINTED].max() < TOLERANCE, angle[t >= POINTED].max()
    assert angle[t < 150.0].max() > 10.0  # (it takes its time: not pointed at once)
    assert angle[-1] < FINAL, angle[-1]
    efforts = np.array([c.effort for c in commands.messages])
    assert np.abs(efforts).max() <= 0.004 + 5e-5
    assert all(list(c.name) == law.names for c in commands.messages)
