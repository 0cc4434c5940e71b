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
The ``markers`` output: the body's box, the arrows w and H and their labels.

The box's geometry is the uniform box of the body's principal moments on its principal axes; the
arrows are w and H in the inertial frame, in colours no frame axis has, each labelled past its tip;
all five markers are in every message (a viewer that seeks shows the latest message alone); the
encoding decodes in rclpy and is rosbags' own byte for byte; bags (both independent readers) and
the live node carry what the core computes.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from torquefree_ros.bag.markers import (
    ANGULAR_MOMENTUM,
    ANGULAR_MOMENTUM_LABEL,
    ANGULAR_VELOCITY,
    ANGULAR_VELOCITY_LABEL,
    BODY,
    encode_markers,
)
from torquefree_ros.core.effects.outputs import MARKER_ROW
from torquefree_ros.core.frames import quaternion
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping, SceneError

RATE = 50.0
# every MarkerArray's namespaces, in order
NAMESPACES = [
    'body',
    'angular_velocity',
    'angular_momentum',
    'angular_velocity_label',
    'angular_momentum_label',
]
# Ixx, Iyy, Izz, Ixy, Ixz, Iyz: principal axes tilted
GENERIC_TENSOR = [4.0, 3.0, 2.5, 0.3, -0.2, 0.4]
ORIENTATION = [0.1, -0.3, 0.2, math.sqrt(0.86)]


def _simulation(body, angular_velocity, *effects, rate=RATE):
    scene = scene_from_mapping(
        {
            'body': body,
            'initial': {'angular_velocity': angular_velocity, 'orientation': ORIENTATION},
            'effects': list(effects),
        }
    )
    return Simulation(scene.propagator(), rate, outputs=scene.outputs)


def _box_inertia_N(row):
    """
    Return the inertia tensor of the uniform box a marker row draws.

    Per unit mass, in the inertial frame.
    """
    a2, b2, c2 = row[4:7] ** 2
    box = np.diag([b2 + c2, a2 + c2, a2 + b2]) / 12.0
    R = quaternion.to_matrix(row[0:4])
    return R @ box @ R.T


@pytest.mark.parametrize(
    'inertia', [GENERIC_TENSOR, [2.0, 3.0, 4.0], [5.0, 1.0, 5.0], [1.0, 1.0, 1.0]]
)
def test_the_box_has_the_bodys_principal_moments_on_its_principal_axes(inertia):
    simulation = _simulation({'inertia': inertia}, [0.4, -1.0, 0.7], {'markers': {'size': 2.0}})
    block = simulation.samples(0, 200)
    (rows,) = block.outputs
    assert rows.shape == (200, MARKER_ROW)
    assert rows[:, 4:7].max(axis=1) == pytest.approx(2.0, rel=1e-15)  # the longest side is `size`
    J_B = simulation.body.tensor
    for row, q in zip(rows[::37], block.q_NB[::37]):
        R = quaternion.to_matrix(q)
        J_N = R @ J_B @ R.T  # the body's inertia now, inertial frame
        box = _box_inertia_N(row)
        np.testing.assert_allclose(box / np.trace(box), J_N / np.trace(J_N), rtol=0, atol=1e-14)


@pytest.mark.parametrize('inertia, thin', [([1.0, 2.0, 3.0], 2), ([1e-6, 1.0, 1.0], [1, 2])])
def test_a_plate_or_a_rod_is_drawn_one_percent_thick(inertia, thin):
    (rows,) = (
        _simulation({'inertia': inertia}, [0.0, 1.0, 0.0], {'markers': {}}).samples(0, 3).outputs
    )
    sides = rows[0, 4:7]
    assert sides.max() == 1.0
    np.testing.assert_array_equal(sides[thin], 0.01)


def test_the_arrows_are_w_and_h_in_the_inertial_frame_with_the_default_scales():
    simulation = _simulation(
        {'inertia': GENERIC_TENSOR}, [0.4, -1.0, 0.7], {'markers': {'size': 2.0}}
    )
    block = simulation.samples(0, 500)
    (rows,) = block.outputs
    body = simulation.body
    w_N = quaternion.rotate(block.q_NB, block.omega_B)
    h_N = body.angular_momentum_inertial(block.omega_B, block.q_NB)
    w0, h0 = np.linalg.norm(block.omega_B[0]), np.linalg.norm(h_N[0])
    np.testing.assert_allclose(rows[:, 7:10], w_N * (2.0 / w0), rtol=0, atol=1e-14)
    np.testing.assert_allclose(rows[:, 10:13], h_N * (2.5 / h0), rtol=0, atol=1e-14)
    # the initial w: `size` long
    assert np.linalg.norm(rows[0, 7:10]) == pytest.approx(2.0, rel=1e-15)
    # torque-free: the H arrow stands still while the w arrow wanders round it
    np.testing.assert_allclose(
        rows[:, 10:13], np.broadcast_to(rows[0, 10:13], (500, 3)), rtol=0, atol=1e-13
    )
    assert np.ptp(rows[:, 7:10], axis=0).max() > 0.5


def test_explicit_scales_are_lengths_per_unit():
    simulation = _simulation(
        {'inertia': [2.0, 3.0, 4.0]},
        [0.4, -1.0, 0.7],
        {'markers': {'angular_velocity_scale': 0.5, 'momentum_scale': 0.1}},
    )
    block = simulation.samples(0, 10)
    (rows,) = block.outputs
    np.testing.assert_allclose(
        np.linalg.norm(rows[:, 7:10], axis=1),
        0.5 * np.linalg.norm(block.omega_B, axis=1),
        rtol=1e-15,
    )
    h = simulation.body.angular_momentum(block.omega_B)
    np.testing.assert_allclose(
        np.linalg.norm(rows[:, 10:13], axis=1), 0.1 * np.linalg.norm(h, axis=1), rtol=1e-14
    )


def test_rows_do_not_depend_on_how_blocks_are_cut():
    simulation = _simulation({'inertia': [2.0, 3.0, 4.0]}, [0.4, -1.0, 0.7], {'markers': {}})
    whole = simulation.samples(0, 120).outputs[0]
    cut = np.vstack([simulation.samples(first, 7).outputs[0] for first in range(0, 120, 7)])[:120]
    np.testing.assert_array_equal(cut, whole)
    # one sample at a time (a closed loop's blocks) is computed on floats rather than arrays
    single = np.vstack([simulation.samples(first, 1).outputs[0] for first in range(120)])
    np.testing.assert_array_equal(single, whole)


def test_one_message_at_a_time_is_the_blocks_bytes():
    # one message is packed field by field, a block through numpy: the same bytes
    stamps, rows = _rows(count=9)
    whole = encode_markers(stamps, 'world', rows)
    assert [
        encode_markers(stamps[i: i + 1], 'world', rows[i: i + 1])[0] for i in range(9)
    ] == list(whole)


def test_the_h_arrow_follows_a_torque_that_changes_h():
    torqued = _simulation(
        {'inertia': [2.0, 3.0, 4.0]},
        [0.4, -1.0, 0.7],
        {'external_torque': {'torque': [0.0, 0.0, 0.5]}},
        {'markers': {}},
    )
    block = torqued.samples(0, 60)
    rows = block.outputs[0]
    h_N = torqued.body.angular_momentum_inertial(block.omega_B, block.q_NB)
    np.testing.assert_allclose(
        rows[:, 10:13], h_N * (1.25 / np.linalg.norm(h_N[0])), rtol=0, atol=1e-13
    )
    assert np.linalg.norm(rows[-1, 10:13] - rows[0, 10:13]) > 1e-3


@pytest.mark.parametrize(
    'parameters, reason',
    [
        ({'size': 0}, r'effects\[0\]\.markers\.size: must be > 0 m, got 0'),
        # retired (issue 31): refused with what replaced it, whatever its value
        (
            {'momentum_interval': 1.0},
            r'effects\[0\]\.markers\.momentum_interval: no longer used: every MarkerArray now '
            r'carries the H arrow.*remove this key',
        ),
        (
            {'angular_velocity_scale': 'big'},
            r'effects\[0\]\.markers\.angular_velocity_scale: expected a finite number',
        ),
        ({'colour': 1}, r'effects\[0\]\.markers\.colour: unknown key'),
    ],
)
def test_marker_parameters_are_checked_with_the_field_path(parameters, reason):
    with pytest.raises(SceneError, match=reason):
        _simulation({'inertia': [2.0, 3.0, 4.0]}, [0.0, 1.0, 0.0], {'markers': parameters})


# the frame and pose axes the views draw: RViz's red, green and blue, then Foxglove's and
# Lichtblick's shades of them (their 3-D panel's Axis)
AXIS_COLOURS = [
    (1.0, 0.0, 0.0),
    (0.0, 1.0, 0.0),
    (0.0, 0.0, 1.0),
    (0x9C / 255, 0x39 / 255, 0x48 / 255),
    (0x88 / 255, 0xDD / 255, 0x04 / 255),
    (0x2B / 255, 0x90 / 255, 0xFB / 255),
]


def test_w_and_h_have_colours_no_axis_has_and_read_apart_where_they_are_parallel():
    w, h = ANGULAR_VELOCITY.color[:3], ANGULAR_MOMENTUM.color[:3]
    for colour in (w, h):
        assert min(math.dist(colour, axis) for axis in AXIS_COLOURS) > 0.5, colour
        assert math.dist(colour, BODY.color[:3]) > 0.5, colour
    assert math.dist(w, h) > 0.5
    assert ANGULAR_VELOCITY.color[3] == ANGULAR_MOMENTUM.color[3] == 1.0
    # where w and H are parallel (a spin about a principal axis), the thinner H, longer by
    # default, comes out of the w arrow rather than hiding it
    (w_shaft, w_head), (h_shaft, h_head) = ANGULAR_VELOCITY.size, ANGULAR_MOMENTUM.size
    assert w_shaft > h_shaft and w_head > h_head
    # labels: each arrow's name in its colour
    assert (ANGULAR_VELOCITY_LABEL.text, ANGULAR_VELOCITY_LABEL.color) == (
        'w',
        ANGULAR_VELOCITY.color,
    )
    assert (ANGULAR_MOMENTUM_LABEL.text, ANGULAR_MOMENTUM_LABEL.color) == (
        'H',
        ANGULAR_MOMENTUM.color,
    )


def _decoded_fields(marker):
    return (
        marker.header.frame_id,
        marker.ns,
        marker.id,
        marker.type,
        marker.action,
        [marker.pose.position.x, marker.pose.position.y, marker.pose.position.z],
        [
            marker.pose.orientation.x,
            marker.pose.orientation.y,
            marker.pose.orientation.z,
            marker.pose.orientation.w,
        ],
        [marker.scale.x, marker.scale.y, marker.scale.z],
        [[p.x, p.y, p.z] for p in marker.points],
        marker.lifetime.sec,
        marker.lifetime.nanosec,
        marker.frame_locked,
    )


def _rgba(marker):
    return [marker.color.r, marker.color.g, marker.color.b, marker.color.a]


def _rows(count=4):
    simulation = _simulation({'inertia': GENERIC_TENSOR}, [0.4, -1.0, 0.7], {'markers': {}})
    block = simulation.samples(0, count)
    return block.stamps_ns + 1_700_000_000_123_456_789, block.outputs[0]


@pytest.mark.parametrize('frame_id', ['world', 'w', 'a_much_longer_inertial_frame_name'])
def test_the_encoding_decodes_in_rclpy_and_is_byte_for_byte_rosbags_own(frame_id):
    from rclpy.serialization import deserialize_message
    from rosbags.typesys import get_typestore, Stores
    from visualization_msgs.msg import Marker, MarkerArray

    store = get_typestore(Stores.ROS2_JAZZY)
    stamps, rows = _rows()
    messages = encode_markers(stamps, frame_id, rows)
    assert len(messages) == len(rows)
    for stamp, row, message in zip(stamps, rows, messages):
        markers = deserialize_message(message, MarkerArray).markers
        assert [m.ns for m in markers] == NAMESPACES
        assert {m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in markers} == {stamp}
        box, arrows, labels = markers[0], markers[1:3], markers[3:]
        longest = row[4:7].max()
        assert _decoded_fields(box) == (
            frame_id,
            'body',
            0,
            Marker.CUBE,
            Marker.ADD,
            [0.0] * 3,
            row[0:4].tolist(),
            row[4:7].tolist(),
            [],
            0,
            0,
            False,
        )
        for arrow, tip, style in zip(
            arrows, (row[7:10], row[10:13]), (ANGULAR_VELOCITY, ANGULAR_MOMENTUM)
        ):
            shaft, head = style.size
            assert _decoded_fields(arrow) == (
                frame_id,
                arrow.ns,
                0,
                Marker.ARROW,
                Marker.ADD,
                [0.0] * 3,
                [0.0, 0.0, 0.0, 1.0],
                [shaft * longest, head * longest, 0.0],
                [[0.0] * 3, tip.tolist()],
                0,
                0,
                False,
            )
            assert (
                arrow.color.a == 1.0
                and not arrow.text
                and not arrow.mesh_resource
                and not arrow.colors
            )
            assert _rgba(arrow) == pytest.approx(style.color, abs=1e-7)  # float32
        for label, tip, style in zip(
            labels, (row[7:10], row[10:13]), (ANGULAR_VELOCITY_LABEL, ANGULAR_MOMENTUM_LABEL)
        ):
            place, orientation, scale = _decoded_fields(label)[5:8]
            assert _decoded_fields(label)[:5] == (
                frame_id,
                style.namespace,
                0,
                Marker.TEXT_VIEW_FACING,
                Marker.ADD,
            )
            assert _decoded_fields(label)[8:] == ([], 0, 0, False)
            # a tenth of the longest side past the tip, on the arrow's line; a tenth high
            np.testing.assert_allclose(
                place, tip * (1.0 + 0.1 * longest / np.linalg.norm(tip)), rtol=1e-15, atol=0
            )
            assert orientation == [0.0, 0.0, 0.0, 1.0] and scale == [0.0, 0.0, 0.1 * longest]
            assert label.text == style.text and not label.points and not label.colors
        # each label in its arrow's colour
        assert [(m.text, _rgba(m)) for m in labels] == [
            ('w', _rgba(arrows[0])),
            ('H', _rgba(arrows[1])),
        ]
        assert 0.0 < box.color.a < 1.0  # see-through: the arrows inside stay visible
        decoded = store.deserialize_cdr(message, 'visualization_msgs/msg/MarkerArray')
        assert store.serialize_cdr(decoded, 'visualization_msgs/msg/MarkerArray') == message


def test_a_bag_carries_markers_as_the_core_computes_them_in_both_independent_readers(tmp_path):
    from bag_checks import read_with_mcap, read_with_rosbags, stamp_ns
    from torquefree_ros import load_scene
    from torquefree_ros.cli.bag import main as bag_main

    bag = tmp_path / 'dzhanibekov'
    assert (
        bag_main(
            [
                'dzhanibekov',
                '--duration',
                '2',
                '--rate',
                '50',
                '--output',
                str(bag),
                '--inertial-frame',
                'odom',
            ]
        )
        == 0
    )
    scene = load_scene('dzhanibekov')
    block = Simulation(scene.propagator(), 50.0, outputs=scene.outputs).samples(0, 101)
    (rows,) = [
        rows for output, rows in zip(scene.outputs, block.outputs) if output.name == 'markers'
    ]
    messages, connections = read_with_rosbags(bag)
    assert connections['/markers'].msgtype == 'visualization_msgs/msg/MarkerArray'
    arrays = [m.markers for _, m in messages['/markers']]
    assert [stamp_ns(a[0].header) for a in arrays] == block.stamps_ns.tolist()
    assert {tuple(m.ns for m in a) for a in arrays} == {tuple(NAMESPACES)}
    assert {m.header.frame_id for a in arrays for m in a} == {'odom'}
    np.testing.assert_array_equal(
        [
            [
                a[0].pose.orientation.x,
                a[0].pose.orientation.y,
                a[0].pose.orientation.z,
                a[0].pose.orientation.w,
            ]
            for a in arrays
        ],
        rows[:, 0:4],
    )
    np.testing.assert_array_equal(
        [[a[1].points[1].x, a[1].points[1].y, a[1].points[1].z] for a in arrays], rows[:, 7:10]
    )
    decoded = read_with_mcap(bag)['/markers']  # mcap-ros2 decodes from the bag's own schema text
    assert [m.ns for m in decoded[50][2].markers] == NAMESPACES
    assert decoded[50][2].markers[2].points[1].z == rows[50, 12]


@pytest.mark.parametrize('seed', [3, 31])
def test_one_marker_array_at_a_random_sample_of_a_bag_is_the_whole_picture(tmp_path, seed):
    """
    One MarkerArray at a random sample of a bag is the whole picture.

    What a viewer does after a seek: show the latest MarkerArray alone. Read just that one message
    (the mcap reader, by log time) and find every marker, each where the core puts it.
    """
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from torquefree_ros import load_scene
    from torquefree_ros.cli.bag import main as bag_main

    bag = tmp_path / 'seek'
    assert bag_main(['dzhanibekov', '--duration', '3', '--rate', '20', '--output', str(bag)]) == 0
    k = int(np.random.default_rng(seed).integers(1, 61))
    scene = load_scene('dzhanibekov')
    block = Simulation(scene.propagator(), 20.0, outputs=scene.outputs).samples(k, 1)
    (row,) = [
        rows[0] for output, rows in zip(scene.outputs, block.outputs) if output.name == 'markers'
    ]
    stamp = int(block.stamps_ns[0])
    (path,) = bag.glob('*.mcap')
    with path.open('rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        (found,) = list(
            reader.iter_decoded_messages(topics=['/markers'], starting_at=stamp, ending_at=stamp)
        )
    markers = {m.ns: m for m in found.decoded_message.markers}
    assert sorted(markers) == sorted(NAMESPACES)
    assert all(
        m.header.stamp.sec * 10**9 + m.header.stamp.nanosec == stamp for m in markers.values()
    )
    body = markers['body']
    assert [
        body.pose.orientation.x,
        body.pose.orientation.y,
        body.pose.orientation.z,
        body.pose.orientation.w,
    ] == row[0:4].tolist()
    assert [body.scale.x, body.scale.y, body.scale.z] == row[4:7].tolist()
    for namespace, tip in (('angular_velocity', row[7:10]), ('angular_momentum', row[10:13])):
        end = markers[namespace].points[1]
        assert [end.x, end.y, end.z] == tip.tolist(), namespace
        label = markers[f'{namespace}_label'].pose.position
        # past the tip, on the arrow's line
        assert np.dot([label.x, label.y, label.z], tip) > np.dot(tip, tip), namespace


def test_the_node_publishes_markers_as_the_core_computes_them():
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sim_harness import connected_harness, reset_epoch_ns, stamp_ns
    from torquefree_ros import load_scene
    from visualization_msgs.msg import MarkerArray

    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=10000, reliability=ReliabilityPolicy.RELIABLE
    )
    with connected_harness(publish_rate=100.0) as harness:
        arrays = []
        harness.client.create_subscription(MarkerArray, 'markers', arrays.append, qos)
        assert harness.set_parameters(scene='dzhanibekov')[0].successful
        response = harness.reset()
        assert response.success, response.message
        epoch = reset_epoch_ns(response)
        harness.spin_until(
            lambda: sum(stamp_ns(a.markers[0].header.stamp) >= epoch for a in arrays) >= 150,
            what='150 marker arrays',
        )
    arrays = [a for a in arrays if stamp_ns(a.markers[0].header.stamp) >= epoch]
    k = (np.array([stamp_ns(a.markers[0].header.stamp) for a in arrays]) - epoch) * 100 // 10**9
    scene = load_scene('dzhanibekov')
    block = Simulation(scene.propagator(), 100.0, epoch, outputs=scene.outputs).samples(
        0, int(k.max()) + 1
    )
    (rows,) = [
        rows for output, rows in zip(scene.outputs, block.outputs) if output.name == 'markers'
    ]
    assert {tuple(m.ns for m in a.markers) for a in arrays} == {tuple(NAMESPACES)}
    np.testing.assert_array_equal(
        [
            [a.markers[2].points[1].x, a.markers[2].points[1].y, a.markers[2].points[1].z]
            for a in arrays
        ],
        rows[k, 10:13],
    )
    np.testing.assert_array_equal(
        [
            [
                a.markers[0].pose.orientation.x,
                a.markers[0].pose.orientation.y,
                a.markers[0].pose.orientation.z,
                a.markers[0].pose.orientation.w,
            ]
            for a in arrays
        ],
        rows[k, 0:4],
    )
    np.testing.assert_array_equal(
        [
            [a.markers[1].points[1].x, a.markers[1].points[1].y, a.markers[1].points[1].z]
            for a in arrays
        ],
        rows[k, 7:10],
    )


# -- reaction wheels: H is the whole momentum, an arrow per wheel ---------------------------------
WHEEL_BODY = {'inertia': [3.0, 2.5, 2.0]}
WHEELS = {
    'reaction_wheels': {
        'schedule': [
            {'start': 0.0, 'torque': [0.05, -0.03]},
            {'start': 1.0, 'torque': [-0.02, 0.04]},
        ],
        'wheels': [
            {'name': 'a', 'axis': [1.0, 0.0, 1.0], 'spin_inertia': 0.05, 'max_torque': 0.1,
             'max_speed': 500.0, 'speed': 20.0, 'viscous': 1e-3},
            {'name': 'b', 'axis': [0.0, 1.0, 0.0], 'spin_inertia': 0.04, 'max_torque': 0.1,
             'max_speed': 500.0, 'speed': -10.0},
        ],
    }
}


def test_with_wheels_h_is_the_whole_momentum_and_each_wheel_has_its_arrow():
    """
    The amber H arrow is ``R(q) (I w + sum Js Omega g)``; wheel i's arrow ``R(q) Js Omega_i g_i``.

    Both at the H arrow's scale (default: the initial whole |H| is 1.25 m long), computed here
    from the scene's locked inertia and the wheels' relative speeds (the effect's momenta less
    ``Js g . w``): the arrows' formula is ``I_s w + sum h g``, the same momentum written another
    way, so rounding (1e-13 m on arrows of a metre) separates them. The motors trade momentum with
    the body, so the body's own ``R(q) I w`` moves by tenths of a metre while the whole H stands
    still to the integrator's tolerance (1e-9 m).
    """
    simulation = _simulation(WHEEL_BODY, [0.3, -0.2, 0.4], WHEELS, {'markers': {}})
    block = simulation.samples(0, 150)
    (rows,) = block.outputs
    assert rows.shape == (150, MARKER_ROW + 6)
    effect = simulation.propagator.dynamics.effects[0]
    speeds = effect.wheel_speeds(block.omega_B, block.internal)
    axes = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    Js = np.array([0.05, 0.04])
    whole_B = block.omega_B @ np.diag([3.0, 2.5, 2.0]) + (Js * speeds) @ axes
    whole_N = quaternion.rotate(block.q_NB, whole_B)
    scale = 1.25 / np.linalg.norm(whole_N[0])
    np.testing.assert_allclose(rows[:, 10:13], scale * whole_N, rtol=0, atol=1e-13)
    np.testing.assert_allclose(
        rows[:, 10:13], np.broadcast_to(rows[0, 10:13], (150, 3)), rtol=0, atol=1e-9
    )
    body_N = quaternion.rotate(block.q_NB, block.omega_B @ np.diag([3.0, 2.5, 2.0]))
    assert np.ptp(scale * body_N, axis=0).max() > 0.1
    for i in range(2):
        tip = scale * (Js[i] * speeds[:, i])[:, None] * quaternion.rotate(block.q_NB, axes[i])
        np.testing.assert_allclose(rows[:, MARKER_ROW + 3 * i: MARKER_ROW + 3 * i + 3], tip,
                                   rtol=0, atol=1e-13)
    # the rows do not depend on how the samples are cut into blocks
    for size in (7, 1):  # one sample at a time is a closed loop's blocks (floats, not arrays)
        again = _simulation(WHEEL_BODY, [0.3, -0.2, 0.4], WHEELS, {'markers': {}})
        cut = np.vstack([again.samples(k, size).outputs[0] for k in range(0, 150, size)])[:150]
        np.testing.assert_array_equal(cut, rows)


def test_wheel_arrows_decode_in_rclpy_after_the_five_markers():
    """Each wheel's ARROW: namespace wheel_NAME, id 0, from the centre to its tip, teal."""
    from rclpy.serialization import deserialize_message
    from torquefree_ros.bag.layouts import LAYOUTS
    from visualization_msgs.msg import Marker, MarkerArray

    simulation = _simulation(WHEEL_BODY, [0.3, -0.2, 0.4], WHEELS, {'markers': {}})
    block = simulation.samples(0, 5)
    (output,) = simulation.outputs
    (rows,) = block.outputs
    assert output.layout == 'wheel_markers' and output.layout_options == {'names': ('a', 'b')}
    stamps = block.stamps_ns + 1_700_000_000_000_000_000
    for place in (None, np.array([1.0, -2.0, 0.5])):
        messages = LAYOUTS[output.layout](stamps, 'world', 'body', rows, place,
                                          **output.layout_options)
        plain = encode_markers(stamps, 'world', rows[:, :MARKER_ROW], place)
        offset = np.zeros(3) if place is None else place
        for stamp, row, message, five in zip(stamps, rows, messages, plain):
            markers = deserialize_message(message, MarkerArray).markers
            assert [m.ns for m in markers] == NAMESPACES + ['wheel_a', 'wheel_b']
            first = deserialize_message(five, MarkerArray).markers
            assert [_decoded_fields(m) for m in markers[:5]] == [_decoded_fields(m) for m in first]
            longest = row[4:7].max()
            for i, marker in enumerate(markers[5:]):
                assert marker.header.stamp.sec * 10**9 + marker.header.stamp.nanosec == stamp
                assert (marker.id, marker.type, marker.action) == (0, Marker.ARROW, Marker.ADD)
                tip = row[MARKER_ROW + 3 * i: MARKER_ROW + 3 * i + 3] + offset
                assert [[p.x, p.y, p.z] for p in marker.points] == [offset.tolist(), tip.tolist()]
                assert [marker.scale.x, marker.scale.y, marker.scale.z] == pytest.approx(
                    [0.03 * longest, 0.07 * longest, 0.0], rel=1e-15
                )
                # float32 colour: teal, the same bits as the constants rounded
                assert _rgba(marker) == np.float32([0.0, 0.72, 0.72, 1.0]).tolist()
