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

import contextlib

import numpy as np
import pytest

pytest.importorskip(
    'tf2_msgs.msg', reason='needs tf2_msgs for Python; test_tf.py builds it and runs this file'
)

#: a body with the tf output and no orbit: one transform, the attitude, per sample
TF_SCENE = (
    'body: {inertia: [3.0, 2.0, 1.0]}\ninitial: {angular_velocity: [0.001, 1.0, 0.001]}\n'
    'effects:\n  - tf: {}\n'
)


@contextlib.contextmanager
def _receiving_tf(scene_file, **node_options):
    """
    Run a node at 100 Hz on ``scene_file``, reset, with a client subscribed to /tf.

    Yields the harness, the TFMessages received (the list grows while the harness spins) and the
    reset's epoch in ns; ``node_options`` go to the node (``body_frame``, ``frame_prefix``).
    """
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sim_harness import connected_harness, reset_epoch_ns
    from tf2_msgs.msg import TFMessage

    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=10000, reliability=ReliabilityPolicy.RELIABLE
    )
    with connected_harness(
        publish_rate=100.0, scene_directories=[str(scene_file.parent)], **node_options
    ) as harness:
        received = []
        harness.client.create_subscription(TFMessage, '/tf', received.append, qos)
        assert harness.set_parameters(scene=str(scene_file))[0].successful
        response = harness.reset()
        assert response.success and 'not published' not in response.message, response.message
        yield harness, received, reset_epoch_ns(response)


def test_the_node_publishes_tf_that_a_tf2_msgs_subscriber_receives_bit_for_bit(tmp_path):
    from bag_checks import transform_table
    from sim_harness import stamp_ns
    from torquefree_ros import load_scene
    from torquefree_ros.core.run.simulation import Simulation

    scene_file = tmp_path / 'tf_scene.yaml'
    scene_file.write_text(TF_SCENE)
    with _receiving_tf(scene_file, body_frame='satellite') as (harness, received, epoch):
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
        tables = [transform_table(m) for m in received]
        types = dict(
            harness.node.get_publisher_names_and_types_by_node(
                harness.node.get_name(), harness.node.get_namespace()
            )
        )
        assert types['/tf'] == ['tf2_msgs/msg/TFMessage']  # absolute: outside the node's namespace
    assert all(len(pairs) == 1 for pairs, _, _ in tables)
    after_reset = [table for table in tables if table[1][0] >= epoch]
    pairs = [pair for table in after_reset for pair in table[0]]
    stamps = np.array([stamp for table in after_reset for stamp in table[1]])
    rows = np.concatenate([table[2] for table in after_reset])
    k = (stamps - epoch) * 100 // 10**9
    np.testing.assert_array_equal(np.diff(k), 1)  # every sample, in order
    block = Simulation(load_scene(scene_file).propagator(), 100.0, epoch).samples(
        0, int(k.max()) + 1
    )
    assert set(pairs) == {('world', 'satellite')}
    np.testing.assert_array_equal(stamps, block.stamps_ns[k])
    np.testing.assert_array_equal(rows[:, 3:7], block.q_NB[k])
    assert not np.any(rows[:, 0:3])  # zero translation


def test_two_namespaced_nodes_publish_two_body_frames_on_tf_under_one_inertial_frame(tmp_path):
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from test_formation import formation, spin_until
    from tf2_msgs.msg import TFMessage

    scene_file = tmp_path / 'tf_scene.yaml'
    scene_file.write_text(TF_SCENE)
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
    from bag_checks import transform_table
    from sim_harness import stamp_ns
    from test_tf_orbit import orbit_frame_pairs, tf_scene_mapping
    from torquefree_ros import load_scene
    from torquefree_ros.core.run.simulation import Simulation

    scene_file = tmp_path / 'orbit_tf.yaml'
    scene_file.write_text(yaml.safe_dump(tf_scene_mapping()))
    with _receiving_tf(scene_file, frame_prefix='sat1/') as (harness, received, epoch):

        def after_reset():
            return [m for m in received if stamp_ns(m.transforms[0].header.stamp) >= epoch]

        harness.spin_until(lambda: len(after_reset()) >= 20, what='20 TFMessages')
        tables = [transform_table(m) for m in after_reset()]
    k = (np.array([stamps[0] for _, stamps, _ in tables]) - epoch) * 100 // 10**9
    np.testing.assert_array_equal(np.diff(k), 1)  # every sample, in order
    scene = load_scene(scene_file)
    block = Simulation(scene.propagator(), 100.0, epoch, outputs=scene.outputs).samples(
        0, int(k.max()) + 1
    )
    for index, (pairs, stamps, rows) in zip(k, tables):
        assert pairs == orbit_frame_pairs('sat1/')
        assert set(stamps) == {block.stamps_ns[index]}
        # bit for bit: the core's rows, through the node's encoder and rclpy's deserializer
        np.testing.assert_array_equal(rows.ravel(), block.outputs[0][index])
