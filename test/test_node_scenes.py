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
Scenes in the node.

Outputs publish only while a scene names them, their samples are the core's, effects switch the
propagator, and a bad scene file changes nothing.
"""

from __future__ import annotations

from geometry_msgs.msg import Vector3Stamped
import numpy as np
import pytest
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu
from sim_harness import connected_harness, reset_epoch_ns, stamp_ns
from torquefree_ros import load_scene
from torquefree_ros.core.run.simulation import Simulation


@pytest.fixture
def harness():
    with connected_harness(publish_rate=200.0) as h:
        yield h


def published_topics(harness) -> set[str]:
    node = harness.node
    names = node.get_publisher_names_and_types_by_node(node.get_name(), node.get_namespace())
    return {name.rsplit('/', 1)[-1] for name, _ in names}


def test_outputs_publish_only_while_the_scene_names_them(harness):
    assert published_topics(harness) >= {'angular_velocity', 'attitude'}
    assert not published_topics(harness) & {'imu', 'euler_angles', 'clock'}

    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=10000, reliability=ReliabilityPolicy.RELIABLE
    )
    imu, euler = [], []
    harness.client.create_subscription(Imu, 'imu', imu.append, qos)
    harness.client.create_subscription(Vector3Stamped, 'euler_angles', euler.append, qos)
    assert harness.set_parameters(scene='imu')[0].successful
    response = harness.reset()
    assert response.success, response.message
    assert (
        'imu(gyro_noise_density=0.0001' in response.message
        and 'propagator analytic' in response.message
    )
    assert published_topics(harness) >= {'imu', 'euler_angles'}
    harness.spin_until(
        lambda: len(imu) >= 60 and len(euler) >= 60, what='imu and euler_angles samples'
    )

    # every output sample is the core's own for its index k on the run's grid
    scene = load_scene('imu')
    epoch = reset_epoch_ns(response)
    stamps = np.array([stamp_ns(m.header.stamp) for m in imu])
    k = (stamps - epoch) * 200 // 10**9
    assert np.all(k >= 0)
    block = Simulation(scene.propagator(), 200.0, epoch, outputs=scene.outputs).samples(
        0, int(k.max()) + 1
    )
    imu_rows, euler_rows = block.outputs
    got = np.array(
        [[m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z] for m in imu]
    )
    np.testing.assert_array_equal(got, imu_rows[k, 13:16])
    assert all(
        m.header.frame_id == 'body'
        and m.orientation_covariance[0] == -1.0
        and m.linear_acceleration_covariance[0] == -1.0
        for m in imu
    )
    np.testing.assert_array_equal(np.array(imu[0].angular_velocity_covariance), imu_rows[0, 16:25])
    euler_k = (np.array([stamp_ns(m.header.stamp) for m in euler]) - epoch) * 200 // 10**9
    got = np.array([[m.vector.x, m.vector.y, m.vector.z] for m in euler])
    np.testing.assert_array_equal(got, euler_rows[euler_k])
    assert all(m.header.frame_id == 'world' for m in euler)

    # back to the default scene: the output publishers go away
    assert harness.set_parameters(scene='')[0].successful
    assert harness.reset().success
    assert not published_topics(harness) & {'imu', 'euler_angles'}


def test_a_bad_scene_file_is_refused_and_the_running_scene_goes_on(harness, tmp_path):
    assert harness.set_parameters(scene='gyrostat')[0].successful
    first = harness.reset()
    assert first.success and 'rotor(momentum=5' in first.message
    assert 'propagator gyrostat, accuracy: exact' in first.message
    # the gyrostat's own regime (its equilibria move with h), not the free body's reading
    assert 'regime: free gyrostat (h 5 N m s along principal axis' in first.message
    assert 'torque-free regime of the initial state' not in first.message
    bad = tmp_path / 'bad.yaml'
    bad.write_text(
        'body: {inertia: [3, 2, 1]}\ninitial: {angular_velocity: [0, 0, 1]}\n'
        'effects: [{external_torque: {torque: [0, 1], frame: inertial}}]\n'
    )
    result = harness.set_parameters(scene=str(bad))[0]
    assert not result.successful
    assert result.reason.startswith(
        f'scene: {bad}: effects[0].external_torque.torque: expected 3 numbers'
    ), result.reason
    assert harness.get_parameter('scene') == 'gyrostat'
    again = harness.reset()
    assert again.success and 'rotor(momentum=5' in again.message


def test_effects_in_the_node_choose_dop853_and_report_what_is_conserved(harness):
    assert harness.set_parameters(scene='explorer1')[0].successful
    response = harness.reset()
    assert 'damper(inertia=0.05, damping=0.01)' in response.message
    assert 'propagator dop853(rtol=1e-09, atol=1e-11)' in response.message
    assert 'torque-free regime of the initial state' in response.message

    def conserved():
        for array in harness.diagnostics:
            values = {kv.key: kv.value for kv in array.status[0].values}
            if 'damper' in values.get('effects', '') and 'conserved' in values:
                return values
        return None

    harness.spin_until(lambda: conserved() is not None, what='diagnostics of the damped run')
    values = conserved()
    assert values['conserved'] == 'momentum'
    assert abs(float(values['angular_momentum_drift'])) < 1e-8


def test_the_coning_scene_reports_its_cones_on_reset(harness):
    assert harness.set_parameters(scene='axisymmetric_coning')[0].successful
    response = harness.reset()
    assert 'body cone angle 9.46232 deg, space cone angle 8.97263 deg' in response.message
    assert 'symmetry axis precesses about H at 1.58114 rad/s' in response.message
