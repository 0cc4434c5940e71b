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
Many messages into an ``mcap.writer.Writer`` at once, byte for byte what ``add_message`` writes.

The bytes are what ``add_message`` one by one writes, at a fraction of its per-message Python
cost.

``add_message`` builds a record object, packs five fields and updates the chunk's index for every
message (about 5 µs each). Here the message records of a whole block are assembled with numpy
(headers in one array, payloads joined once), cut into chunks exactly where ``add_message`` would
cut them (right after the message that takes the chunk past ``chunk_size``), and their message
indexes are written from arrays. Chunks, chunk indexes, statistics, CRCs and the summary stay the
library's: the block goes into the writer's own chunk builder, so this relies on the writer's
private state (mcap is pinned in requirements.lock); :func:`supported` tells whether it is there,
and a test compares whole files written both ways.
"""

from __future__ import annotations

import itertools
import operator

from mcap.records import MessageIndex
from mcap.writer import Writer
import numpy as np

from .cdr import MessageBlock

MESSAGE_OPCODE, MESSAGE_INDEX_OPCODE = 0x05, 0x07
# a Message record before its data:
# opcode, record length, channel id, sequence, log and publish time
_HEADER = np.dtype(
    [
        ('opcode', 'u1'),
        ('length', '<u8'),
        ('channel', '<u2'),
        ('sequence', '<u4'),
        ('log_time', '<u8'),
        ('publish_time', '<u8'),
    ]
)
_HEADER_SIZE = _HEADER.itemsize  # 31, packed


def supported(writer: Writer) -> bool:
    return all(
        hasattr(writer, name)
        for name in (
            '_Writer__chunk_builder',
            '_Writer__statistics',
            '_Writer__chunk_size',
            '_Writer__finalize_chunk',
        )
    )


class _ArrayIndex:
    """
    A chunk's message index of one channel, kept as arrays.

    ``records`` still takes the tuples ``add_message`` appends, so both paths can share a chunk.
    """

    def __init__(self, channel_id: int, records=()):
        self.channel_id = channel_id
        self.records = list(records)  # (log_time, offset) from add_message, after the arrays
        self._arrays: list[np.ndarray] = []

    def extend(self, log_times: np.ndarray, offsets: np.ndarray) -> None:
        if self.records:  # keep the order the messages were written in
            self._arrays.append(np.array(self.records, dtype='<u8').reshape(-1, 2))
            self.records = []
        self._arrays.append(np.column_stack([log_times, offsets]).astype('<u8'))

    def write(self, stream) -> None:
        parts = self._arrays + (
            [np.array(self.records, dtype='<u8').reshape(-1, 2)] if self.records else []
        )
        entries = np.concatenate(parts).tobytes() if parts else b''
        head = np.zeros(
            1, dtype=[('opcode', 'u1'), ('length', '<u8'), ('channel', '<u2'), ('size', '<u4')]
        )
        head['opcode'], head['length'] = MESSAGE_INDEX_OPCODE, 6 + len(entries)
        head['channel'], head['size'] = self.channel_id, len(entries)
        stream.write(head.tobytes() + entries)


def add_rows(writer: Writer, channel_ids, log_times, columns, publish_times=None) -> None:
    """
    Add a block of rows of messages to the writer, as ``add_message`` would one by one.

    Row ``i`` adds ``columns[j][i]`` on ``channel_ids[j]`` (none where it is None), in row order.
    """
    log_times = np.asarray(log_times, dtype=np.int64)
    published = log_times if publish_times is None else np.asarray(publish_times, dtype=np.int64)
    if all(
        isinstance(column, MessageBlock) and len(column) == log_times.size for column in columns
    ):
        records, lengths, channels, times = _fixed_rows(channel_ids, log_times, published, columns)
    else:
        records, lengths, channels, times = _any_rows(channel_ids, log_times, published, columns)
    if not lengths.size:
        return
    ends = np.cumsum(lengths)
    _into_chunks(writer, records, ends - lengths, ends, channels, times)
    statistics = writer._Writer__statistics
    if statistics.message_count == 0:
        statistics.message_start_time = int(times.min())
    else:
        statistics.message_start_time = min(statistics.message_start_time, int(times.min()))
    statistics.message_end_time = max(statistics.message_end_time, int(times.max()))
    statistics.message_count += lengths.size
    for channel, n in zip(*np.unique(channels, return_counts=True)):
        statistics.channel_message_counts[int(channel)] += int(n)


def _headers(channels, times, published, sizes) -> np.ndarray:
    headers = np.zeros(np.shape(times), dtype=_HEADER)
    headers['opcode'] = MESSAGE_OPCODE
    headers['length'] = _HEADER_SIZE - 9 + sizes
    headers['channel'], headers['log_time'], headers['publish_time'] = channels, times, published
    return np.frombuffer(headers.tobytes(), dtype=np.uint8).reshape(-1, _HEADER_SIZE)


def _fixed_rows(channel_ids, log_times, published, columns):
    """
    Assemble the records when every column is a MessageBlock with a message on every row.

    One table, a row per sample, no per-message Python.
    """
    rows = log_times.size
    widths = [_HEADER_SIZE + column.size for column in columns]
    table = np.empty((rows, sum(widths)), dtype=np.uint8)
    at = 0
    for channel, column, width in zip(channel_ids, columns, widths):
        table[:, at: at + _HEADER_SIZE] = _headers(channel, log_times, published, column.size)
        table[:, at + _HEADER_SIZE: at + width] = np.frombuffer(
            column.buffer, dtype=np.uint8
        ).reshape(rows, -1)
        at += width
    lengths = np.tile(np.array(widths, dtype=np.int64), rows)
    channels = np.tile(np.asarray(channel_ids, dtype=np.int64), rows)
    return table.reshape(-1), lengths, channels, np.repeat(log_times, len(columns))


def _any_rows(channel_ids, log_times, published, columns):
    """Assemble the records of messages of any size, with gaps (None)."""
    per_row = len(columns)
    channels = np.tile(np.asarray(channel_ids, dtype=np.int64), log_times.size)
    times, publish = np.repeat(log_times, per_row), np.repeat(published, per_row)
    payloads = list(itertools.chain.from_iterable(zip(*columns)))
    if payloads.count(None):
        present = np.fromiter(
            map(operator.is_not, payloads, itertools.repeat(None)), dtype=bool, count=len(payloads)
        )
        payloads = list(itertools.compress(payloads, present))
        channels, times, publish = channels[present], times[present], publish[present]
    sizes = np.fromiter(map(len, payloads), dtype=np.int64, count=len(payloads))
    lengths = _HEADER_SIZE + sizes
    starts = np.cumsum(lengths) - lengths
    records = np.empty(int(lengths.sum()), dtype=np.uint8)
    is_header = np.zeros(records.size, dtype=bool)
    positions = (starts[:, np.newaxis] + np.arange(_HEADER_SIZE)).ravel()
    is_header[positions] = True
    records[positions] = _headers(channels, times, publish, sizes).ravel()
    records[~is_header] = np.frombuffer(b''.join(payloads), dtype=np.uint8)
    return records, lengths, channels, times


def _into_chunks(writer: Writer, records, starts, ends, channels, times) -> None:
    """
    Append records to the open chunk, finishing chunks where ``add_message`` would.

    A chunk is finished right after the record that takes it past the writer's chunk size
    (``add_message``'s rule).
    """
    builder, chunk_size = writer._Writer__chunk_builder, writer._Writer__chunk_size
    first = 0
    while first < len(starts):
        base = builder.count - int(starts[first])  # chunk offset of a record = base + its start
        over = np.flatnonzero(base + ends[first:] > chunk_size)
        # the last record into this chunk
        last = first + int(over[0]) if over.size else len(starts) - 1
        span = slice(first, last + 1)
        block_times = times[span]
        if builder.num_messages == 0:
            builder.message_start_time = int(block_times.min())
        else:
            builder.message_start_time = min(builder.message_start_time, int(block_times.min()))
        builder.message_end_time = max(builder.message_end_time, int(block_times.max()))
        offsets = base + starts[span]
        span_channels = channels[span]
        _, first_seen = np.unique(span_channels, return_index=True)
        # indexes in order of first message
        for channel in span_channels[np.sort(first_seen)].tolist():
            picked = span_channels == channel
            index = builder.message_indices.get(channel)
            if not isinstance(index, _ArrayIndex):
                index = _ArrayIndex(
                    channel, index.records if isinstance(index, MessageIndex) else ()
                )
                builder.message_indices[channel] = index
            index.extend(block_times[picked], offsets[picked])
        builder.num_messages += last + 1 - first
        builder.record_writer.write(records[int(starts[first]): int(ends[last])].tobytes())
        if over.size:
            writer._Writer__finalize_chunk()
        first = last + 1
