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
Writes rosbag2 (Jazzy) bags with MCAP storage, as ``rosbag2_storage_mcap`` does.

A bag is a directory ``NAME/`` with ``NAME_0.mcap`` and ``metadata.yaml``. The MCAP file has
profile ``ros2``; one ``ros2msg`` schema per type with the full definition (``definitions``); one
``cdr`` channel per topic with the metadata ``offered_qos_profiles`` (YAML) and
``topic_type_hash``; chunks, uncompressed unless asked (``zstd``), with message indexes, statistics
and summary; and, at close, the ``rosbag2`` metadata record carrying the same mapping as
``metadata.yaml``.

Crash safety: a chunk is written out (and the file flushed) when it reaches ``chunk_bytes`` or when
it has been open ``chunk_seconds`` of wall time, so a killed recorder loses at most that much.
:func:`~torquefree_ros.bag.reader.reindex` makes such a file complete again (``torquefree_bag
--reindex``).
"""

from __future__ import annotations

import os
from pathlib import Path
import shutil
import time
from typing import NamedTuple

from mcap.writer import CompressionType, Writer
import numpy as np

from . import bulk
from .definitions import DefinitionError, message_definition, MessageDefinition
from .files import BagError, mcap_file_name, prepare_bag_directory, write_atomically
from .metadata import BagMetadata, dump, METADATA_FILE, metadata_file_text, TopicRecord
from .qos import BagQos
from .reader import BagReader
from ..version import __version__

CHUNK_BYTES = 1024 * 1024
# a batch of at least this many messages goes in through ``bulk`` (numpy); fewer, one by one
BULK_MESSAGES = 64
CHUNK_SECONDS = 1.0
COMPRESSIONS = {'none': CompressionType.NONE, 'zstd': CompressionType.ZSTD}
LIBRARY = f'torquefree_ros {__version__} (python mcap writer, rosbag2_storage_mcap layout)'


class BagWriter:
    """
    A rosbag2 MCAP bag being written; a context manager that closes the bag however the block ends.

    Not thread-safe: write and close from one thread at a time.
    """

    def __init__(
        self,
        path,
        *,
        overwrite: bool = False,
        compression: str = 'none',
        chunk_bytes: int = CHUNK_BYTES,
        chunk_seconds: float = CHUNK_SECONDS,
        custom_data: dict[str, str] | None = None,
        file_name: str | None = None,
    ):
        if compression not in COMPRESSIONS:
            raise BagError(f"compression: '{compression}' is not one of {', '.join(COMPRESSIONS)}")
        if not (chunk_bytes > 0 and chunk_seconds > 0):
            raise BagError('chunk_bytes and chunk_seconds: must be > 0')
        self.path = prepare_bag_directory(path, overwrite)
        self.file_path = self.path / (file_name or mcap_file_name(self.path))
        self._metadata = BagMetadata(self.file_path.name, custom_data=dict(custom_data or {}))
        self._topics: dict[str, int] = {}
        self._records: dict[int, TopicRecord] = {}
        self._schemas: dict[str, int] = {}
        self._chunk_seconds = chunk_seconds
        self._chunk_opened: float | None = None
        self._failure: str | None = None
        self._closed = False
        try:
            self._stream = open(self.file_path, 'xb')
            # the data section CRC (rosbag2's `enableDataCRC`) also covers the message indexes
            # between the chunks, which no chunk CRC does:
            # reindex can then tell that nothing was changed
            self._mcap = Writer(
                self._stream,
                chunk_size=chunk_bytes,
                compression=COMPRESSIONS[compression],
                enable_data_crcs=True,
            )
            self._mcap.start(profile='ros2', library=LIBRARY)
            self._bulk = bulk.supported(self._mcap)
        except OSError as error:
            raise self._io_error(error) from None

    # -- topics -----------------------------------------------------------------------------------
    def add_topic(
        self,
        name: str,
        type_name: str,
        offered_qos: tuple[BagQos, ...] | list = (),
        definition: MessageDefinition | None = None,
    ) -> int:
        """
        Register a topic with its type and QoS profiles; return the channel id to write with.

        ``name`` is an absolute topic name; ``offered_qos`` the publishers' QoS profiles. Adding a
        topic again returns its channel. ``definition`` defaults to the installed one (copying a
        bag passes the bag's own).
        """
        if not name.startswith('/'):
            raise BagError(
                f"topic '{name}': bag topics are fully qualified names starting with '/'"
            )
        if name in self._topics:
            return self._topics[name]
        try:
            definition = definition or message_definition(type_name)
        except DefinitionError as error:
            raise BagError(f"topic '{name}': {error}") from None
        offered_qos = tuple(offered_qos)
        try:
            schema_id = self._schemas.get(definition.type_name)
            if schema_id is None:
                schema_id = self._mcap.register_schema(
                    definition.type_name, definition.encoding, definition.text.encode('utf-8')
                )
                self._schemas[definition.type_name] = schema_id
            qos_text = dump([qos.to_yaml() for qos in offered_qos]).rstrip('\n')
            channel_id = self._mcap.register_channel(
                name,
                'cdr',
                schema_id,
                {'offered_qos_profiles': qos_text, 'topic_type_hash': definition.type_hash},
            )
        except OSError as error:
            raise self._io_error(error) from None
        self._topics[name] = channel_id
        record = TopicRecord(name, definition.type_name, offered_qos, definition.type_hash)
        self._records[channel_id] = record
        self._metadata.topics.append(record)
        return channel_id

    # -- messages ---------------------------------------------------------------------------------
    def write(
        self, channel_id: int, log_time_ns: int, data: bytes, publish_time_ns: int | None = None
    ) -> None:
        """Write one serialized (CDR) message; ``publish_time`` defaults to ``log_time``."""
        self.write_rows(
            (channel_id,),
            (log_time_ns,),
            ((data,),),
            None if publish_time_ns is None else (publish_time_ns,),
        )

    def write_rows(self, channel_ids, log_times_ns, columns, publish_times_ns=None) -> None:
        """
        Write rows of messages: the messages of one sample stay together and in time order.

        Row ``i`` writes ``columns[j][i]`` on ``channel_ids[j]`` for every ``j`` (none where it is
        None), all with ``log_times_ns[i]``.
        """
        self._check_open()
        rows = len(log_times_ns)
        if not rows:
            return
        for channel_id, payloads in zip(channel_ids, columns):
            if channel_id not in self._records:
                raise BagError(
                    f"bag '{self.path}': write on unknown channel {channel_id} (add_topic first)"
                )
            if len(payloads) != rows:
                raise BagError(
                    f"bag '{self.path}': channel {channel_id}: "
                    f'{len(payloads)} messages for {rows} times'
                )
        try:
            if self._bulk and rows * len(columns) >= BULK_MESSAGES:
                times = np.asarray(log_times_ns, dtype=np.int64)
                bulk.add_rows(self._mcap, channel_ids, times, columns, publish_times_ns)
                first, last = int(times.min()), int(times.max())
            else:  # a few messages (the node's recorder, a sample at a time): one by one
                times = [int(t) for t in log_times_ns]
                published = (
                    times if publish_times_ns is None else [int(t) for t in publish_times_ns]
                )
                add = self._mcap.add_message
                for i, log_time in enumerate(times):
                    for channel_id, payloads in zip(channel_ids, columns):
                        if payloads[i] is not None:
                            add(channel_id, log_time, payloads[i], published[i])
                first, last = min(times), max(times)
        except OSError as error:
            raise self._io_error(error) from None
        for channel_id, payloads in zip(channel_ids, columns):
            self._records[channel_id].message_count += rows - payloads.count(None)
        metadata = self._metadata
        metadata.first_time_ns = (
            first if metadata.first_time_ns is None else min(first, metadata.first_time_ns)
        )
        metadata.last_time_ns = (
            last if metadata.last_time_ns is None else max(last, metadata.last_time_ns)
        )
        now = time.monotonic()
        if self._chunk_opened is None:
            self._chunk_opened = now
        elif now - self._chunk_opened >= self._chunk_seconds:
            self.flush()

    def flush(self) -> None:
        """Write out the open chunk and flush the file (readable after a crash from here on)."""
        self._check_open()
        try:
            self._mcap.flush()
        except OSError as error:
            raise self._io_error(error) from None
        self._chunk_opened = None

    def flush_if_due(self) -> None:
        """
        Write out the open chunk if it has been open ``chunk_seconds``.

        Call it from a timer when messages are sparse.
        """
        if (
            self._chunk_opened is not None
            and time.monotonic() - self._chunk_opened >= self._chunk_seconds
        ):
            self.flush()

    @property
    def message_count(self) -> int:
        return self._metadata.message_count

    @property
    def metadata(self) -> BagMetadata:
        return self._metadata

    # -- closing ----------------------------------------------------------------------------------
    def close(self) -> None:
        """
        Finish the MCAP file (rosbag2 record, summary, footer) and write ``metadata.yaml``.

        After a write error, make what is in the file a complete bag again (when the disk allows).
        """
        if self._closed:
            return
        self._closed = True
        if self._failure is None:
            try:
                self._mcap.flush()
                self._mcap.add_metadata(
                    'rosbag2', {'serialized_metadata': dump(self._metadata.to_yaml()).rstrip('\n')}
                )
                self._mcap.finish()
                self._stream.close()
            except OSError as error:
                self._failure = self._io_error(error).args[0]
            else:
                try:
                    write_atomically(self.path / METADATA_FILE, metadata_file_text(self._metadata))
                except OSError as error:  # the .mcap is whole; only the small YAML file is missing
                    raise BagError(
                        f"bag '{self.path}': '{self.file_path.name}' is complete, "
                        f'but {METADATA_FILE} could not be written ({error.strerror or error}); '
                        f'{_REPAIR.format(self.path)}'
                    ) from None
                return
        try:
            self._stream.close()
        except OSError:
            pass  # the buffered tail is lost; the chunks already in the file stay readable
        try:
            reindex(self.path)
        except (BagError, OSError) as error:
            # e.g. no room for the rebuilt copy on the same full disk
            detail = (
                error.strerror if isinstance(error, OSError) and error.strerror else str(error)
            )
            raise BagError(
                f'{self._failure}; the bag could not be completed now ({detail}): '
                f'{_REPAIR.format(self.path)}'
            ) from None
        raise BagError(self._failure)

    def __enter__(self) -> 'BagWriter':
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
            return
        try:
            self.close()
        except BagError:
            pass  # the original error is the one to report

    # -- helpers ----------------------------------------------------------------------------------
    def _check_open(self) -> None:
        if self._failure is not None:
            raise BagError(self._failure)
        if self._closed:
            raise BagError(f"bag '{self.path}': already closed")

    def _io_error(self, error: OSError) -> BagError:
        reason = error.strerror or str(error)
        self._failure = (
            f"bag '{self.path}': cannot write '{self.file_path.name}': {reason}; the chunks "
            f'written before stay readable, the last open chunk is lost'
        )
        return BagError(self._failure)


_REPAIR = 'free some space, then run `torquefree_bag --reindex {}` to make it a complete bag'


class Reindexed(NamedTuple):
    metadata: BagMetadata
    damage: str  # where the file was damaged and what was lost; "" when nothing was
    repaired: str = ''  # damage that lost no message, now repaired; "" when there was none


def reindex(path) -> Reindexed:
    """
    Make a bag whose recorder died or whose file was damaged complete again.

    A recorder that died leaves no summary, maybe a cut-off chunk. The readable messages are
    copied, with their schemas, QoS and times, into a complete MCAP file that replaces the old one,
    and ``metadata.yaml`` is written. A complete, undamaged bag (every CRC is checked) only gets
    ``metadata.yaml``.
    """
    bag = Path(path)
    reader = BagReader(bag)
    damage = ''
    repaired = reader.repairable
    if reader.complete:
        try:
            for _ in reader.messages():
                pass
        except BagError as error:
            damage = str(error)
        if not damage:
            repaired = reader.check_data_section()
    if reader.complete and not damage and not repaired:
        metadata = BagMetadata(reader.file_path.name)
        for topic in reader.topics:
            metadata.topics.append(
                TopicRecord(
                    topic.name,
                    topic.type_name,
                    topic.offered_qos_profiles,
                    topic.type_description_hash,
                    message_count=topic.message_count,
                )
            )
        if reader.span_ns is not None:
            metadata.first_time_ns, metadata.last_time_ns = reader.span_ns
        write_atomically(bag / METADATA_FILE, metadata_file_text(metadata))
        return Reindexed(metadata, '')
    if damage:
        reader = BagReader(bag, scan=True)
    if reader.file_path.parent != bag:
        raise BagError(f"bag '{bag}': give the bag directory to reindex, not the file")
    staging = bag.parent / f'.{bag.name}.reindex'
    try:
        with BagWriter(staging, overwrite=True, file_name=reader.file_path.name) as writer:
            channels = {
                topic.name: writer.add_topic(
                    topic.name, topic.type_name, topic.offered_qos_profiles, topic.definition
                )
                for topic in reader.topics
            }
            for message in reader.messages():
                writer.write(
                    channels[message.topic],
                    message.log_time_ns,
                    message.data,
                    message.publish_time_ns,
                )
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)  # the original file is untouched
        raise
    os.replace(staging / reader.file_path.name, reader.file_path)
    os.replace(staging / METADATA_FILE, bag / METADATA_FILE)
    staging.rmdir()
    if reader.damage:
        damage = (
            f'damaged ({reader.damage}): {writer.metadata.message_count} messages before it '
            'were kept, everything after it is lost'
        )
    return Reindexed(writer.metadata, damage, '' if damage else repaired or reader.repairable)
