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
The ``torquefree_record`` and ``torquefree_play`` processes, on this test session's DDS domain.

Player → recorder round trip, recorder against the node's own recording, and their input errors.
"""

from __future__ import annotations

import os
from pathlib import Path
import signal
import subprocess
import sys
import time

from bag_checks import read_with_rosbags
from conftest import PROCESS_TIMEOUT
from geometry_msgs.msg import Vector3Stamped
import numpy as np
import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from torquefree_ros.bag import BagReader
from torquefree_ros.cli import play as player
from torquefree_ros.cli import record as recorder
from torquefree_ros.cli.bag import main as bag_main
from torquefree_ros.testing.domains import claim_domain

REPO = Path(__file__).resolve().parent.parent


def _spawn(module: str, *args: str, domain_id: int | None = None) -> subprocess.Popen:
    env = dict(os.environ, PYTHONUNBUFFERED='1')
    if domain_id is not None:
        env['ROS_DOMAIN_ID'] = str(domain_id)
    return subprocess.Popen(
        [sys.executable, '-m', module, *args],
        cwd=REPO,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait_for_message(topic: str, message_type, domain_id: int, timeout: float) -> None:
    """Wait until a message arrives on ``topic`` in ``domain_id``, at most ``timeout`` s."""
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain_id)
    received = []
    try:
        node = rclpy.create_node('test_listener', context=context)
        node.create_subscription(message_type, topic, received.append, 10)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        deadline = time.monotonic() + timeout
        while not received and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        executor.shutdown()
        node.destroy_node()
    finally:
        context.try_shutdown()
    assert received, f'no message on {topic} within {timeout:g} s'


def _wait_for_line(process: subprocess.Popen, text: str, count: int = 1) -> None:
    seen = 0
    for line in process.stderr:
        seen += text in line
        if seen >= count:
            return
    raise AssertionError(f"'{text}' never appeared: {process.communicate()}")


def _stop(process: subprocess.Popen) -> str:
    process.send_signal(signal.SIGINT)
    try:
        _, stderr = process.communicate(timeout=PROCESS_TIMEOUT)
    finally:
        process.kill()
    assert process.returncode == 0 and 'Traceback' not in stderr, stderr
    return stderr


def _data(bag: Path, topic: str) -> list[bytes]:
    return [m.data for m in BagReader(bag).messages([topic])]


def test_player_to_recorder_round_trip_keeps_every_message_and_the_timing(tmp_path):
    source, copy = tmp_path / 'source', tmp_path / 'copy'
    assert bag_main(['default', '--duration', '2', '--rate', '50', '--output', str(source)]) == 0
    rec = _spawn(
        'torquefree_ros.cli.record',
        '--output',
        str(copy),
        '--topics',
        '/angular_velocity',
        '/attitude',
        '/clock',
    )
    try:
        play = subprocess.run(
            [
                sys.executable,
                '-m',
                'torquefree_ros.cli.play',
                str(source),
                '--rate',
                '2',
                '--clock',
                '50',
                '--wait-for-subscribers',
                '20',
            ],
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=PROCESS_TIMEOUT,
        )
        assert play.returncode == 0 and 'played 202 messages' in play.stderr, play.stderr
        time.sleep(0.5)
    finally:
        _stop(rec)
    for topic in ('/angular_velocity', '/attitude'):
        assert _data(copy, topic) == _data(source, topic)  # every message, in order, byte for byte
    copied = BagReader(copy)
    assert {
        t.name: t.offered_qos_profiles[0].reliability for t in copied.topics if t.name != '/clock'
    } == {'/angular_velocity': 'reliable', '/attitude': 'reliable'}
    # the recorded timing: 2 s of bag played at twice the speed takes about 1 s
    received = np.array([m.log_time_ns for m in copied.messages(['/attitude'])]) / 1e9
    assert 0.9 <= received[-1] - received[0] <= 2.0
    # /clock carried the bag's time, never ahead of the messages
    clock = [
        int.from_bytes(d[4:8], 'little', signed=True) * 10**9 + int.from_bytes(d[8:12], 'little')
        for d in _data(copy, '/clock')
    ]
    assert len(clock) >= 20 and clock == sorted(clock) and 0 <= clock[0] and clock[-1] <= 2 * 10**9
    messages, _ = read_with_rosbags(copy)  # an independent reader opens the recording
    assert len(messages['/attitude']) == 101


def test_recorder_gets_every_sample_the_node_publishes(tmp_path):
    node_bag, recorded = tmp_path / 'node_bag', tmp_path / 'recorded'
    rec = _spawn('torquefree_ros.cli.record', '--output', str(recorded))  # all topics
    # qos_depth 1000 (5 s at 200 Hz): with the default 10, a reliable keep-last writer overwrites
    # samples a CPU-starved reader has not acknowledged within 50 ms, which is DDS, not the
    # recorder
    node = _spawn(
        'torquefree_ros.cli.sim',
        '--ros-args',
        '-p',
        'publish_rate:=200.0',
        '-p',
        'qos_depth:=1000',
        '-p',
        f'record_bag:={node_bag}',
    )
    try:
        _wait_for_line(rec, 'recording /attitude')
        time.sleep(1.5)
        _stop(node)  # the node closes its own bag: the reference of what it published
        time.sleep(0.5)
    finally:
        node.kill()
        _stop(rec)
    for topic in ('/angular_velocity', '/attitude'):
        published, got = _data(node_bag, topic), _data(recorded, topic)
        assert len(got) >= 200
        # nothing lost between the first message received and the last: a contiguous run of what
        # the node published (under load the last few may still be in flight when the recorder
        # stops)
        first = published.index(got[0])
        expected = published[first: first + len(got)]
        mismatch = next((i for i, (a, b) in enumerate(zip(got, expected)) if a != b), None)
        assert mismatch is None, (
            f'{topic}: message {mismatch} of {len(got)} received differs; it is '
            f'published[{published.index(got[mismatch]) if got[mismatch] in published else None}]'
            f', expected published[{first + mismatch}]'
        )
        # at most 0.1 s of samples at 200 Hz in flight
        assert len(published) - (first + len(got)) <= 20
    # /diagnostics (the invariants the Foxglove layout plots) is in what the recorder took from the
    # live node, not in the node's own bag of its samples
    assert '/diagnostics' in {t.name for t in BagReader(recorded).topics}
    assert '/diagnostics' not in {t.name for t in BagReader(node_bag).topics}


def test_recorder_resolves_relative_names_and_duration_is_recorded_time(tmp_path):
    """
    The recorder resolves relative names, and ``--duration`` is recorded time.

    ``--topics angular_velocity`` is ``/angular_velocity`` (the recorder's namespace is ``/``); the
    1.5 s of ``--duration`` count from the first message, not from start-up (discovery takes time).
    """
    recorded = tmp_path / 'recorded'
    node = _spawn('torquefree_ros.cli.sim', '--ros-args', '-p', 'publish_rate:=100.0')
    try:
        rec = subprocess.run(
            [
                sys.executable,
                '-m',
                'torquefree_ros.cli.record',
                '--output',
                str(recorded),
                '--topics',
                'angular_velocity',
                '--duration',
                '1.5',
            ],
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=PROCESS_TIMEOUT,
        )
    finally:
        _stop(node)
    assert rec.returncode == 0, rec.stderr
    assert [t.name for t in BagReader(recorded).topics] == ['/angular_velocity']
    received = np.array([m.log_time_ns for m in BagReader(recorded).messages()]) / 1e9
    assert 1.4 <= received[-1] - received[0] <= 2.0  # the clock starts with the first message


@pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_a_looping_player_stops_cleanly_on_signals(signum, tmp_path):
    bag = tmp_path / 'bag'
    assert bag_main(['default', '--duration', '1', '--rate', '50', '--output', str(bag)]) == 0
    # a domain of its own: the message waited for is the player's, not another test's node's
    domain = claim_domain()
    try:
        play = _spawn(
            'torquefree_ros.cli.play', str(bag), '--loop', '--clock', '20',
            domain_id=domain.domain_id,
        )
        try:
            # signalled once it plays (not after a fixed sleep: under load it may still be
            # importing)
            _wait_for_message(
                'angular_velocity', Vector3Stamped, domain.domain_id, PROCESS_TIMEOUT
            )
            play.send_signal(signum)
            _, stderr = play.communicate(timeout=PROCESS_TIMEOUT)
        finally:
            play.kill()
    finally:
        domain.release()
    assert play.returncode == 0 and 'Traceback' not in stderr, stderr
    assert int(stderr.split('played ')[1].split()[0]) > 0


def test_player_and_recorder_input_errors(tmp_path, capsys):
    assert player.main(['torquefree_play', str(tmp_path / 'missing')]) == 1
    assert f"bag '{tmp_path / 'missing'}'" in capsys.readouterr().err
    bag = tmp_path / 'bag'
    assert bag_main(['default', '--duration', '0.1', '--rate', '10', '--output', str(bag)]) == 0
    for argv, message in (
        (['--rate', '0'], '--rate'),
        (['--topics', '/nope'], 'not in the bag: /nope'),
        (['--clock', '-1'], '--clock'),
    ):
        with pytest.raises(SystemExit) as exit_info:
            player.main(['torquefree_play', str(bag), *argv])
        assert exit_info.value.code == 2 and message in capsys.readouterr().err
    assert recorder.main(['torquefree_record', '--output', str(bag)]) == 1
    assert 'already exists' in capsys.readouterr().err
    with pytest.raises(SystemExit):
        recorder.main(
            ['torquefree_record', '--output', str(tmp_path / 'new'), '--topics', 'bad name']
        )
    assert (
        '--topics: Invalid topic name' in capsys.readouterr().err
        and not (tmp_path / 'new').exists()
    )
