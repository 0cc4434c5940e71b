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
The rosbag2 MCAP writer and ``torquefree_bag``.

Checked with independent readers (mcap + mcap-ros2-support, rosbags) and against rosbag2's own
layout rules. No DDS.
"""

from __future__ import annotations

import json
from pathlib import Path
import resource
import signal
import subprocess
import sys

from bag_checks import (
    mcap_file,
    metadata,
    quaternions,
    read_with_mcap,
    read_with_rosbags,
    SEPARATOR,
    stamp_ns,
    summary,
    vectors,
)
import numpy as np
import pytest
from torquefree_ros import propagate
from torquefree_ros.bag import BagError, BagQos, BagReader, BagWriter, message_definition
from torquefree_ros.cli.bag import main as bag_main
from torquefree_ros.core.scene.loader import DEFAULT_SCENE_DATA
import yaml

REPO = Path(__file__).resolve().parent.parent
SHARE = Path(sys.prefix) / 'share'
INFINITE = {'sec': 9223372036, 'nsec': 854775807}


def _msg(type_name: str) -> str:
    package, name = type_name.split('/')
    return (SHARE / package / 'msg' / f'{name}.msg').read_text()


def _layout(root: str, *dependencies: str) -> str:
    """rosbag2's text: the root's .msg, then each dependency after a separator and 'MSG: name'."""
    return _msg(root) + ''.join(f'\n{SEPARATOR}MSG: {name}\n{_msg(name)}' for name in dependencies)


@pytest.mark.parametrize(
    'type_name, expected',
    [
        (
            'geometry_msgs/msg/Vector3Stamped',
            _layout(
                'geometry_msgs/Vector3Stamped',
                'geometry_msgs/Vector3',
                'std_msgs/Header',
                'builtin_interfaces/Time',
            ),
        ),
        (
            'geometry_msgs/msg/QuaternionStamped',
            _layout(
                'geometry_msgs/QuaternionStamped',
                'geometry_msgs/Quaternion',
                'std_msgs/Header',
                'builtin_interfaces/Time',
            ),
        ),
        # depth first, each dependency once, sorted by the name as written in the .msg
        (
            'geometry_msgs/msg/PoseStamped',
            _layout(
                'geometry_msgs/PoseStamped',
                'geometry_msgs/Pose',
                'geometry_msgs/Point',
                'geometry_msgs/Quaternion',
                'std_msgs/Header',
                'builtin_interfaces/Time',
            ),
        ),
        ('rosgraph_msgs/msg/Clock', _layout('rosgraph_msgs/Clock', 'builtin_interfaces/Time')),
    ],
)
def test_schema_text_is_rosbag2s_layout(type_name, expected):
    definition = message_definition(type_name)
    assert definition.encoding == 'ros2msg'
    assert definition.text == expected
    package, _, name = type_name.split('/')
    description = json.loads((SHARE / package / 'msg' / f'{name}.json').read_text())
    hashes = {entry['type_name']: entry['hash_string'] for entry in description['type_hashes']}
    assert definition.type_hash == hashes[type_name] and definition.type_hash.startswith('RIHS01_')


def test_unknown_types_are_named():
    with pytest.raises(ValueError, match='no_such_pkg'):
        message_definition('no_such_pkg/msg/Thing')
    with pytest.raises(ValueError, match="'geometry_msgs/msg/NoSuch'"):
        message_definition('geometry_msgs/msg/NoSuch')
    with pytest.raises(ValueError, match="expected 'package/msg/Type'"):
        message_definition('Vector3')


@pytest.fixture(scope='module')
def offline_bag(tmp_path_factory) -> Path:
    """Write the default scene, 2.3 s at 100 Hz: 231 samples (both ends included)."""
    bag = tmp_path_factory.mktemp('offline') / 'default_bag'
    assert bag_main(['default', '--duration', '2.3', '--rate', '100', '--output', str(bag)]) == 0
    return bag


def _expected_state(count: int, rate: float):
    times = np.arange(count) / rate
    scene = DEFAULT_SCENE_DATA
    return times, *propagate(
        scene['body']['inertia'],
        scene['initial']['angular_velocity'],
        scene['initial']['orientation'],
        times,
    )


def test_offline_bag_read_with_mcap_and_mcap_ros2(offline_bag):
    header, file_summary, records = summary(offline_bag)
    assert header.profile == 'ros2'
    topics = read_with_mcap(offline_bag)
    assert sorted(topics) == ['/angular_velocity', '/attitude']
    times, omega, q = _expected_state(231, 100.0)
    stamps = np.arange(231) * 10_000_000
    for topic in topics.values():
        assert len(topic) == 231
        assert [log for log, _, _ in topic] == stamps.tolist()  # log time = the sample's stamp
        assert [pub for _, pub, _ in topic] == stamps.tolist()  # and so is publish time
        assert [stamp_ns(m.header) for *_, m in topic] == stamps.tolist()
    assert {m.header.frame_id for *_, m in topics['/angular_velocity']} == {'body'}
    assert {m.header.frame_id for *_, m in topics['/attitude']} == {'world'}
    np.testing.assert_array_equal(vectors(topics['/angular_velocity']), omega)
    np.testing.assert_array_equal(quaternions(topics['/attitude']), q)
    schemas = {s.name: s for s in file_summary.schemas.values()}
    assert {s.encoding for s in schemas.values()} == {'ros2msg'}
    for channel in file_summary.channels.values():
        assert channel.message_encoding == 'cdr'
        schema = file_summary.schemas[channel.schema_id]
        assert schema.data.decode() == message_definition(schema.name).text
        assert channel.metadata['topic_type_hash'] == message_definition(schema.name).type_hash
        assert yaml.safe_load(channel.metadata['offered_qos_profiles']) == [
            {
                'history': 'keep_last',
                'depth': 10,
                'reliability': 'reliable',
                'durability': 'volatile',
                'deadline': INFINITE,
                'lifespan': INFINITE,
                'liveliness': 'automatic',
                'liveliness_lease_duration': INFINITE,
                'avoid_ros_namespace_conventions': False,
            }
        ]


def test_offline_bag_read_with_rosbags(offline_bag):
    messages, connections = read_with_rosbags(offline_bag)
    times, omega, q = _expected_state(231, 100.0)
    assert connections['/angular_velocity'].msgtype == 'geometry_msgs/msg/Vector3Stamped'
    assert connections['/attitude'].msgtype == 'geometry_msgs/msg/QuaternionStamped'
    for topic in ('/angular_velocity', '/attitude'):
        assert connections[topic].msgcount == 231
        qos = connections[topic].ext.offered_qos_profiles[0]
        assert (qos.reliability.name, qos.history.name, qos.depth) == ('RELIABLE', 'KEEP_LAST', 10)
        assert [t for t, _ in messages[topic]] == [stamp_ns(m.header) for _, m in messages[topic]]
    np.testing.assert_array_equal(vectors(messages['/angular_velocity']), omega)
    np.testing.assert_array_equal(quaternions(messages['/attitude']), q)


def test_metadata_yaml_agrees_with_the_file(offline_bag):
    info = metadata(offline_bag)
    _, file_summary, records = summary(offline_bag)
    stats = file_summary.statistics
    name = mcap_file(offline_bag).name
    assert (
        info['version'] == 9
        and info['storage_identifier'] == 'mcap'
        and info['ros_distro'] == 'jazzy'
    )
    assert info['relative_file_paths'] == [name]
    assert info['message_count'] == stats.message_count == 462
    assert info['starting_time']['nanoseconds_since_epoch'] == stats.message_start_time == 0
    assert (
        info['duration']['nanoseconds']
        == stats.message_end_time - stats.message_start_time
        == 2_300_000_000
    )
    assert info['files'] == [
        {
            'path': name,
            'starting_time': info['starting_time'],
            'duration': info['duration'],
            'message_count': 462,
        }
    ]
    assert (info['compression_format'], info['compression_mode']) == ('', '')
    by_topic = {c.topic: stats.channel_message_counts[i] for i, c in file_summary.channels.items()}
    for entry in info['topics_with_message_count']:
        topic = entry['topic_metadata']
        assert entry['message_count'] == by_topic[topic['name']] == 231
        assert topic['serialization_format'] == 'cdr'
        assert topic['type_description_hash'] == message_definition(topic['type']).type_hash
        assert topic['offered_qos_profiles'][0]['reliability'] == 'reliable'
    # the rosbag2 metadata record carries the same mapping
    [record] = [r for r in records if r.name == 'rosbag2']
    assert yaml.safe_load(record.metadata['serialized_metadata']) == info
    assert info['custom_data']['torquefree_ros.scene'] == '<built-in default>'


def test_file_is_chunked_indexed_and_uncompressed_by_default(offline_bag, tmp_path):
    _, file_summary, _ = summary(offline_bag)
    assert file_summary.chunk_indexes and all(
        c.compression == '' for c in file_summary.chunk_indexes
    )
    assert all(len(c.message_index_offsets) == 2 for c in file_summary.chunk_indexes)
    assert file_summary.statistics.chunk_count == len(file_summary.chunk_indexes)
    zstd = tmp_path / 'zstd_bag'
    assert (
        bag_main(
            [
                'default',
                '--duration',
                '2.3',
                '--rate',
                '100',
                '--output',
                str(zstd),
                '--compression',
                'zstd',
            ]
        )
        == 0
    )
    _, zstd_summary, _ = summary(zstd)
    assert {c.compression for c in zstd_summary.chunk_indexes} == {'zstd'}
    np.testing.assert_array_equal(
        quaternions(read_with_rosbags(zstd)[0]['/attitude']),
        quaternions(read_with_rosbags(offline_bag)[0]['/attitude']),
    )


def test_chunks_are_bounded_in_bytes(tmp_path):
    with BagWriter(tmp_path / 'small_chunks', chunk_bytes=4096) as writer:
        channel = writer.add_topic('/clock', 'rosgraph_msgs/msg/Clock')
        writer.write_rows((channel,), range(5000), ([b'\x00\x01\x00\x00' + bytes(8)] * 5000,))
    _, file_summary, _ = summary(tmp_path / 'small_chunks')
    sizes = [c.uncompressed_size for c in file_summary.chunk_indexes]
    assert len(sizes) > 10 and max(sizes) <= 4096 + 100  # one message past the bound at most


def test_contract_sample_count_and_start_time(tmp_path):
    bag = tmp_path / 'later'
    assert (
        bag_main(
            [
                'default',
                '--duration',
                '0.05',
                '--rate',
                '40',
                '--start-time',
                '12.5',
                '--output',
                str(bag),
            ]
        )
        == 0
    )
    topics = read_with_mcap(bag)
    # k = 0 … 2
    assert [log for log, _, _ in topics['/attitude']] == [
        12_500_000_000,
        12_525_000_000,
        12_550_000_000,
    ]


def test_start_time_now_stamps_sample_0_from_the_wall_clock(tmp_path):
    import time

    before = time.time_ns()
    assert (
        bag_main(
            [
                'default',
                '--duration',
                '0.05',
                '--rate',
                '40',
                '--start-time',
                'now',
                '--output',
                str(tmp_path / 'today'),
            ]
        )
        == 0
    )
    after = time.time_ns()
    logs = [log for log, _, _ in read_with_mcap(tmp_path / 'today')['/attitude']]
    assert before <= logs[0] <= after  # sample 0 at the moment the command read the clock
    assert [log - logs[0] for log in logs] == [0, 25_000_000, 50_000_000]


def test_an_existing_bag_is_never_overwritten_without_asking(offline_bag, tmp_path, capsys):
    before = mcap_file(offline_bag).read_bytes()
    assert (
        bag_main(['default', '--duration', '1', '--rate', '10', '--output', str(offline_bag)]) == 1
    )
    assert (
        'already exists' in capsys.readouterr().err
        and mcap_file(offline_bag).read_bytes() == before
    )
    copy = tmp_path / 'copy'
    assert bag_main(['default', '--duration', '1', '--rate', '10', '--output', str(copy)]) == 0
    assert (
        bag_main(
            ['default', '--duration', '0.5', '--rate', '10', '--output', str(copy), '--overwrite']
        )
        == 0
    )
    assert metadata(copy)['message_count'] == 12
    other = tmp_path / 'not_a_bag'
    other.mkdir()
    (other / 'notes.txt').write_text('keep me')
    assert (
        bag_main(
            ['default', '--duration', '1', '--rate', '10', '--output', str(other), '--overwrite']
        )
        == 1
    )
    assert (
        'not a bag directory' in capsys.readouterr().err
        and (other / 'notes.txt').read_text() == 'keep me'
    )


def test_an_unusable_output_fails_before_simulating_and_names_the_path(
    tmp_path, capsys, monkeypatch
):
    blocker = tmp_path / 'a_file'
    blocker.write_text('')
    calls = []
    monkeypatch.setattr(
        'torquefree_ros.core.run.simulation.Simulation.samples', lambda *a: calls.append(a)
    )
    assert (
        bag_main(['default', '--duration', '1', '--rate', '10', '--output', str(blocker / 'bag')])
        == 1
    )
    error = capsys.readouterr().err
    assert str(blocker / 'bag') in error and 'cannot create the directory' in error and calls == []


@pytest.mark.parametrize(
    'argv, message',
    [
        (['no_such_scene', '--duration', '1', '--rate', '10'], 'no_such_scene'),
        (['default', '--duration', '1', '--rate', '0'], 'rate'),
        (['default', '--duration', '-1', '--rate', '10'], 'duration'),
        (['default', '--duration', '1', '--rate', '10', '--start-time', 'nan'], '--start-time'),
        (['default', '--duration', '1'], 'missing --rate'),
    ],
)
def test_bad_arguments_are_named_and_create_nothing(argv, message, tmp_path, capsys):
    output = tmp_path / 'never'
    with pytest.raises(SystemExit) as exit_info:
        bag_main([*argv, '--output', str(output)])
    assert exit_info.value.code == 2 and message in capsys.readouterr().err and not output.exists()


def test_a_bad_scene_file_names_the_field(tmp_path, capsys):
    scene = tmp_path / 'bad.yaml'
    scene.write_text(
        'body:\n  inertia: [1.0, 1.0, 3.0]\ninitial:\n  angular_velocity: [0, 0, 1]\n'
    )
    with pytest.raises(SystemExit):
        bag_main(
            [str(scene), '--duration', '1', '--rate', '10', '--output', str(tmp_path / 'never')]
        )
    error = capsys.readouterr().err
    assert 'body.inertia' in error and 'triangle' in error and not (tmp_path / 'never').exists()


def test_writer_api_errors_are_named(tmp_path):
    with BagWriter(tmp_path / 'api') as writer:
        with pytest.raises(BagError, match="'angular_velocity'.*starting with '/'"):
            writer.add_topic('angular_velocity', 'geometry_msgs/msg/Vector3Stamped')
        with pytest.raises(BagError, match="'/x'.*no_pkg"):
            writer.add_topic('/x', 'no_pkg/msg/X')
        with pytest.raises(BagError, match='unknown channel'):
            writer.write(99, 0, b'')
    with pytest.raises(BagError, match='compression'):
        BagWriter(tmp_path / 'c', compression='lz5')
    with pytest.raises(ValueError, match='qos.reliability'):
        BagQos(reliability='sometimes')


@pytest.mark.parametrize('type_name, reader', [
    ('geometry_msgs/msg/WrenchStamped', 'read_commands'),
    ('geometry_msgs/msg/Vector3Stamped', 'read_vector_commands'),
    ('sensor_msgs/msg/JointState', 'read_joint_commands'),
])
def test_a_command_that_is_not_its_type_is_named_with_its_time(tmp_path, type_name, reader):
    from torquefree_ros.bag import offline

    with BagWriter(tmp_path / 'bad') as writer:
        channel = writer.add_topic('/command', type_name)
        writer.write(channel, 1_000, b'\x00\x01\x00\x00' + b'\xff' * 7)  # truncated CDR
    short = type_name.rsplit('/', 1)[-1]
    with pytest.raises(BagError, match=f"on '/command' at 1000 ns is not a {short} "):
        getattr(offline, reader)(tmp_path / 'bad', '/command')
    with pytest.raises(BagError, match=f"'/command' is {type_name}, not "):
        other = 'read_commands' if reader != 'read_commands' else 'read_vector_commands'
        getattr(offline, other)(tmp_path / 'bad', '/command')


def test_an_error_inside_the_block_still_leaves_a_complete_bag(tmp_path):
    with pytest.raises(KeyError):
        with BagWriter(tmp_path / 'interrupted') as writer:
            channel = writer.add_topic('/clock', 'rosgraph_msgs/msg/Clock')
            writer.write(channel, 5, b'\x00\x01\x00\x00' + bytes(8))
            raise KeyError("the caller's own error")
    reader = BagReader(tmp_path / 'interrupted')
    assert (
        reader.complete
        and reader.message_count == 1
        and metadata(tmp_path / 'interrupted')['message_count'] == 1
    )


def _limit_file_size():
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # writes past the limit fail with EFBIG instead
    # two 1 MiB chunks fit, the third does not
    resource.setrlimit(resource.RLIMIT_FSIZE, (2_500_000, 2_500_000))


def test_a_full_disk_is_a_clear_error_and_what_was_written_stays_readable(tmp_path):
    bag = tmp_path / 'full'
    process = subprocess.run(
        [
            sys.executable,
            '-m',
            'torquefree_ros.cli.bag',
            'default',
            '--duration',
            '1000',
            '--rate',
            '100',
            '--output',
            str(bag),
        ],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=_limit_file_size,
    )
    assert process.returncode == 1, process.stderr
    assert f"bag '{bag}'" in process.stderr and 'File too large' in process.stderr
    assert 'Traceback' not in process.stderr
    # the complete chunks were copied into a complete file with its metadata.yaml
    reader = BagReader(bag)
    assert (
        reader.complete
        and reader.message_count > 1000
        and sorted(p.name for p in bag.iterdir()) == ['full_0.mcap', 'metadata.yaml']
    )
    omega = [m for m in reader.messages() if m.topic == '/angular_velocity']
    # a gap-free prefix
    assert [m.log_time_ns for m in omega] == [k * 10_000_000 for k in range(len(omega))]
    assert metadata(bag)['message_count'] == reader.message_count
    messages, _ = read_with_rosbags(bag)  # an independent reader agrees
    assert len(messages['/angular_velocity']) == len(omega)
    np.testing.assert_array_equal(
        vectors(messages['/angular_velocity']), _expected_state(len(omega), 100.0)[1]
    )


def test_a_scene_with_outputs_writes_them_as_the_node_publishes_them(tmp_path):
    """
    The imu library scene's bag holds /imu and /euler_angles beside the samples.

    /imu is sensor_msgs/Imu; both independent readers read them, values equal to the core's rows
    for each sample.
    """
    from torquefree_ros import load_scene
    from torquefree_ros.core.run.simulation import Simulation

    bag = tmp_path / 'imu_bag'
    assert bag_main(['imu', '--duration', '2', '--rate', '50', '--output', str(bag)]) == 0
    messages, connections = read_with_rosbags(bag)
    assert {t: c.msgtype for t, c in connections.items()} == {
        '/angular_velocity': 'geometry_msgs/msg/Vector3Stamped',
        '/attitude': 'geometry_msgs/msg/QuaternionStamped',
        '/imu': 'sensor_msgs/msg/Imu',
        '/euler_angles': 'geometry_msgs/msg/Vector3Stamped',
    }
    scene = load_scene('imu')
    block = Simulation(scene.propagator(), 50.0, outputs=scene.outputs).samples(0, 101)
    imu_rows, euler_rows = block.outputs
    imu = [m for _, m in messages['/imu']]
    assert len(imu) == 101 and [stamp_ns(m.header) for m in imu] == block.stamps_ns.tolist()
    np.testing.assert_array_equal(
        [[m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z] for m in imu],
        imu_rows[:, 13:16],
    )
    np.testing.assert_array_equal([m.angular_velocity_covariance for m in imu], imu_rows[:, 16:25])
    assert all(m.orientation_covariance[0] == -1.0 and m.header.frame_id == 'body' for m in imu)
    np.testing.assert_array_equal(vectors(messages['/euler_angles']), euler_rows)
    decoded = read_with_mcap(bag)
    assert (
        len(decoded['/imu']) == 101 and decoded['/imu'][5][2].angular_velocity.x == imu_rows[5, 13]
    )
    assert metadata(bag)['message_count'] == 4 * 101
