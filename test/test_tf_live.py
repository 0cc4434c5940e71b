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
The live /tf round trip through rclpy.

The node publishes tf2_msgs/TFMessage on /tf and a client subscribed with tf2_msgs' own class
receives the attitude bit for bit (parent the inertial frame, child the body frame, zero
translation, the samples' stamps); two nodes in two namespaces, each with its frame_prefix, publish
two body frames under the one inertial frame, at tf2_ros's depth; on an orbit, each message carries
the body, Earth-fixed and LVLH frames, named in the body frame's namespace.

Needs tf2_msgs for Python: a ROS install has it; here test_tf.py builds it with the rosidl
toolchain from PyPI and runs this file in a process that has it (the libraries must be on the path
at start).
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip(
    'tf2_msgs.msg', reason='needs tf2_msgs for Python; test_tf.py builds it and runs this file'
)


def test_the_node_publishes_tf_that_a_tf2_msgs_subscriber_receives_bit_for_bit(tmp_path):
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sim_harness import connected_harness, reset_epoch_ns, stamp_ns
    from tf2_msgs.msg import TFMessage
    from torquefree_ros import load_scene
    from torquefree_ros.core.run.simulation import Simulation

    scene_file = tmp_path / 'tf_scene.yaml'
    scene_file.write_text(
        'body: {inertia: [3.0, 2.0, 1.0]}\ninitial: {angular_velocity: [0.001, 1.0, 0.001]}\n'
        'effects:\n  - tf: {}\n'
    )
    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=10000, reliability=ReliabilityPolicy.RELIABLE
    )
    with connected_harness(
        publish_rate=100.0, body_frame='satellite', scene_directories=[str(tmp_path)]
    ) as harness:
        received = []
        harness.client.create_subscription(TFMessage, '/tf', received.append, qos)
        assert harness.set_parameters(scene=str(scene_file))[0].successful
        response = harness.reset()
        assert response.success and 'not published' not in response.message, response.message
        epoch = reset_epoch_ns(response)
        harness.spin_until(
            lambda: (
                len(
                    [
                        t
                        for m in received
                        for t in m.transforms
                        if stamp_ns(t.header.stamp) >= epoch
                    ]
                )
                >= 100
            ),
            what='100 transforms',
        )
        transforms = [
            t for m in received for t in m.transforms if stamp_ns(t.header.stamp) >= epoch
        ]
        assert all(len(m.transforms) == 1 for m in received)
        types = dict(
            harness.node.get_publisher_names_and_types_by_node(
                harness.node.get_name(), harness.node.get_namespace()
            )
        )
        assert types['/tf'] == ['tf2_msgs/msg/TFMessage']  # absolute: outside the node's namespace
    k = (np.array([stamp_ns(t.header.stamp) for t in transforms]) - epoch) * 100 // 10**9
    np.testing.assert_array_equal(np.diff(k), 1)  # every sample, in order
    block = Simulation(load_scene(scene_file).propagator(), 100.0, epoch).samples(
        0, int(k.max()) + 1
    )
    assert {(t.header.frame_id, t.child_frame_id) for t in transforms} == {('world', 'satellite')}
    np.testing.assert_array_equal(
        [stamp_ns(t.header.stamp) for t in transforms], block.stamps_ns[k]
    )
    np.testing.assert_array_equal(
        [
            [
                t.transform.rotation.x,
                t.transform.rotation.y,
                t.transform.rotation.z,
                t.transform.rotation.w,
            ]
            for t in transforms
        ],
        block.q_NB[k],
    )
    assert all(
        t.transform.translation.x == t.transform.translation.y == t.transform.translation.z == 0.0
        for t in transforms
    )


def test_two_namespaced_nodes_publish_two_body_frames_on_tf_under_one_inertial_frame(tmp_path):
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from test_formation import formation, spin_until
    from tf2_msgs.msg import TFMessage

    scene_file = tmp_path / 'tf_scene.yaml'
    scene_file.write_text(
        'body: {inertia: [3.0, 2.0, 1.0]}\ninitial: {angular_velocity: [0.001, 1.0, 0.001]}\n'
        'effects:\n  - tf: {}\n'
    )
    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE
    )
    with formation(publish_rate=50.0, scene=str(scene_file)) as (client, executor, nodes):
        received = []
        client.create_subscription(TFMessage, '/tf', received.append, qos)

        def pairs():
            return {(t.header.frame_id, t.child_frame_id) for m in received for t in m.transforms}

        spin_until(executor, lambda: len(pairs()) >= 2, 'transforms of both bodies')
        # tf2_ros's TransformBroadcaster depth, whatever qos_depth (10 here) says
        assert [node._outputs.get('/tf').qos_profile.depth for node in nodes] == [100, 100]
        assert [node._outputs.get('angular_velocity').qos_profile.depth for node in nodes] == [
            10,
            10,
        ]
    assert pairs() == {('world', 'sat1/body'), ('world', 'sat2/body')}


def test_on_an_orbit_the_node_publishes_the_earth_fixed_and_lvlh_frames_beside_the_body(tmp_path):
    import yaml
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sim_harness import connected_harness, reset_epoch_ns, stamp_ns
    from test_tf_orbit import BODY, INITIAL, LEO
    from tf2_msgs.msg import TFMessage
    from torquefree_ros import load_scene
    from torquefree_ros.core.run.simulation import Simulation

    scene_file = tmp_path / 'orbit_tf.yaml'
    scene_file.write_text(
        yaml.safe_dump({'body': BODY, 'initial': INITIAL, 'effects': [{'tf': {}}], 'orbit': LEO})
    )
    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=10000, reliability=ReliabilityPolicy.RELIABLE
    )
    with connected_harness(
        publish_rate=100.0, frame_prefix='sat1/', scene_directories=[str(tmp_path)]
    ) as harness:
        received = []
        harness.client.create_subscription(TFMessage, '/tf', received.append, qos)
        assert harness.set_parameters(scene=str(scene_file))[0].successful
        response = harness.reset()
        assert response.success and 'not published' not in response.message, response.message
        epoch = reset_epoch_ns(response)

        def after_reset():
            return [m for m in received if stamp_ns(m.transforms[0].header.stamp) >= epoch]

        harness.spin_until(lambda: len(after_reset()) >= 20, what='20 TFMessages')
        messages = after_reset()
    k = (np.array([stamp_ns(m.transforms[0].header.stamp) for m in messages]) - epoch) * 100
    k //= 10**9
    np.testing.assert_array_equal(np.diff(k), 1)  # every sample, in order
    scene = load_scene(scene_file)
    block = Simulation(scene.propagator(), 100.0, epoch, outputs=scene.outputs).samples(
        0, int(k.max()) + 1
    )
    for index, message in zip(k, messages):
        assert [(t.header.frame_id, t.child_frame_id) for t in message.transforms] == [
            ('world', 'sat1/body'),
            ('world', 'sat1/earth_fixed'),
            ('world', 'sat1/lvlh'),
        ]
        assert {stamp_ns(t.header.stamp) for t in message.transforms} == {block.stamps_ns[index]}
        values = [
            [
                t.transform.translation.x,
                t.transform.translation.y,
                t.transform.translation.z,
                t.transform.rotation.x,
                t.transform.rotation.y,
                t.transform.rotation.z,
                t.transform.rotation.w,
            ]
            for t in message.transforms
        ]
        # bit for bit: the core's rows, through the node's encoder and rclpy's deserializer
        np.testing.assert_array_equal(np.ravel(values), block.outputs[0][index])
