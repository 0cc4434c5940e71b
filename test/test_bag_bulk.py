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
The bulk path of the bag writer (``bag.bulk``) writes the very bytes ``add_message`` writes.

``add_message`` writes one message at a time; whole files are compared, across chunk boundaries,
with messages of varying sizes, gaps (None), single rows between blocks (both paths in one chunk),
compression, and scenes with every output.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from torquefree_ros import load_scene
from torquefree_ros.bag import bulk
from torquefree_ros.bag import writer as bag_writer
from torquefree_ros.bag.cdr import MessageBlock
from torquefree_ros.bag.offline import write_scene_bag
from torquefree_ros.bag.writer import BagWriter

TOPICS = (
    ('/clock', 'rosgraph_msgs/msg/Clock'),
    ('/angular_velocity', 'geometry_msgs/msg/Vector3Stamped'),
    ('/markers', 'visualization_msgs/msg/MarkerArray'),
)


def _write(path, batches, monkeypatch, bulk_on: bool, compression='none'):
    monkeypatch.setattr(bag_writer, 'BULK_MESSAGES', 1 if bulk_on else 10**12)
    with BagWriter(path, chunk_bytes=4096, chunk_seconds=1e9, compression=compression) as writer:
        assert bulk.supported(writer._mcap)
        channels = [writer.add_topic(name, type_name) for name, type_name in TOPICS]
        for times, published, columns in batches:
            writer.write_rows(channels, times, columns, published)
    return (path / f'{path.name}_0.mcap').read_bytes()


def _batches(seed: int):
    """
    Draw batches of rows of three columns.

    Fixed 12-byte messages, 40-byte ones, and ones of any size with gaps; batches of 1 to 300 rows
    (single rows take add_message's path even with bulk on).
    """
    rng = np.random.default_rng(seed)
    batches, t = [], 0
    for _ in range(40):
        rows = int(rng.choice([1, 1, 3, 50, 300]))
        times = t + np.cumsum(rng.integers(1, 1000, rows))
        t = int(times[-1])
        published = times + rng.integers(0, 50, rows)
        columns = [
            [rng.bytes(12) for _ in range(rows)],
            [rng.bytes(40) if rng.random() > 0.1 else None for _ in range(rows)],
            [
                rng.bytes(int(rng.integers(0, 700))) if rng.random() > 0.5 else None
                for _ in range(rows)
            ],
        ]
        batches.append((times.tolist(), published.tolist(), columns))
    return batches


@pytest.mark.parametrize('seed, compression', [(1, 'none'), (2, 'none'), (3, 'zstd')])
def test_bulk_writes_the_bytes_add_message_writes(tmp_path, monkeypatch, seed, compression):
    batches = _batches(seed)
    one_by_one = _write(tmp_path / 'a' / 'bag', batches, monkeypatch, False, compression)
    in_bulk = _write(tmp_path / 'b' / 'bag', batches, monkeypatch, True, compression)
    assert len(one_by_one) > 20 * 4096  # many chunks
    assert in_bulk == one_by_one


def test_blocks_of_fixed_size_messages_take_one_table_and_write_the_same_bytes(
    tmp_path, monkeypatch
):
    rng = np.random.default_rng(4)
    batches = []
    for first in range(0, 3000, 500):  # each batch spans chunk boundaries of the 4 KiB test chunks
        rows = 500
        times = (first + np.arange(rows)) * 10_000_000
        columns = [
            MessageBlock(rng.bytes(rows * 12), 12),
            MessageBlock(rng.bytes(rows * 40), 40),
            MessageBlock(rng.bytes(rows * 7), 7),
        ]
        batches.append((times, times + 5, columns))
    one_by_one = _write(tmp_path / 'a' / 'bag', batches, monkeypatch, False)
    in_bulk = _write(tmp_path / 'b' / 'bag', batches, monkeypatch, True)
    assert in_bulk == one_by_one


@pytest.mark.parametrize('scene', ['default', 'estimator', 'dzhanibekov'])
def test_scene_bags_are_byte_identical_either_way(tmp_path, monkeypatch, scene):
    files = []
    for bulk_on in (False, True):
        monkeypatch.setattr(bag_writer, 'BULK_MESSAGES', 64 if bulk_on else 10**12)
        out = tmp_path / str(bulk_on) / scene
        write_scene_bag(load_scene(scene), out, 30.0, 100.0)
        files.append((out / f'{scene}_0.mcap').read_bytes())
        shutil.rmtree(out.parent) if bulk_on else None
    assert files[0] == files[1]


@pytest.mark.parametrize('scene', ['estimator', 'dzhanibekov'])
def test_scene_bags_do_not_depend_on_how_the_blocks_are_cut(tmp_path, monkeypatch, scene):
    """
    A scene's bag is the same with blocks of one sample throughout and blocks as large as allowed.

    The blocks adapt to the machine's speed (one sample at first, doubling while fast), so a bag
    must not depend on them.
    """
    from torquefree_ros.bag import offline

    files = []
    # always too slow: blocks stay at one sample; never: they grow to the limit
    for seconds in (0.0, 1e9):
        monkeypatch.setattr(offline, 'BLOCK_SECONDS', seconds)
        out = tmp_path / str(seconds) / scene
        write_scene_bag(load_scene(scene), out, 5.0, 100.0)
        files.append((out / f'{scene}_0.mcap').read_bytes())
    assert files[0] == files[1]
