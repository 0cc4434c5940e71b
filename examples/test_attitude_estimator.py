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
The estimator of attitude_estimator.py against the simulator's exact truth.

It runs through the test kit's pytest fixture, ``torquefree_sim``.
"""

from attitude_estimator import AttitudeEstimator
from geometry_msgs.msg import QuaternionStamped
import numpy as np
import pytest


@pytest.mark.torquefree_sim(scene='estimator')  # 100 Hz gyro with a bias, a 10 Hz star tracker
def test_the_estimate_stays_within_a_milliradian_of_the_truth(torquefree_sim):
    sim = torquefree_sim
    sim.add_node(AttitudeEstimator(context=sim.context))
    estimates = sim.tap('attitude_estimate', QuaternionStamped)
    sim.advance(3000)  # 30 s: each sample processed by the estimator before the next goes out
    # one per gyro sample from the second on (the first fix comes with the first)
    estimates.wait(2999)
    t = np.array([sim.time_of(e.header.stamp) for e in estimates.messages])
    q = np.array(
        [
            [e.quaternion.x, e.quaternion.y, e.quaternion.z, e.quaternion.w]
            for e in estimates.messages
        ]
    )
    truth = sim.truth(t).attitude
    error = 2 * np.arccos(np.clip(np.abs(np.sum(q * truth, axis=1)), 0.0, 1.0))  # rad
    settled = t >= 10.0  # the bias estimate settles within 10 s
    assert error[settled].max() < 1e-3, f'worst error after 10 s: {error[settled].max():.2e} rad'
