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
The ``tf`` output and the vendored tf2_msgs interface.

Bags carry /tf with rosbag2's full schema and Jazzy's type hash, its messages equal the attitude
bit for bit and read in both independent readers; the encoding is rosbags' own, byte for byte;
live, through rclpy, with tf2_msgs built from the vendored interface by the PyPI rosidl toolchain;
a node whose Python lacks tf2_msgs leaves /tf out and says so.
"""

from __future__ import annotations

import os
from pathlib import Path
import subprocess
import sys

from conftest import missing_requirement
import numpy as np
import pytest
from torquefree_ros.bag.cdr import encode_transforms
from torquefree_ros.bag.definitions import message_definition
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping

REPO = Path(__file__).resolve().parents[1]
# what `ros2 topic info /tf --verbose` shows on a Jazzy install (and rosbag2's metadata.yaml of a
# Jazzy bag)
JAZZY_TF_HASH = 'RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087'


def test_the_vendored_interface_is_what_the_rosidl_tools_generate():
    result = subprocess.run(
        [sys.executable, str(REPO / 'tools' / 'make_interfaces.py'), '--check'],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_schema_is_rosbag2s_layout_with_jazzys_hash():
    definition = message_definition('tf2_msgs/msg/TFMessage')
    assert definition.type_hash == JAZZY_TF_HASH and definition.encoding == 'ros2msg'
    sections = definition.text.split('=' * 80 + '\n')
    assert sections[0] == 'geometry_msgs/TransformStamped[] transforms\n\n'
    assert [section.splitlines()[0] for section in sections[1:]] == [
        'MSG: geometry_msgs/TransformStamped',
        'MSG: geometry_msgs/Transform',
        'MSG: geometry_msgs/Quaternion',
        'MSG: geometry_msgs/Vector3',
        'MSG: std_msgs/Header',
        'MSG: builtin_interfaces/Time',
    ]


def test_the_encoding_is_byte_for_byte_rosbags_own():
    from rosbags.typesys import get_typestore, Stores

    store = get_typestore(Stores.ROS2_JAZZY)
    rows = np.array([[0.0, 0.0, 0.0, 0.1, -0.2, 0.3, 0.9], [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0]])
    for parent, child in (('world', 'body'), ('w', 'a_much_longer_body_frame'), ('map/odom', 'b')):
        for stamp, row, message in zip(
            (0, 1_700_000_000_123_456_789),
            rows,
            encode_transforms(np.array([0, 1_700_000_000_123_456_789]), parent, child, rows),
        ):
            decoded = store.deserialize_cdr(message, 'tf2_msgs/msg/TFMessage')
            (transform,) = decoded.transforms
            assert (transform.header.frame_id, transform.child_frame_id) == (parent, child)
            assert transform.header.stamp.sec * 10**9 + transform.header.stamp.nanosec == stamp
            t, r = transform.transform.translation, transform.transform.rotation
            assert [t.x, t.y, t.z, r.x, r.y, r.z, r.w] == row.tolist()
            assert store.serialize_cdr(decoded, 'tf2_msgs/msg/TFMessage') == message


def _tf_scene(tmp_path, rate=''):
    path = tmp_path / 'tf_scene.yaml'
    path.write_text(
        'body: {inertia: [3.0, 2.0, 1.0]}\ninitial: {angular_velocity: [0.001, 1.0, 0.001]}\n'
        f'effects:\n  - tf: {{{rate}}}\n'
    )
    return path


def test_a_bag_carries_tf_equal_to_the_attitude_in_both_independent_readers(tmp_path):
    from bag_checks import metadata, read_with_mcap, read_with_rosbags, stamp_ns
    from torquefree_ros import load_scene
    from torquefree_ros.cli.bag import main as bag_main

    scene_file = _tf_scene(tmp_path)
    bag = tmp_path / 'tf_bag'
    assert (
        bag_main(
            [
                str(scene_file),
                '--duration',
                '2',
                '--rate',
                '50',
                '--output',
                str(bag),
                '--body-frame',
                'satellite',
                '--namespace',
                '/sim',
            ]
        )
        == 0
    )
    block = Simulation(load_scene(scene_file).propagator(), 50.0).samples(0, 101)
    messages, connections = read_with_rosbags(bag)
    assert connections['/tf'].msgtype == 'tf2_msgs/msg/TFMessage'  # absolute: not under /sim
    transforms = [m.transforms[0] for _, m in messages['/tf']]
    assert [stamp_ns(t.header) for t in transforms] == block.stamps_ns.tolist()
    assert {(t.header.frame_id, t.child_frame_id) for t in transforms} == {('world', 'satellite')}
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
        block.q_NB,
    )
    assert all(
        t.transform.translation.x == t.transform.translation.y == t.transform.translation.z == 0.0
        for t in transforms
    )
    decoded = read_with_mcap(bag)  # mcap-ros2 decodes from the bag's own schema text
    assert decoded['/tf'][50][2].transforms[0].transform.rotation.w == block.q_NB[50, 3]
    topics = {
        t['topic_metadata']['name']: t['topic_metadata']
        for t in metadata(bag)['topics_with_message_count']
    }
    assert topics['/tf']['type'] == 'tf2_msgs/msg/TFMessage'
    assert topics['/tf']['type_description_hash'] == JAZZY_TF_HASH


def test_tf_at_a_rate_of_its_own(tmp_path):
    scene = scene_from_mapping(
        {
            'body': {'inertia': [3.0, 2.0, 1.0]},
            'initial': {'angular_velocity': [0, 1, 0]},
            'effects': [{'tf': {'rate': 10.0}}],
        }
    )
    block = Simulation(scene.propagator(), 50.0, outputs=scene.outputs).samples(0, 51)
    np.testing.assert_array_equal(block.outputs[0][:, 3:], block.q_NB[::5])


def test_live_tf_through_rclpy_with_tf2_msgs_built_from_the_vendored_interface(tmp_path_factory):
    from interfaces import build

    missing = build.missing_tools()
    if missing:
        reason = (
            f'building tf2_msgs needs {", ".join(missing)} '
            '(the rosidl toolchain compiles its typesupport)'
        )
        missing_requirement(reason)
    environment = {**os.environ, **build.build('tf2_msgs', tmp_path_factory.mktemp('tf2_msgs'))}
    # a process of its own: the typesupport libraries must be on the library path when it starts
    result = subprocess.run(
        [
            sys.executable,
            '-m',
            'pytest',
            '-q',
            '-p',
            'no:cacheprovider',
            str(REPO / 'test' / 'test_tf_live.py'),
        ],
        cwd=REPO,
        env=environment,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0 and '3 passed' in result.stdout, (
        result.stdout[-4000:] + result.stderr[-4000:]
    )


def test_a_node_without_tf2_msgs_leaves_tf_out_and_says_so(tmp_path):
    try:
        import tf2_msgs  # noqa: F401

        # a ROS install: the node publishes /tf then (test_tf_live.py checks it)
        pytest.skip('tf2_msgs is installed here: the node publishes /tf instead of leaving it out')
    except ImportError:
        pass
    from sim_harness import connected_harness

    with connected_harness(publish_rate=100.0, scene_directories=[str(tmp_path)]) as harness:
        assert harness.set_parameters(scene=str(_tf_scene(tmp_path)))[0].successful
        response = harness.reset()
        assert response.success, response.message
        assert 'not published: tf (tf2_msgs/msg/TFMessage)' in response.message
        names = {
            name
            for name, _ in harness.node.get_publisher_names_and_types_by_node(
                harness.node.get_name(), harness.node.get_namespace()
            )
        }
        assert '/tf' not in names
        # (no sample of the start-up run may have been taken yet on a busy machine)
        last = max((stamp for stamp, _, _ in harness.pairs()), default=None)
        harness.wait_samples(3, after=last)  # the rest of the scene runs
