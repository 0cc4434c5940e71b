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
The slew controller of wheel_slew_controller.py on the library's wheel_slew scene, in lock-step.

It runs through the test kit's pytest fixture, ``torquefree_sim`` (lock-step is the kit's
default): every sample is answered before the next is computed.
"""

import numpy as np
import pytest
from sensor_msgs.msg import JointState
from wheel_slew_controller import SlewLaw, WheelSlewController

RATE = 10.0  # Hz
SETTLE = 55.0  # s: from here on the attitude is within TOLERANCE of the target
TOLERANCE = np.radians(0.01)  # rad (36 arcsec)


@pytest.mark.torquefree_sim(scene='wheel_slew', publish_rate=RATE)
def test_the_slew_settles_within_a_hundredth_of_a_degree_in_55_s(torquefree_sim):
    """
    The 60 deg rest-to-rest slew, every sample answered: settled to 0.01 deg from 55 s on.

    With omega_n 0.2 rad/s and zeta 1 the linear loop's error falls as (1 + omega_n t)
    exp(-omega_n t); the first 15 s or so are torque-limited (the wheels at 0.02 N m), which
    delays it: measured on the plant, under 0.01 deg from 53.4 s, 1e-6 deg at 100 s. At rest
    again: the body's rate under 1e-5 rad/s, and the wheels (whose momentum the body's is while
    it turns) back on their bias, which friction slows in the pyramid's null space, where it
    puts no torque on the body: ``Js s' = -(Fc + b s)``, ``s = (s_0 + Fc / b) exp(-b t / Js) -
    Fc / b`` (96.41 rad/s at 60 s), within 0.05 rad/s (the wheels' speeds differ during the
    slew, and so do their frictions: measured 0.005 rad/s).
    """
    sim = torquefree_sim
    sim.add_node(WheelSlewController(context=sim.context))
    commands = sim.tap('wheel_command', JointState)
    states = sim.tap('wheel_states', JointState)
    samples = sim.advance(int(60 * RATE) + 1)  # 0 .. 60 s
    assert sim.node.stepping.state().missed_steps == 0  # every sample answered in time
    commands.wait(len(samples) - 1)
    states.wait(len(samples))
    law = SlewLaw('wheel_slew')
    t = np.array([s.t for s in samples])
    error = np.array([law.error(s.attitude) for s in samples])
    angle = 2.0 * np.arctan2(np.linalg.norm(error[:, :3], axis=1), error[:, 3])
    assert angle[0] == pytest.approx(np.radians(60.0), rel=1e-12)
    assert angle[t >= SETTLE].max() < TOLERANCE, np.degrees(angle[t >= SETTLE].max())
    assert angle[t < 40.0].max() > 10 * TOLERANCE  # (it takes its time: not settled at once)
    rates = np.linalg.norm([s.angular_velocity for s in samples], axis=1)
    assert rates[-1] < 1e-5
    speeds = np.array(states.messages[len(samples) - 1].velocity)
    Js, Fc, b = 0.01, 5e-4, 1e-6  # the scene's wheels
    coasted = (100.0 + Fc / b) * np.exp(-b * t[-1] / Js) - Fc / b
    np.testing.assert_allclose(speeds, coasted * np.array([1, -1, 1, -1]), rtol=0, atol=0.05)
    # the commands named every wheel, within the torque limit (the law scales them down to it
    # at the start: to rounding)
    assert all(list(c.name) == law.names for c in commands.messages)
    efforts = np.array([c.effort for c in commands.messages])
    assert np.abs(efforts).max() == pytest.approx(0.02, rel=1e-15, abs=0)
