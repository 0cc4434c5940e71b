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
The ``tf`` output on an orbit: the Earth-fixed and orbit (LVLH) frames beside the body (issue 41).

The LVLH axes against numpy's cross products of the orbit's ``r`` and ``v``; the Earth-fixed
rotation against ``environment.earth`` and the Earth's rotation rate; the translations that keep
the body at the inertial frame's origin; the TFMessage of several transforms byte for byte as
rosbags writes it, and in a bag read by rosbags and mcap. Without an orbit, ``tf`` is unchanged.
"""

from __future__ import annotations

import numpy as np
import pytest
from torquefree_ros.bag.cdr import encode_transform_lists, encode_transforms
from torquefree_ros.bag.layouts import LAYOUTS
from torquefree_ros.bag.samples import encode_block
from torquefree_ros.core.checks.schema import FieldError
from torquefree_ros.core.environment import earth
from torquefree_ros.core.frames import quaternion
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping, SceneError

#: a 500 km orbit, inclined, slightly eccentric
LEO = {
    'epoch': '2026-03-20T12:00:00Z',
    'semi_major_axis': 6878137.0,
    'eccentricity': 0.001,
    'inclination': 1.7,
    'raan': 0.3,
    'argument_of_perigee': 0.5,
    'mean_anomaly': 0.2,
}
BODY = {'inertia': [3.0, 2.0, 1.0]}
INITIAL = {'angular_velocity': [0.001, 1.0, 0.001]}
#: the Earth's rotation rate relative to the stars, rad/s (IERS Conventions 2010, table 1.1)
EARTH_RATE = 7.292115e-5
# rounding of a rotation matrix through a quaternion and back: a few ulps of 1
ROUND_TRIP = 1e-15 * 8


def tf_scene_mapping(tf=None, orbit=LEO):
    """Return the tests' scene: BODY, INITIAL, the ``tf`` output and ``orbit`` (None: none)."""
    data = {'body': BODY, 'initial': INITIAL, 'effects': [{'tf': tf or {}}]}
    if orbit is not None:
        data['orbit'] = orbit
    return data


def orbit_frame_pairs(prefix):
    """Return the (parent, child) frames of the default ``tf`` on an orbit, children prefixed."""
    return [('world', f'{prefix}{child}') for child in ('body', 'earth_fixed', 'lvlh')]


def _scene(tf=None, orbit=LEO):
    return scene_from_mapping(tf_scene_mapping(tf, orbit), source='s.yaml')


def _run(scene, count=601, rate=1.0):
    simulation = Simulation(scene.propagator(), rate, outputs=scene.outputs)
    return simulation, simulation.samples(0, count)


def _translations_and_matrices(rows, index):
    part = rows[:, 7 * index: 7 * index + 7]
    return part[:, 0:3], quaternion.to_matrix(part[:, 3:7])


def test_lvlh_axes_are_the_cross_products_of_r_and_v_orthonormal_and_right_handed():
    scene = _scene()
    _, block = _run(scene)  # 10 minutes: a tenth of the orbit, at 1 Hz
    r, v = scene.outputs[0].place.state(block.times)
    translation, axes = _translations_and_matrices(block.outputs[0], 2)
    # independent: the field's definition written out with numpy's cross product
    z = -r / np.linalg.norm(r, axis=1, keepdims=True)
    h = np.cross(r, v)
    y = -h / np.linalg.norm(h, axis=1, keepdims=True)
    x = np.cross(y, z)
    for column, expected in enumerate((x, y, z)):
        np.testing.assert_allclose(axes[:, :, column], expected, rtol=0, atol=ROUND_TRIP)
    identity = np.broadcast_to(np.eye(3), axes.shape)
    np.testing.assert_allclose(
        np.swapaxes(axes, 1, 2) @ axes, identity, rtol=0, atol=ROUND_TRIP
    )  # orthonormal to rounding
    np.testing.assert_allclose(np.linalg.det(axes), 1.0, rtol=0, atol=ROUND_TRIP)  # right-handed
    # z to nadir: -r, to rounding
    cosines = np.einsum('ij,ij->i', axes[:, :, 2], -r) / np.linalg.norm(r, axis=1)
    np.testing.assert_allclose(cosines, 1.0, rtol=0, atol=ROUND_TRIP)
    # x along the velocity up to the flight path angle, at most atan(e / sqrt(1 - e^2)) ~ e
    along = np.einsum('ij,ij->i', axes[:, :, 0], v) / np.linalg.norm(v, axis=1)
    assert along.min() >= np.cos(1.001 * LEO['eccentricity'])
    assert not np.any(translation)  # at the body's centre: the inertial frame's origin


def test_the_earth_fixed_frame_is_earths_rotation_at_minus_r():
    scene = _scene()
    _, block = _run(scene)
    place = scene.outputs[0].place
    r, _ = place.state(block.times)
    translation, R_NE = _translations_and_matrices(block.outputs[0], 1)
    W = earth.earth_fixed_matrix(place.instants(block.times))
    np.testing.assert_allclose(R_NE, np.swapaxes(W, 1, 2), rtol=0, atol=ROUND_TRIP)
    np.testing.assert_array_equal(translation, -r)  # the Earth's centre seen from the body
    # independent of earth.py: the frame turns about its z axis at the Earth's rate; over 600 s
    # precession and nutation move the pole by under 1e-9 rad, the rate's 7 digits ~ 1e-13 rad/s
    turn = np.swapaxes(R_NE[0], 0, 1) @ R_NE[-1]  # [E0 E1]
    assert abs(turn[2, 2] - 1.0) < 1e-12
    angle = np.arctan2(turn[1, 0], turn[0, 0])
    assert angle == pytest.approx(EARTH_RATE * 600.0, abs=1e-8)
    # its pole is the J2000 pole moved by 26 years of precession (50"/yr at most) and nutation
    assert np.arccos(R_NE[0, 2, 2]) < np.radians((26 * 50 + 20) / 3600.0)


def test_the_body_keeps_its_transform_bit_for_bit():
    scene = _scene()
    _, block = _run(scene, count=51, rate=50.0)
    rows = block.outputs[0]
    np.testing.assert_array_equal(rows[:, 3:7], block.q_NB)
    assert not np.any(rows[:, 0:3])
    without = _scene(orbit=None)
    _, plain = _run(without, count=51, rate=50.0)
    np.testing.assert_array_equal(rows[:, 0:7], plain.outputs[0])  # the same attitude, rows


def test_the_rows_do_not_depend_on_how_samples_are_cut_into_blocks():
    scene = _scene()
    simulation = Simulation(scene.propagator(), 10.0, outputs=scene.outputs)
    whole = simulation.samples(0, 40).outputs[0]
    one_at_a_time = [simulation.samples(k, 1).outputs[0] for k in range(40)]
    np.testing.assert_array_equal(np.concatenate(one_at_a_time), whole)  # bit for bit


def test_a_scene_without_orbit_encodes_tf_as_before():
    scene = _scene(orbit=None)
    simulation, block = _run(scene, count=11, rate=10.0)
    assert simulation.outputs[0].layout == 'transform'
    assert simulation.outputs[0].layout_options == {}
    columns = encode_block(block, 'body', 'world', simulation.outputs)
    (tf,) = [column for column in columns if column.topic == '/tf']
    rows = np.c_[np.zeros((11, 3)), block.q_NB]
    expected = encode_transforms(block.stamps_ns, 'world', 'body', rows)
    assert list(tf.messages) == list(expected)


def test_one_frame_pair_is_the_single_transform_encoding_byte_for_byte():
    rows = np.array([[1.0, -2.0, 3.0, 0.1, -0.2, 0.3, 0.9], [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]])
    stamps = np.array([0, 1_700_000_000_123_456_789])
    for parent, child in (('world', 'body'), ('w', 'a_much_longer_body_frame'), ('map/odom', 'b')):
        assert list(encode_transform_lists(stamps, [(parent, child)], rows)) == list(
            encode_transforms(stamps, parent, child, rows)
        )


def test_several_transforms_are_rosbags_own_encoding_byte_for_byte():
    from rosbags.typesys import get_typestore, Stores

    store = get_typestore(Stores.ROS2_JAZZY)
    rng = np.random.default_rng(41)
    stamps = np.array([0, 5, 1_700_000_000_123_456_789])
    # frame ids of every length modulo 8: each transform's alignment differs
    for lengths in ((1, 2, 3), (4, 5, 6), (7, 8, 9), (5, 12, 1)):
        pairs = [('w' * (n + 1), 'c' * n) for n in lengths]
        rows = rng.normal(size=(3, 7 * len(pairs)))
        for stamp, row, message in zip(stamps, rows, encode_transform_lists(stamps, pairs, rows)):
            decoded = store.deserialize_cdr(message, 'tf2_msgs/msg/TFMessage')
            assert [(t.header.frame_id, t.child_frame_id) for t in decoded.transforms] == pairs
            for index, t in enumerate(decoded.transforms):
                assert t.header.stamp.sec * 10**9 + t.header.stamp.nanosec == stamp
                a, b = t.transform.translation, t.transform.rotation
                expected = row[7 * index: 7 * index + 7].tolist()
                assert [a.x, a.y, a.z, b.x, b.y, b.z, b.w] == expected
            assert store.serialize_cdr(decoded, 'tf2_msgs/msg/TFMessage') == message


def test_rows_that_do_not_match_the_frame_pairs_are_refused():
    with pytest.raises(ValueError, match='7 float64s per transform'):
        encode_transform_lists(np.array([0]), [('a', 'b'), ('a', 'c')], np.zeros((1, 7)))


def test_frames_are_named_in_the_body_frames_namespace_and_moved_with_the_body():
    from rosbags.typesys import get_typestore, Stores

    store = get_typestore(Stores.ROS2_JAZZY)
    scene = _scene({'earth_frame': 'earth', 'lvlh_frame': 'orbit'})
    simulation, block = _run(scene, count=3)
    rows = block.outputs[0]
    position = np.array([10.0, -20.0, 30.0])
    for body_frame, earth_frame, lvlh_frame in (
        ('body', 'earth', 'orbit'),
        ('sat1/body', 'sat1/earth', 'sat1/orbit'),
        ('fleet/sat1/base', 'fleet/sat1/earth', 'fleet/sat1/orbit'),
    ):
        columns = encode_block(block, body_frame, 'world', simulation.outputs, position=position)
        (tf,) = [column for column in columns if column.topic == '/tf']
        for row, message in zip(rows, tf.messages):
            transforms = store.deserialize_cdr(message, 'tf2_msgs/msg/TFMessage').transforms
            assert [(t.header.frame_id, t.child_frame_id) for t in transforms] == [
                ('world', body_frame),
                ('world', earth_frame),
                ('world', lvlh_frame),
            ]
            translations = [
                [t.transform.translation.x, t.transform.translation.y, t.transform.translation.z]
                for t in transforms
            ]
            np.testing.assert_array_equal(
                translations, [position, row[7:10] + position, position]
            )


def test_frame_names_that_collide_are_refused_when_encoding():
    with pytest.raises(ValueError, match='must all differ'):
        LAYOUTS['orbit_transforms'](
            np.array([0]), 'world', 'body', np.zeros((1, 21)), None, earth_frame='world'
        )


@pytest.mark.parametrize(
    'tf, orbit, path, reason',
    [
        ({'earth_frame': 'a/b'}, LEO, 'effects[0].tf.earth_frame', "no '/'"),
        ({'lvlh_frame': ''}, LEO, 'effects[0].tf.lvlh_frame', 'frame name'),
        ({'lvlh_frame': 3}, LEO, 'effects[0].tf.lvlh_frame', 'frame name'),
        ({'lvlh_frame': 'lvlh\n'}, LEO, 'effects[0].tf.lvlh_frame', 'frame name'),
        ({'earth_frame': 'earth'}, None, 'effects[0].tf.earth_frame', "'orbit:'"),
        ({'lvlh_frame': 'orbit'}, None, 'effects[0].tf.lvlh_frame', "'orbit:'"),
    ],
)
def test_bad_frame_names_are_refused_with_their_field_path(tf, orbit, path, reason):
    with pytest.raises((SceneError, FieldError)) as error:
        _scene(tf, orbit)
    assert path in str(error.value) and reason in str(error.value)


def test_a_bag_carries_the_three_frames_in_both_independent_readers(tmp_path):
    import yaml
    from bag_checks import read_with_mcap, read_with_rosbags, transform_table
    from torquefree_ros.cli.bag import main as bag_main

    scene_file = tmp_path / 'orbit_tf.yaml'
    scene_file.write_text(yaml.safe_dump(tf_scene_mapping()))
    bag = tmp_path / 'bag'
    arguments = [str(scene_file), '--duration', '2', '--rate', '10', '--output', str(bag)]
    assert bag_main(arguments + ['--body-frame', 'sat1/body']) == 0
    scene = _scene()
    _, block = _run(scene, count=21, rate=10.0)
    messages, connections = read_with_rosbags(bag)
    assert connections['/tf'].msgtype == 'tf2_msgs/msg/TFMessage'
    decoded = read_with_mcap(bag)  # mcap-ros2 decodes from the bag's own schema text
    for by_rosbags, (_, _, by_mcap), row, stamp in zip(
        messages['/tf'], decoded['/tf'], block.outputs[0], block.stamps_ns
    ):
        for message in (by_rosbags[1], by_mcap):
            pairs, stamps, values = transform_table(message)
            assert pairs == orbit_frame_pairs('sat1/')
            assert set(stamps) == {stamp}
            np.testing.assert_array_equal(values.ravel(), row)
    assert len(messages['/tf']) == len(decoded['/tf']) == 21
