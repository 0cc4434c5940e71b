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
The ``odometry`` output (nav_msgs/Odometry): the core's rows, the encoding, bags, the node.

The encoding: rclpy's own serializer decodes it, rosbags re-encodes it byte for byte. The bag: both
independent readers, the schema text rosbag2 writes. The node: in process. Everywhere the pose is
``q_NB`` and the twist's angular part the body rates bit for bit as the ``attitude`` and
``angular_velocity`` of the same sample carry them; position and linear velocity zero, both
covariances zero (exact values).
"""

from __future__ import annotations

import json
from pathlib import Path
import sys

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest
from torquefree_ros.bag import message_definition
from torquefree_ros.bag.cdr import encode_odometry
from torquefree_ros.core.effects.outputs import ODOMETRY_ROW
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping, SceneError

RATE = 50.0
SCENE = {
    'body': {'inertia': [4.0, 3.0, 2.5, 0.3, -0.2, 0.4]},  # a full tensor: body frame != principal
    'initial': {
        'angular_velocity': [0.4, -1.0, 0.7],
        'orientation': [0.1, -0.3, 0.2, 0.9273618495495703],
    },
    'effects': [{'odometry': {}}],
}
ODOMETRY_TYPE = 'nav_msgs/msg/Odometry'


def _simulation(scene=SCENE, rate=RATE, epoch=0):
    scene = scene_from_mapping(scene)
    return Simulation(scene.propagator(), rate, epoch, outputs=scene.outputs)


# -- core -----------------------------------------------------------------------------------------
def test_rows_are_the_samples_attitude_and_rates_bit_for_bit():
    block = _simulation().samples(0, 300)
    (rows,) = block.outputs
    assert rows.shape == (300, ODOMETRY_ROW)
    # pose.orientation: q_NB, the same floats
    np.testing.assert_array_equal(rows[:, 3:7], block.q_NB)
    # twist.angular: w, body (child) frame
    np.testing.assert_array_equal(rows[:, 10:13], block.omega_B)
    np.testing.assert_array_equal(rows[:, 0:3], 0.0)  # position
    np.testing.assert_array_equal(rows[:, 7:10], 0.0)  # linear velocity


def test_rows_do_not_depend_on_blocks_and_an_own_rate_takes_every_nth_sample():
    simulation = _simulation()
    whole = simulation.samples(0, 100).outputs[0]
    cut = np.vstack([simulation.samples(first, 7).outputs[0] for first in range(0, 100, 7)])[:100]
    np.testing.assert_array_equal(cut, whole)
    slow = _simulation({**SCENE, 'effects': [{'odometry': {'rate': 10.0, 'topic': 'truth/odom'}}]})
    block = slow.samples(0, 100)
    (rows,) = block.outputs
    np.testing.assert_array_equal(block.output_positions[0], np.arange(0, 100, 5))
    np.testing.assert_array_equal(rows, whole[::5])
    assert slow.outputs[0].topic == 'truth/odom'


@pytest.mark.parametrize(
    'parameters, reason',
    [
        ({'rate': 7.0}, r'odometry\.rate: 7 Hz must divide'),
        ({'topic': '1bad'}, r'effects\[0\]\.odometry\.topic: expected a ROS topic name'),
        ({'covariance': 0.0}, r'effects\[0\]\.odometry\.covariance: unknown key'),
    ],
)
def test_parameters_are_checked_with_the_field_path(parameters, reason):
    with pytest.raises((SceneError, ValueError), match=reason):
        _simulation({**SCENE, 'effects': [{'odometry': parameters}]}).samples(0, 1)


# -- the encoding ---------------------------------------------------------------------------------
stamps = st.lists(st.integers(0, 2**31 * 10**9 - 1), min_size=1, max_size=8)
frame_ids = st.text(
    alphabet=st.characters(blacklist_characters='\x00', blacklist_categories=('Cs',)), max_size=12
)
doubles = st.floats(allow_nan=False, width=64)


@settings(max_examples=150, deadline=None)
@given(stamps=stamps, frame_id=frame_ids, child_frame_id=frame_ids, data=st.data())
def test_the_encoding_decodes_in_rclpy_and_is_byte_for_byte_rosbags_own(
    stamps, frame_id, child_frame_id, data
):
    from nav_msgs.msg import Odometry
    from rclpy.serialization import deserialize_message
    from rosbags.typesys import get_typestore, Stores

    store = get_typestore(Stores.ROS2_JAZZY)
    rows = np.array(
        data.draw(
            st.lists(
                st.lists(doubles, min_size=13, max_size=13),
                min_size=len(stamps),
                max_size=len(stamps),
            )
        )
    )
    messages = encode_odometry(np.array(stamps, dtype=np.int64), frame_id, child_frame_id, rows)
    assert len(messages) == len(stamps)
    for stamp, row, ours in zip(stamps, rows, messages):
        message = deserialize_message(ours, Odometry)
        assert (message.header.stamp.sec, message.header.stamp.nanosec) == divmod(stamp, 10**9)
        assert (message.header.frame_id, message.child_frame_id) == (frame_id, child_frame_id)
        pose, twist = message.pose.pose, message.twist.twist
        assert [pose.position.x, pose.position.y, pose.position.z] == row[0:3].tolist()
        assert [
            pose.orientation.x,
            pose.orientation.y,
            pose.orientation.z,
            pose.orientation.w,
        ] == row[3:7].tolist()
        assert [twist.linear.x, twist.linear.y, twist.linear.z] == row[7:10].tolist()
        assert [twist.angular.x, twist.angular.y, twist.angular.z] == row[10:13].tolist()
        assert (
            message.pose.covariance.tolist() == [0.0] * 36
            and message.twist.covariance.tolist() == [0.0] * 36
        )
        # rosbags writes zero padding as we do: the bytes must be identical (rclpy's padding is
        # arbitrary)
        assert (
            store.serialize_cdr(store.deserialize_cdr(ours, ODOMETRY_TYPE), ODOMETRY_TYPE) == ours
        )


def test_a_row_of_the_wrong_width_is_refused_with_its_shape():
    with pytest.raises(
        ValueError, match=r'odometry rows: expected 13 float64s per row .* got shape \(2, 7\)'
    ):
        encode_odometry([0, 1], 'world', 'body', np.zeros((2, 7)))


def test_schema_text_is_rosbag2s_layout():
    share = Path(sys.prefix) / 'share'

    def msg(name):
        package, base = name.split('/')
        return (share / package / 'msg' / f'{base}.msg').read_text()

    # depth first, each dependency once, sorted by the name as written (Pose → geometry_msgs/Pose)
    order = [
        'geometry_msgs/PoseWithCovariance',
        'geometry_msgs/Pose',
        'geometry_msgs/Point',
        'geometry_msgs/Quaternion',
        'geometry_msgs/TwistWithCovariance',
        'geometry_msgs/Twist',
        'geometry_msgs/Vector3',
        'std_msgs/Header',
        'builtin_interfaces/Time',
    ]
    expected = msg('nav_msgs/Odometry') + ''.join(
        f'\n{"=" * 80}\nMSG: {name}\n{msg(name)}' for name in order
    )
    definition = message_definition(ODOMETRY_TYPE)
    assert definition.encoding == 'ros2msg'
    assert definition.text == expected
    hashes = json.loads((share / 'nav_msgs' / 'msg' / 'Odometry.json').read_text())['type_hashes']
    assert (
        definition.type_hash == {h['type_name']: h['hash_string'] for h in hashes}[ODOMETRY_TYPE]
    )


# -- bags -----------------------------------------------------------------------------------------
def _vector(v):
    return [v.x, v.y, v.z]


def _quaternion(q):
    return [q.x, q.y, q.z, q.w]


def test_a_bag_carries_odometry_equal_to_its_attitude_and_rates_in_both_independent_readers(
    tmp_path,
):
    from bag_checks import read_with_mcap, read_with_rosbags, stamp_ns, summary
    from torquefree_ros.cli.bag import main as bag_main
    import yaml

    scene = tmp_path / 'odometry.yaml'
    scene.write_text(yaml.safe_dump(SCENE))
    bag = tmp_path / 'odometry_bag'
    assert (
        bag_main(
            [
                str(scene),
                '--duration',
                '2',
                '--rate',
                '50',
                '--output',
                str(bag),
                '--start-time',
                '1700000000.25',
                '--inertial-frame',
                'odom',
                '--body-frame',
                'base_link',
            ]
        )
        == 0
    )
    messages, connections = read_with_rosbags(bag)
    assert connections['/odometry'].msgtype == ODOMETRY_TYPE
    odometry = [m for _, m in messages['/odometry']]
    attitude = [m for _, m in messages['/attitude']]
    rates = [m for _, m in messages['/angular_velocity']]
    assert len(odometry) == len(attitude) == len(rates) == 101
    assert (
        [stamp_ns(m.header) for m in odometry]
        == [stamp_ns(m.header) for m in attitude]
        == [stamp_ns(m.header) for m in rates]
    )
    assert {(m.header.frame_id, m.child_frame_id) for m in odometry} == {('odom', 'base_link')}
    np.testing.assert_array_equal(
        [_quaternion(m.pose.pose.orientation) for m in odometry],
        [_quaternion(m.quaternion) for m in attitude],
    )
    np.testing.assert_array_equal(
        [_vector(m.twist.twist.angular) for m in odometry], [_vector(m.vector) for m in rates]
    )
    np.testing.assert_array_equal(
        [_vector(m.pose.pose.position) + _vector(m.twist.twist.linear) for m in odometry], 0.0
    )
    np.testing.assert_array_equal(
        [np.concatenate([m.pose.covariance, m.twist.covariance]) for m in odometry], 0.0
    )
    # the schema the bag carries is rosbag2's text for the type (checked above against the .msg
    # files)
    _, file_summary, _ = summary(bag)
    (schema,) = [s for s in file_summary.schemas.values() if s.name == ODOMETRY_TYPE]
    assert (
        schema.encoding == 'ros2msg'
        and schema.data.decode() == message_definition(ODOMETRY_TYPE).text
    )

    decoded = read_with_mcap(bag)  # mcap-ros2 decodes from the bag's own schema text
    by_stamp = {
        topic: {stamp_ns(m.header): m for _, _, m in decoded[topic]}
        for topic in ('/odometry', '/attitude', '/angular_velocity')
    }
    assert (
        by_stamp['/odometry'].keys()
        == by_stamp['/attitude'].keys()
        == by_stamp['/angular_velocity'].keys()
    )
    for stamp, m in by_stamp['/odometry'].items():
        assert _quaternion(m.pose.pose.orientation) == _quaternion(
            by_stamp['/attitude'][stamp].quaternion
        )
        assert _vector(m.twist.twist.angular) == _vector(
            by_stamp['/angular_velocity'][stamp].vector
        )
        assert m.child_frame_id == 'base_link'


# -- the node -------------------------------------------------------------------------------------
def test_the_node_publishes_odometry_equal_to_its_attitude_and_rates(tmp_path):
    from nav_msgs.msg import Odometry
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sim_harness import connected_harness, reset_epoch_ns, stamp_ns
    import yaml

    scene = tmp_path / 'odometry.yaml'
    scene.write_text(yaml.safe_dump(SCENE))
    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=10000, reliability=ReliabilityPolicy.RELIABLE
    )
    with connected_harness(publish_rate=100.0, frame_prefix='sat1/') as harness:
        odometry = []
        harness.client.create_subscription(Odometry, 'odometry', odometry.append, qos)
        assert harness.set_parameters(scene=str(scene))[0].successful
        response = harness.reset()
        assert response.success, response.message
        epoch = reset_epoch_ns(response)

        def fresh():
            return [
                m
                for m in odometry
                if stamp_ns(m.header.stamp) >= epoch
                and stamp_ns(m.header.stamp) in harness.q
                and stamp_ns(m.header.stamp) in harness.omega
            ]

        harness.spin_until(
            lambda: len(fresh()) >= 120, what='120 odometry messages with their attitude and rates'
        )
        received = fresh()
        assert {(m.header.frame_id, m.child_frame_id) for m in received} == {
            ('world', 'sat1/body')
        }
        stamps = [stamp_ns(m.header.stamp) for m in received]
        np.testing.assert_array_equal(
            [_quaternion(m.pose.pose.orientation) for m in received],
            [harness.q[s] for s in stamps],
        )
        np.testing.assert_array_equal(
            [_vector(m.twist.twist.angular) for m in received], [harness.omega[s] for s in stamps]
        )
        # and they are the core's samples k on the run's grid
        k = (np.array(stamps) - epoch) * 100 // 10**9
        block = _simulation(rate=100.0, epoch=epoch).samples(0, int(k.max()) + 1)
        np.testing.assert_array_equal(block.stamps_ns[k], stamps)
        np.testing.assert_array_equal(
            [_quaternion(m.pose.pose.orientation) for m in received], block.q_NB[k]
        )
        np.testing.assert_array_equal(
            [_vector(m.twist.twist.angular) for m in received], block.omega_B[k]
        )
        assert all(not any(m.pose.covariance) and not any(m.twist.covariance) for m in received)
