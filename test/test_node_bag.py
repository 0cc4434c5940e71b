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
The node's own recording (``record_bag``): what it publishes, byte for byte.

Closed cleanly on shutdown and signals, bounded loss on SIGKILL. Checked against the offline bag
and independent readers.
"""

from __future__ import annotations

import os
from pathlib import Path
import signal
import subprocess
import sys
import time

from bag_checks import metadata, read_with_rosbags, vectors
from conftest import PROCESS_TIMEOUT
import numpy as np
import pytest
from sim_harness import SimHarness
from torquefree_ros.bag import BagReader
from torquefree_ros.bag.offline import write_scene_bag
from torquefree_ros.cli.bag import main as bag_main
from torquefree_ros.core.scene.loader import default_scene
from torquefree_ros.ros.parameters import ConfigurationError

REPO = Path(__file__).resolve().parent.parent


def _payloads(bag: Path, suffix: str) -> list:
    return [m for m in BagReader(bag).messages() if m.topic.endswith(suffix)]


def test_the_node_records_what_it_publishes_across_a_reset(tmp_path):
    bag = tmp_path / 'node_bag'
    # paced: ~2000 samples/s
    h = SimHarness(record_bag=str(bag), real_time_factor=20.0, publish_rate=100.0)
    try:
        h.wait_samples(300)
        assert h.reset().success
        restart_epoch = h.node.sample_loop.simulation.epoch_ns
        h.wait_samples(300, after=restart_epoch - 1)
        namespace = h.node.get_namespace()
        offered = {
            info.topic_type: info
            for info in h.client.get_publishers_info_by_topic(f'{namespace}/attitude')
        }
    finally:
        h.close()
    published = h.node.sample_loop.published
    omega, q = _payloads(bag, '/angular_velocity'), _payloads(bag, '/attitude')
    clock = _payloads(bag, '/clock')
    assert len(omega) == len(q) == len(clock) == published  # every sample, closed with the node
    assert all(m.topic.startswith(namespace + '/') for m in omega + q)
    stamps = [m.log_time_ns for m in omega]
    assert [m.log_time_ns for m in q] == [m.log_time_ns for m in clock] == stamps
    assert all(m.publish_time_ns == m.log_time_ns for m in omega + q)
    assert np.all(np.diff(stamps) > 0)
    restart = stamps.index(restart_epoch)
    assert restart >= 300 and len(stamps) - restart >= 300
    # each run equals the offline bag of the same scene, rate and epoch, byte for byte
    for first, last in ((0, restart), (restart, len(stamps))):
        offline = tmp_path / f'offline_{first}'
        write_scene_bag(
            default_scene(),
            offline,
            (last - first - 1) / 100.0,
            100.0,
            epoch_ns=stamps[first],
            namespace=namespace,
        )
        assert [m.data for m in _payloads(offline, '/angular_velocity')] == [
            m.data for m in omega[first:last]
        ]
        assert [m.data for m in _payloads(offline, '/attitude')] == [m.data for m in q[first:last]]
    # the QoS and type hash in the bag are what the graph reports for the node's publisher
    [topic] = [t for t in BagReader(bag).topics if t.name == f'{namespace}/attitude']
    info = offered['geometry_msgs/msg/QuaternionStamped']
    assert topic.type_description_hash == str(info.topic_type_hash)
    recorded, graph = topic.offered_qos_profiles[0], info.qos_profile
    assert (recorded.reliability, recorded.durability, recorded.liveliness) == (
        graph.reliability.name.lower(),
        graph.durability.name.lower(),
        graph.liveliness.name.lower(),
    )
    assert (
        recorded.deadline == graph.deadline.nanoseconds
        and recorded.lifespan == graph.lifespan.nanoseconds
    )
    # DDS discovery does not carry history and depth (the graph says unknown / 0); the node knows
    # them
    assert (recorded.history, recorded.depth) == ('keep_last', 10)
    assert metadata(bag)['message_count'] == 3 * published
    # the bag carries what its plots need: the body's inertia (the reset kept it), as offline bags
    # do
    from torquefree_ros.plot import bag_inertia

    assert bag_inertia(bag) == [3.0, 2.0, 1.0, 0.0, 0.0, 0.0]


def test_record_bag_is_read_only_and_never_overwrites(tmp_path):
    existing = tmp_path / 'existing'
    assert (
        bag_main(['default', '--duration', '0.1', '--rate', '10', '--output', str(existing)]) == 0
    )
    before = sorted((p.name, p.read_bytes()) for p in existing.iterdir())
    with pytest.raises(ConfigurationError, match=f"record_bag: bag '{existing}': already exists"):
        SimHarness(record_bag=str(existing))
    assert sorted((p.name, p.read_bytes()) for p in existing.iterdir()) == before
    h = SimHarness()
    try:
        result = h.set_parameters(record_bag=str(tmp_path / 'elsewhere'))[0]
        assert not result.successful and 'read-only' in result.reason
    finally:
        h.close()
    assert not (tmp_path / 'elsewhere').exists()


def _start_recording_node(bag: Path, rate: float = 200.0) -> subprocess.Popen:
    env = dict(os.environ, PYTHONUNBUFFERED='1')
    process = subprocess.Popen(
        [
            sys.executable,
            '-m',
            'torquefree_ros.cli.sim',
            '--ros-args',
            '-p',
            f'publish_rate:={rate}',
            '-p',
            f'record_bag:={bag}',
        ],
        cwd=REPO,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    for line in process.stderr:
        if 'start: ' in line:
            return process
    process.kill()
    raise AssertionError(f'the node did not start: {process.communicate()}')


@pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_a_signal_closes_the_bag_cleanly(signum, tmp_path):
    bag = tmp_path / 'signalled'
    process = _start_recording_node(bag)
    try:
        time.sleep(0.5)
        process.send_signal(signum)
        _, stderr = process.communicate(timeout=PROCESS_TIMEOUT)
    finally:
        process.kill()
    assert process.returncode == 0 and 'Traceback' not in stderr, stderr
    reader = BagReader(bag)
    assert reader.complete and reader.message_count == metadata(bag)['message_count'] >= 2
    messages, _ = read_with_rosbags(bag)
    assert (
        len(messages['/angular_velocity'])
        == len(messages['/attitude'])
        == reader.message_count // 2
    )


def test_sigkill_loses_at_most_the_open_chunk(tmp_path):
    """
    SIGKILL loses at most the open chunk.

    Chunks are written out at least once a second; stamps are wall-clock at real_time_factor 1, so
    the last readable stamp tells how much was lost.
    """
    bag = tmp_path / 'killed'
    process = _start_recording_node(bag)
    time.sleep(2.6)
    killed_at = time.time_ns()
    process.kill()
    process.communicate(timeout=PROCESS_TIMEOUT)
    reader = BagReader(bag)
    assert not reader.complete
    omega = [m for m in reader.messages() if m.topic == '/angular_velocity']
    stamps = np.array([m.log_time_ns for m in omega])
    assert len(stamps) >= 200  # at least one second of samples survived
    assert np.all(np.diff(stamps) == 5_000_000)  # a gap-free prefix from sample 0
    lost_seconds = (killed_at - stamps[-1]) / 1e9
    # the chunk bound plus slack for a loaded machine
    assert lost_seconds <= 1.0 + 0.5, lost_seconds
    # torquefree_bag --reindex makes it a complete bag that independent readers open
    assert bag_main(['--reindex', str(bag)]) == 0
    messages, _ = read_with_rosbags(bag)
    assert len(messages['/angular_velocity']) == len(omega)
    np.testing.assert_array_equal(
        vectors(messages['/angular_velocity']),
        np.array([np.frombuffer(m.data[-24:], '<f8') for m in omega]),
    )
