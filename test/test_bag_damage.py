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
Damaged and interrupted bags.

Damaged metadata, special files, changed bytes anywhere in the file, cut files, names too long, a
full disk at close. Every case gets one clear line and an exit status, keeps what is readable, and
never plays a damaged bag as if it were whole.

(Kept apart from the node's hostile-input tests: a node spinning in the same process would share
the interpreter with the byte-by-byte scan here.)
"""

from __future__ import annotations

import os
import time

from hostile_yaml import billion_laughs
import pytest

# -- damaged bags ---------------------------------------------------------------------------------


@pytest.fixture
def good_bag(tmp_path):
    from torquefree_ros.cli.bag import main as bag_main

    bag = tmp_path / 'good'
    # 300 s at 100 Hz: 4 chunks of 1 MiB, so a flipped byte in the second leaves the first whole
    assert bag_main(['default', '--duration', '300', '--rate', '100', '--output', str(bag)]) == 0
    return bag


def _play(bag, capsys):
    from torquefree_ros.cli.play import main as play_main

    status = play_main(['torquefree_play', str(bag), '--rate', '1000'])
    return status, capsys.readouterr().err


@pytest.mark.parametrize(
    'metadata, reason',
    [
        (b'\xff\xfe\x00junk', 'not UTF-8 text'),
        (billion_laughs().encode(), 'too large once its aliases are expanded'),
        (b'rosbag2_bagfile_information: [1, 2]\n', 'unreadable metadata.yaml'),
    ],
)
def test_players_and_reindex_refuse_a_damaged_metadata_file_in_one_line(
    good_bag, capsys, metadata, reason
):
    from torquefree_ros.cli.bag import main as bag_main

    (good_bag / 'metadata.yaml').write_bytes(metadata)
    started = time.monotonic()
    status, err = _play(good_bag, capsys)
    assert (
        status == 1 and reason in err and 'Traceback' not in err and len(err.splitlines()) == 1
    ), err
    assert bag_main(['--reindex', str(good_bag)]) == 1
    assert reason in capsys.readouterr().err
    assert time.monotonic() - started < 5.0


def test_a_fifo_in_place_of_the_mcap_file_is_refused_not_opened(good_bag, capsys):
    (good_bag / 'good_0.mcap').unlink()
    os.mkfifo(good_bag / 'good_0.mcap')
    status, err = _play(good_bag, capsys)
    assert status == 1 and 'is not a regular file' in err


def test_flipped_bytes_are_reported_with_what_was_lost_and_reindex_keeps_the_rest(
    good_bag, capsys
):
    from bag_checks import read_with_mcap, read_with_rosbags
    from torquefree_ros.bag import BagError, BagReader
    from torquefree_ros.cli.bag import main as bag_main

    data = bytearray((good_bag / 'good_0.mcap').read_bytes())
    data[len(data) // 3] ^= 0xFF  # inside a chunk's records
    (good_bag / 'good_0.mcap').write_bytes(bytes(data))
    with pytest.raises(
        BagError, match=r'damaged after \d+ messages .*the rest is lost.*--reindex'
    ):
        for _ in BagReader(good_bag).messages():
            pass
    assert bag_main(['--reindex', str(good_bag)]) == 1  # it repaired, and says what was lost
    err = capsys.readouterr().err
    assert (
        'damaged (' in err and 'messages before it were kept, everything after it is lost' in err
    )
    kept = BagReader(good_bag)
    assert kept.complete and 0 < kept.message_count < 2 * 30001
    assert sum(len(v) for v in read_with_mcap(good_bag).values()) == kept.message_count
    assert sum(len(v) for v in read_with_rosbags(good_bag)[0].values()) == kept.message_count


def _small_bag(path):
    from torquefree_ros.bag.offline import write_scene_bag
    from torquefree_ros.core.scene.loader import default_scene

    write_scene_bag(default_scene(), path, 0.5, 20)  # 22 messages, one chunk, 13 kB
    return next(path.glob('*.mcap'))


def _records(data: bytes) -> dict[str, list[tuple[int, int]]]:
    """Byte ranges of the file's top-level MCAP records, by opcode name (an independent parse)."""
    names = {
        1: 'header',
        2: 'footer',
        3: 'schema',
        4: 'channel',
        6: 'chunk',
        7: 'message_index',
        8: 'chunk_index',
        11: 'statistics',
        12: 'metadata',
        13: 'metadata_index',
        14: 'summary_offset',
        15: 'data_end',
    }
    found, position = {}, 8
    while position < len(data) - 8:
        length = int.from_bytes(data[position + 1: position + 9], 'little')
        found.setdefault(names[data[position]], []).append((position, position + 9 + length))
        position += 9 + length
    return found


def test_every_single_byte_change_is_noticed_by_play_or_reindex(tmp_path):
    """
    A changed byte anywhere is never silently played as if the bag were whole.

    A changed byte anywhere (chunks, message indexes, header, metadata record, summary, footer,
    magic) is refused, read as a damaged/incomplete file, or repaired by reindex with a note. Every
    byte of the small records, every 31st of the chunk, the schemas, the channels and rosbag2's
    metadata record.
    """
    import shutil

    from torquefree_ros.bag import BagError, BagReader, reindex

    original = tmp_path / 'original'
    file = _small_bag(original)
    data = file.read_bytes()
    expected = [tuple(m) for m in BagReader(original).messages()]
    sampled = [
        span
        for name in ('chunk', 'schema', 'channel', 'metadata')
        for span in _records(data)[name]
    ]
    offsets = [
        i for i in range(len(data)) if i % 31 == 0 or not any(a + 16 <= i < b for a, b in sampled)
    ]
    outcomes: dict[str, int] = {}
    work = tmp_path / 'work'
    for offset in offsets:
        shutil.rmtree(work, ignore_errors=True)
        # the .mcap alone: metadata.yaml has its own tests, and parsing it is most of the time
        work.mkdir()
        changed = bytearray(data)
        changed[offset] ^= 0x10
        (work / file.name).write_bytes(changed)
        try:
            bag = BagReader(work)
            read = [tuple(m) for m in bag.messages()]
            if not bag.complete:
                outcome = (
                    'read as incomplete, with a reason'
                    if bag.damage or bag.repairable
                    else 'incomplete'
                )
                assert read == expected[: len(read)], offset  # what is read is never changed
            elif read != expected:
                outcome = f'CHANGED MESSAGES at byte {offset}'
            else:
                repaired = reindex(work)
                outcome = (
                    'reindex repaired it, no message lost'
                    if repaired.repaired
                    else f'UNNOTICED at byte {offset}'
                )
                assert (
                    repaired.damage == ''
                    and [tuple(m) for m in BagReader(work).messages()] == expected
                )
        except BagError:
            outcome = 'refused, or stopped at the damage'
        outcomes[outcome] = outcomes.get(outcome, 0) + 1
    assert set(outcomes) <= {
        'read as incomplete, with a reason',
        'incomplete',
        'refused, or stopped at the damage',
        'reindex repaired it, no message lost',
    }, outcomes
    assert sum(outcomes.values()) == len(offsets) > 800


@pytest.mark.parametrize(
    'record, expected',
    [
        (
            'message_index',
            'repaired: bytes between its chunks are damaged (the data section CRC does not match)',
        ),
        (
            'metadata',
            'repaired: bytes between its chunks are damaged (the data section CRC does not match)',
        ),
        ('chunk_index', 'repaired: its summary is damaged (CRC mismatch)'),
        ('statistics', 'repaired: its summary is damaged (CRC mismatch)'),
    ],
)
def test_damage_that_loses_no_message_is_played_as_incomplete_and_repaired(
    tmp_path, capsys, record, expected
):
    from bag_checks import read_with_mcap, read_with_rosbags
    from torquefree_ros.bag import BagReader
    from torquefree_ros.cli.bag import main as bag_main

    file = _small_bag(tmp_path / 'bag')
    data = bytearray(file.read_bytes())
    start, end = _records(bytes(data))[record][0]
    data[(start + end) // 2] ^= 0x01  # inside the record's body, not its length
    file.write_bytes(bytes(data))
    if 'summary' in expected:  # the player reads every message by scanning, and says why
        status, err = _play(tmp_path / 'bag', capsys)
        assert (
            status == 1
            and 'is incomplete (its summary is damaged (CRC mismatch)): 22 readable' in err
        ), err
    assert bag_main(['--reindex', str(tmp_path / 'bag')]) == 0
    assert f'{tmp_path / "bag"}: {expected}; no message was lost' in capsys.readouterr().out
    assert (
        BagReader(tmp_path / 'bag').complete
        and BagReader(tmp_path / 'bag').check_data_section() == ''
    )
    assert sum(len(v) for v in read_with_mcap(tmp_path / 'bag').values()) == 22
    assert sum(len(v) for v in read_with_rosbags(tmp_path / 'bag')[0].values()) == 22
    assert bag_main(['--reindex', str(tmp_path / 'bag')]) == 0  # now nothing is left to repair
    assert 'repaired' not in capsys.readouterr().out


@pytest.mark.parametrize('keep', [0.5, 0.0], ids=['half', 'header-only'])
def test_a_cut_bag_plays_what_is_readable_and_exits_1(good_bag, capsys, keep):
    path = good_bag / 'good_0.mcap'
    data = path.read_bytes()
    # magic + a header record at least
    path.write_bytes(data[: max(int(len(data) * keep), 8 + 30)])
    (good_bag / 'metadata.yaml').unlink()
    status, err = _play(good_bag, capsys)
    assert status == 1 and 'Traceback' not in err, err
    # then, for the half bag, "played N messages": what was readable went out
    first = err.splitlines()[0]
    assert (
        'is incomplete' in first and '--reindex' in first
    ) or 'it ends inside its header' in first, err


def test_bag_tools_refuse_a_name_too_long_for_the_file_system(tmp_path, capsys):
    from torquefree_ros.cli.bag import main as bag_main
    from torquefree_ros.cli.record import main as record_main

    name = str(tmp_path / ('b' * 300))
    assert bag_main(['default', '--duration', '1', '--rate', '10', '--output', name]) == 1
    assert record_main(['torquefree_record', '--output', name]) == 1
    err = capsys.readouterr().err
    assert err.count('File name too long') == 2 and 'Traceback' not in err


# -- a full disk at close -------------------------------------------------------------------------


def _one_sample_writer(path):
    from torquefree_ros.bag import BagWriter

    writer = BagWriter(path)
    channel = writer.add_topic('/clock', 'rosgraph_msgs/msg/Clock')
    writer.write(channel, 5, b'\x00\x01\x00\x00' + bytes(8))
    return writer


def _no_space(*args, **kwargs):
    raise OSError(28, 'No space left on device')


def test_no_room_for_metadata_says_the_mcap_is_whole_and_how_to_repair(tmp_path, monkeypatch):
    from torquefree_ros.bag import BagError, BagReader
    from torquefree_ros.bag import writer as writer_module
    from torquefree_ros.cli.bag import main as bag_main

    writer = _one_sample_writer(tmp_path / 'bag')
    monkeypatch.setattr(writer_module, 'write_atomically', _no_space)
    with pytest.raises(BagError) as error:
        writer.close()
    message = str(error.value)
    assert (
        "'bag_0.mcap' is complete, but metadata.yaml could not be written"
        ' (No space left on device)' in message
    )
    assert 'chunk' not in message and f'torquefree_bag --reindex {tmp_path / "bag"}' in message
    monkeypatch.undo()
    assert bag_main(['--reindex', str(tmp_path / 'bag')]) == 0
    assert (
        BagReader(tmp_path / 'bag').message_count == 1
        and (tmp_path / 'bag' / 'metadata.yaml').is_file()
    )


def test_no_room_to_rebuild_after_a_write_error_gives_the_repair_command(tmp_path, monkeypatch):
    from torquefree_ros.bag import BagError, BagReader
    from torquefree_ros.bag import writer as writer_module
    from torquefree_ros.cli.bag import main as bag_main

    writer = _one_sample_writer(tmp_path / 'bag')
    writer.flush()  # the sample's chunk is on disk
    monkeypatch.setattr(writer._mcap, 'finish', _no_space)
    # the rebuilt copy finds no room either
    monkeypatch.setattr(writer_module, 'reindex', _no_space)
    with pytest.raises(BagError) as error:
        writer.close()
    message = str(error.value)
    assert 'could not be completed now (No space left on device)' in message
    assert f'free some space, then run `torquefree_bag --reindex {tmp_path / "bag"}`' in message
    monkeypatch.undo()
    assert bag_main(['--reindex', str(tmp_path / 'bag')]) == 0
    assert BagReader(tmp_path / 'bag').complete and BagReader(tmp_path / 'bag').message_count == 1
