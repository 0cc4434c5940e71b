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
The ``position`` parameter (``torquefree_bag --position``): bodies side by side in one view.

/tf's translation, pose's and odometry's position and the markers' place (the box, both arrows'
start and end) move by it; nothing else in any message changes; the origin gives the bytes of no
position.
"""

from __future__ import annotations

import math

from bag_checks import read_with_rosbags
import numpy as np
import pytest
from torquefree_ros.bag.samples import encode_block
from torquefree_ros.cli.bag import main as bag_main
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping

POSITION = (2.5, -1.0, 0.75)
SCENE = {
    'body': {'inertia': [4.0, 3.0, 2.5, 0.3, -0.2, 0.4]},
    'initial': {'angular_velocity': [0.4, -1.0, 0.7]},
    'effects': [{'tf': {}}, {'pose': {}}, {'odometry': {}}, {'markers': {}}],
}


def _block(count=40):
    scene = scene_from_mapping(SCENE)
    simulation = Simulation(scene.propagator(), 20.0, outputs=scene.outputs)
    return simulation, simulation.samples(0, count)


def test_an_output_at_a_rate_of_its_own_before_pose_leaves_it_at_the_origin():
    # regression: the own-rate output's sample indices once leaked into the position of the next
    # output
    scene = scene_from_mapping(
        {**SCENE, 'effects': [{'star_tracker': {'rate': 5.0}}, {'pose': {}}]}
    )
    simulation = Simulation(scene.propagator(), 20.0, outputs=scene.outputs)
    block = simulation.samples(0, 12)
    pose = encode_block(block, 'body', 'world', simulation.outputs)[-1]
    assert pose.topic == 'pose'
    for message in pose.messages:
        # position: after the header (stamp, "world"), zero
        assert message[4 + 24: 4 + 24 + 24] == bytes(24)


@pytest.mark.parametrize('count', [1, 40])  # one sample (a closed loop's) is packed differently
def test_the_origin_is_no_position_byte_for_byte(count):
    simulation, block = _block(count)

    def encoded(**position):
        return [
            (column.topic, list(column.messages))
            for column in encode_block(block, 'body', 'world', simulation.outputs, **position)
        ]

    assert encoded(position=(0.0, 0.0, 0.0)) == encoded()
    assert encoded(position=(0.0, 1.0, 0.0)) != encoded()


def test_a_bag_places_every_output_at_the_position_and_changes_nothing_else(tmp_path):
    common = ['--duration', '2', '--rate', '20', '--start-time', '100']
    scene = tmp_path / 'scene.yaml'
    scene.write_text(repr(SCENE).replace("'", '"'))  # JSON is YAML
    assert bag_main([str(scene), *common, '--output', str(tmp_path / 'origin')]) == 0
    assert (
        bag_main(
            [
                str(scene),
                *common,
                '--position',
                *map(str, POSITION),
                '--output',
                str(tmp_path / 'placed'),
            ]
        )
        == 0
    )
    origin, _ = read_with_rosbags(tmp_path / 'origin')
    placed, _ = read_with_rosbags(tmp_path / 'placed')
    assert origin.keys() == placed.keys() and len(placed['/tf']) == 41

    def xyz(point):
        return [point.x, point.y, point.z]

    def xyzw(q):
        return [q.x, q.y, q.z, q.w]

    for (_, a), (_, b) in zip(origin['/tf'], placed['/tf']):
        assert xyz(a.transforms[0].transform.translation) == [0.0] * 3
        assert xyz(b.transforms[0].transform.translation) == list(POSITION)
        assert xyzw(a.transforms[0].transform.rotation) == xyzw(b.transforms[0].transform.rotation)
    for (_, a), (_, b) in zip(origin['/pose'], placed['/pose']):
        assert xyz(b.pose.position) == list(POSITION) and xyzw(a.pose.orientation) == xyzw(
            b.pose.orientation
        )
    for (_, a), (_, b) in zip(origin['/odometry'], placed['/odometry']):
        assert xyz(b.pose.pose.position) == list(POSITION)
        assert xyzw(a.pose.pose.orientation) == xyzw(b.pose.pose.orientation)
        assert (
            xyz(a.twist.twist.angular) == xyz(b.twist.twist.angular)
            and xyz(b.twist.twist.linear) == [0.0] * 3
        )
    for (_, a), (_, b) in zip(origin['/markers'], placed['/markers']):
        box, arrows, labels = b.markers[0], b.markers[1:3], b.markers[3:]
        assert xyz(box.pose.position) == list(POSITION)
        assert xyzw(box.pose.orientation) == xyzw(a.markers[0].pose.orientation)
        for before, after in zip(a.markers[1:3], arrows):
            assert xyz(after.points[0]) == list(POSITION)
            # the tip moves by the position: the same arrow, drawn from the body's centre
            assert xyz(after.points[1]) == [t + p for t, p in zip(xyz(before.points[1]), POSITION)]
        assert [m.ns for m in labels] == ['angular_velocity_label', 'angular_momentum_label']
        for before, after in zip(a.markers[3:], labels):
            # and so does each arrow's label
            assert xyz(after.pose.position) == [
                t + p for t, p in zip(xyz(before.pose.position), POSITION)
            ]
    assert [xyz(m.vector) for _, m in origin['/angular_velocity']] == [
        xyz(m.vector) for _, m in placed['/angular_velocity']
    ]
    assert [xyzw(m.quaternion) for _, m in origin['/attitude']] == [
        xyzw(m.quaternion) for _, m in placed['/attitude']
    ]


@pytest.mark.parametrize(
    'value, reason', [(['1', '2'], 'expected 3 argument'), (['1', 'nan', '2'], 'must be finite')]
)
def test_a_bad_position_is_named(tmp_path, capsys, value, reason):
    with pytest.raises(SystemExit):
        bag_main(
            [
                'dzhanibekov',
                '--duration',
                '1',
                '--rate',
                '10',
                '--position',
                *value,
                '--output',
                str(tmp_path / 'bag'),
            ]
        )
    error = capsys.readouterr().err
    assert '--position' in error and reason in error
    assert not (tmp_path / 'bag').exists()


def test_nodes_side_by_side_place_their_bodies_where_their_parameter_says():
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from test_formation import BODIES, formation, spin_until
    from visualization_msgs.msg import MarkerArray

    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE
    )
    places = {body: [3.0 * i, 0.0, 0.0] for i, body in enumerate(BODIES)}
    with formation(scene='dzhanibekov', publish_rate=50.0, positions=places) as (
        client,
        executor,
        nodes,
    ):
        seen = {}
        for body in BODIES:
            client.create_subscription(
                MarkerArray,
                f'/{body}/markers',
                lambda m, body=body: seen.__setitem__(body, m),
                qos,
            )
        spin_until(executor, lambda: len(seen) == len(BODIES), 'the markers of every body')
        for body in BODIES:
            box = seen[body].markers[0]
            assert [box.pose.position.x, box.pose.position.y, box.pose.position.z] == places[body]
        # a bad position is refused with its name, and the running body stays where it was
        from rclpy.parameter import Parameter

        (result,) = nodes[0].set_parameters([Parameter('position', value=[1.0, math.inf, 0.0])])
        assert (
            not result.successful
            and result.reason.startswith('position:')
            and 'finite' in result.reason
        )
        assert nodes[0].sample_loop.request.body_position == tuple(places[BODIES[0]])
    assert np.isfinite(POSITION).all()
