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
The pose and star_tracker outputs, and output rates.

Pose is the attitude bit for bit; the star tracker's noise has the statistics its parameters state,
is seeded and independent of block cuts; an output with a rate of its own goes out on every n-th
sample, with the same stamps; all go into bags (read by both independent readers) and out of the
node exactly as the core computes them.
"""

from __future__ import annotations

import numpy as np
import pytest
from torquefree_ros import load_scene
from torquefree_ros.core.effects.outputs import ARCSEC
from torquefree_ros.core.frames import quaternion
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping, SceneError

RATE = 50.0


def _scene(*effects):
    return scene_from_mapping(
        {
            'body': {'inertia': [3.0, 2.0, 1.0]},
            'initial': {'angular_velocity': [0.3, 0.2, 1.0]},
            'effects': list(effects),
        }
    )


def _outputs(scene, first, count):
    return Simulation(scene.propagator(), RATE, outputs=scene.outputs).samples(first, count)


def _rotation_vectors(q_from, q_to):
    """``n`` with ``q_to = q_from ⊗ exp(n / 2)`` (the body-frame error rotation)."""
    d = quaternion.multiply(quaternion.conjugate(q_from), q_to)
    d *= np.sign(d[:, 3:4])
    sine = np.linalg.norm(d[:, :3], axis=1, keepdims=True)
    angle = 2.0 * np.arctan2(sine, d[:, 3:4])
    return d[:, :3] * np.where(sine > 0, angle / np.where(sine > 0, sine, 1.0), 2.0)


def test_pose_is_the_attitude_bit_for_bit_at_zero_position():
    block = _outputs(_scene({'pose': {}}), 0, 500)
    (rows,) = block.outputs
    np.testing.assert_array_equal(rows[:, :3], 0.0)
    np.testing.assert_array_equal(rows[:, 3:], block.q_NB)


BORESIGHT = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)


def test_star_tracker_noise_has_the_stated_statistics_across_and_about_the_boresight():
    cross, about, count = 5.0, 40.0, 40_000
    scene = _scene(
        {
            'star_tracker': {
                'cross_boresight_noise': cross,
                'about_boresight_noise': about,
                'boresight': [2.0, 2.0, 0.0],
                'seed': 11,
            }
        }
    )
    block = _outputs(scene, 0, count)
    (rows,) = block.outputs
    n = _rotation_vectors(block.q_NB, rows[:, 0:4])
    along = n @ BORESIGHT
    across = n - np.outer(along, BORESIGHT)
    # sample statistics of 40 000 normal draws: the mean within 5 sigma / sqrt(N), a variance
    # within 5 sqrt(2 / N) = 3.5 % of its value
    sigma_cross, sigma_about = cross * ARCSEC, about * ARCSEC
    assert abs(along.mean()) < 5 * sigma_about / np.sqrt(count)
    assert np.all(np.abs(across.mean(axis=0)) < 5 * sigma_cross / np.sqrt(count))
    assert along.var() == pytest.approx(sigma_about**2, rel=0.035)
    assert (across**2).sum(axis=1).mean() / 2 == pytest.approx(sigma_cross**2, rel=0.035)
    # the covariance published is E[n n^T] in body axes, and the sample covariance agrees with it
    expected = sigma_cross**2 * (
        np.eye(3) - np.outer(BORESIGHT, BORESIGHT)
    ) + sigma_about**2 * np.outer(BORESIGHT, BORESIGHT)
    np.testing.assert_allclose(rows[0, 4:13].reshape(3, 3), expected, rtol=1e-12, atol=1e-30)
    np.testing.assert_allclose(np.cov(n.T), expected, atol=0.035 * sigma_about**2)
    # REP 145: the quantities not measured say so
    np.testing.assert_array_equal(rows[:, 16], -1.0)
    np.testing.assert_array_equal(rows[:, 28], -1.0)
    np.testing.assert_array_equal(rows[:, 13:16], 0.0)
    np.testing.assert_allclose(np.linalg.norm(rows[:, 0:4], axis=1), 1.0, atol=4e-16)


def test_star_tracker_samples_are_seeded_and_do_not_depend_on_how_blocks_are_cut():
    effect = {
        'star_tracker': {'cross_boresight_noise': 3.0, 'about_boresight_noise': 20.0, 'seed': 5}
    }
    whole = _outputs(_scene(effect), 0, 300).outputs[0]
    simulation = Simulation(_scene(effect).propagator(), RATE, outputs=_scene(effect).outputs)
    cuts = [0, 1, 7, 64, 65, 200, 300]
    pieces = np.vstack([simulation.samples(a, b - a).outputs[0] for a, b in zip(cuts, cuts[1:])])
    np.testing.assert_array_equal(pieces, whole)
    # a skip back
    np.testing.assert_array_equal(simulation.samples(100, 50).outputs[0], whole[100:150])
    # the same seed
    np.testing.assert_array_equal(_outputs(_scene(effect), 0, 300).outputs[0], whole)
    other = {'star_tracker': {**effect['star_tracker'], 'seed': 6}}
    assert not np.array_equal(_outputs(_scene(other), 0, 300).outputs[0][:, 0:4], whole[:, 0:4])


def test_a_noiseless_star_tracker_measures_the_attitude_exactly():
    block = _outputs(_scene({'star_tracker': {}}), 0, 100)
    np.testing.assert_array_equal(block.outputs[0][:, 0:4], block.q_NB)


def test_an_output_at_its_own_rate_is_the_same_output_sampled_at_that_rate():
    tracker = {'cross_boresight_noise': 3.0, 'about_boresight_noise': 20.0, 'seed': 5}
    imu = {'gyro_noise_density': 1e-3, 'gyro_bias_random_walk': 1e-4, 'seed': 3}
    fast = _scene(
        {'star_tracker': {**tracker, 'rate': 10.0}}, {'imu': {**imu, 'rate': 25.0}}, {'pose': {}}
    )
    simulation = Simulation(fast.propagator(), RATE, outputs=fast.outputs)
    block = simulation.samples(0, 501)
    tracker_rows, imu_rows, pose_rows = block.outputs
    np.testing.assert_array_equal(block.output_positions[0], np.arange(0, 501, 5))
    np.testing.assert_array_equal(block.output_positions[1], np.arange(0, 501, 2))
    assert block.output_positions[2] is None and pose_rows.shape == (501, 7)
    # what a run at the output's own rate gives, bit for bit (k / 50 and j / 10 round to the same
    # time)
    for effect, rate, rows in (
        ({'star_tracker': tracker}, 10.0, tracker_rows),
        ({'imu': imu}, 25.0, imu_rows),
    ):
        alone = _scene(effect)
        np.testing.assert_array_equal(
            Simulation(alone.propagator(), rate, outputs=alone.outputs)
            .samples(0, rows.shape[0])
            .outputs[0],
            rows,
        )
    # block cuts that do not fall on the output's samples change nothing
    cuts = [0, 3, 4, 11, 12, 200, 501]
    pieces = [simulation.samples(a, b - a) for a, b in zip(cuts, cuts[1:])]
    np.testing.assert_array_equal(np.vstack([piece.outputs[0] for piece in pieces]), tracker_rows)
    np.testing.assert_array_equal(
        np.concatenate([piece.output_positions[0] + piece.first for piece in pieces]),
        np.arange(0, 501, 5),
    )
    # the states first and the outputs after (a closed loop's one sample at a time): the same
    again = Simulation(fast.propagator(), RATE, outputs=fast.outputs)
    for k in range(12):
        states = again.samples(k, 1, outputs=False)
        assert states.outputs == ()
        single = again.with_outputs(states)
        for rows, positions, j in zip(single.outputs, single.output_positions, range(3)):
            if positions is None:
                np.testing.assert_array_equal(rows, block.outputs[j][k: k + 1])
            else:
                every = (5, 2)[j]
                assert positions.tolist() == ([0] if k % every == 0 else [])
                expected = block.outputs[j][k // every:][: len(positions)]
                np.testing.assert_array_equal(rows, expected)


@pytest.mark.parametrize(
    'rate, reason',
    [
        (
            30.0,
            r'star_tracker\.rate: 30 Hz must divide publish_rate 50 Hz into a whole number '
            r'of samples, got 1\.66667',
        ),
        (
            100.0,
            r'star_tracker\.rate: 100 Hz must divide publish_rate 50 Hz into a whole number '
            r'of samples, got 0\.5',
        ),
    ],
)
def test_a_rate_that_does_not_divide_the_sample_rate_is_refused(rate, reason):
    scene = _scene({'star_tracker': {'rate': rate}})
    with pytest.raises(ValueError, match=reason):
        Simulation(scene.propagator(), RATE, rate_name='publish_rate', outputs=scene.outputs)


def test_torquefree_bag_refuses_an_output_rate_that_does_not_divide_its_rate(tmp_path, capsys):
    from torquefree_ros.cli.bag import main as bag_main

    with pytest.raises(SystemExit) as exit_:
        bag_main(
            ['estimator', '--duration', '1', '--rate', '25', '--output', str(tmp_path / 'bag')]
        )
    assert exit_.value.code == 2 and not (tmp_path / 'bag').exists()
    assert 'star_tracker.rate: 10 Hz must divide rate 25 Hz' in capsys.readouterr().err


@pytest.mark.parametrize(
    'parameters, reason',
    [
        (
            {'boresight': [0, 0, 0]},
            r'effects\[0\]\.star_tracker\.boresight: must not be the zero vector',
        ),
        ({'cross_boresight_noise': -1.0}, r'cross_boresight_noise: must be >= 0 arcsec'),
        (
            {'about_boresight_noise': float('nan')},
            r'about_boresight_noise: expected a finite number arcsec',
        ),
        ({'boresight': [1, 0]}, r'boresight: expected 3 numbers, got 2'),
    ],
)
def test_star_tracker_parameters_are_checked_with_the_field_path(parameters, reason):
    with pytest.raises(SceneError, match=reason):
        _scene({'star_tracker': parameters})


def test_the_estimator_scene_bag_carries_pose_and_star_tracker_as_the_core_computes_them(tmp_path):
    from bag_checks import metadata, read_with_mcap, read_with_rosbags, stamp_ns
    from torquefree_ros.cli.bag import main as bag_main

    bag = tmp_path / 'estimator'
    assert bag_main(['estimator', '--duration', '2', '--rate', '50', '--output', str(bag)]) == 0
    messages, connections = read_with_rosbags(bag)
    assert {t: c.msgtype for t, c in connections.items()} == {
        '/angular_velocity': 'geometry_msgs/msg/Vector3Stamped',
        '/attitude': 'geometry_msgs/msg/QuaternionStamped',
        '/imu': 'sensor_msgs/msg/Imu',
        '/star_tracker': 'sensor_msgs/msg/Imu',
        '/pose': 'geometry_msgs/msg/PoseStamped',
    }
    scene = load_scene('estimator')
    block = Simulation(scene.propagator(), 50.0, outputs=scene.outputs).samples(0, 101)
    _, tracker_rows, pose_rows = block.outputs
    tracker = [m for _, m in messages['/star_tracker']]
    assert [stamp_ns(m.header) for m in tracker] == block.stamps_ns[::5].tolist()  # 10 Hz of 50
    assert all(
        m.header.frame_id == 'body' and m.angular_velocity_covariance[0] == -1.0 for m in tracker
    )
    np.testing.assert_array_equal(
        [[m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w] for m in tracker],
        tracker_rows[:, 0:4],
    )
    np.testing.assert_array_equal(
        [m.orientation_covariance for m in tracker], tracker_rows[:, 4:13]
    )
    poses = [m for _, m in messages['/pose']]
    assert all(m.header.frame_id == 'world' for m in poses)
    np.testing.assert_array_equal(
        [
            [
                m.pose.orientation.x,
                m.pose.orientation.y,
                m.pose.orientation.z,
                m.pose.orientation.w,
            ]
            for m in poses
        ],
        block.q_NB,
    )
    decoded = read_with_mcap(bag)
    assert decoded['/pose'][7][2].pose.orientation.w == block.q_NB[7, 3]
    assert decoded['/star_tracker'][9][2].orientation.x == tracker_rows[9, 0]
    assert metadata(bag)['message_count'] == 4 * 101 + 21


def test_the_node_publishes_pose_and_star_tracker_as_the_core_computes_them():
    from geometry_msgs.msg import PoseStamped
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import Imu
    from sim_harness import connected_harness, reset_epoch_ns, stamp_ns

    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=10000, reliability=ReliabilityPolicy.RELIABLE
    )
    with connected_harness(publish_rate=200.0) as harness:
        poses, tracker = [], []
        harness.client.create_subscription(PoseStamped, 'pose', poses.append, qos)
        harness.client.create_subscription(Imu, 'star_tracker', tracker.append, qos)
        assert harness.set_parameters(scene='estimator')[0].successful
        response = harness.reset()
        assert response.success, response.message
        harness.spin_until(
            lambda: len(poses) >= 40 and len(tracker) >= 40, what='pose and star_tracker samples'
        )
        (refused,) = harness.set_parameters(publish_rate=25.0)
        assert not refused.successful
        assert 'star_tracker.rate: 10 Hz must divide publish_rate 25 Hz' in refused.reason, (
            refused.reason
        )
    scene = load_scene('estimator')
    epoch = reset_epoch_ns(response)
    k = (np.array([stamp_ns(m.header.stamp) for m in tracker]) - epoch) * 200 // 10**9
    pose_k = (np.array([stamp_ns(m.header.stamp) for m in poses]) - epoch) * 200 // 10**9
    assert k.min() >= 0 and pose_k.min() >= 0
    assert np.all(k % 20 == 0)  # the tracker's 10 Hz: every 20th sample of 200 Hz, with its stamp
    count = int(max(k.max(), pose_k.max())) + 1
    block = Simulation(scene.propagator(), 200.0, epoch, outputs=scene.outputs).samples(0, count)
    np.testing.assert_array_equal(block.output_positions[1][k // 20], k)
    np.testing.assert_array_equal(
        [[m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w] for m in tracker],
        block.outputs[1][k // 20, 0:4],
    )
    np.testing.assert_array_equal(
        [
            [
                m.pose.orientation.x,
                m.pose.orientation.y,
                m.pose.orientation.z,
                m.pose.orientation.w,
            ]
            for m in poses
        ],
        block.q_NB[pose_k],
    )
