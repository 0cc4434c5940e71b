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

from mcap.writer import CompressionType, Writer
import numpy as np

from . import bulk
from .definitions import DefinitionError, message_definition, MessageDefinition
from .metadata import BagMetadata, dump, METADATA_FILE, metadata_file_text, TopicRecord
from .qos import BagQos
from .. import __version__

CHUNK_BYTES = 1024 * 1024
# a batch of at least this many messages goes in through ``bulk`` (numpy); fewer, one by one
BULK_MESSAGES = 64
CHUNK_SECONDS = 1.0
COMPRESSIONS = {'none': CompressionType.NONE, 'zstd': CompressionType.ZSTD}
LIBRARY = f'torquefree_ros {__version__} (python mcap writer, rosbag2_storage_mcap layout)'


class BagError(RuntimeError):
    """A bag that cannot be created, written or read; the message names the path and the reason."""


def mcap_file_name(bag_dir: Path) -> str:
    """rosbag2's name for the first (only) storage file of a bag directory."""
    return f'{bag_dir.name}_0.mcap'


def prepare_bag_directory(path, overwrite: bool = False) -> Path:
    """
    Check that a bag can be created at ``path`` and create its (empty) directory.

    An existing path is refused unless ``overwrite``; even then only a bag directory
    (``metadata.yaml`` and ``.mcap`` files) is replaced, never another directory or a file.
    """
    path = Path(path)
    if not path.name or path.name in ('.', '..'):
        raise BagError(f"bag '{path}': give a directory name for the bag")
    try:
        exists = path.exists() or path.is_symlink()
    except OSError as error:  # a name too long for the file system
        raise BagError(
            f"bag '{str(path)[:120]}…': cannot be created: {error.strerror or error}"
        ) from None
    if exists:
        if not overwrite:
            raise BagError(
                f"bag '{path}': already exists; choose another name or overwrite it explicitly"
            )
        if not _is_bag_directory(path):
            raise BagError(
                f"bag '{path}': exists and is not a bag directory (only metadata.yaml and .mcap "
                f'files), so it is not overwritten'
            )
        shutil.rmtree(path)
    try:
        path.mkdir(parents=True)
    except OSError as error:
        raise BagError(
            f"bag '{path}': cannot create the directory: {error.strerror or error}"
        ) from None
    if not os.access(path, os.W_OK | os.X_OK):
        path.rmdir()
        raise BagError(f"bag '{path}': the directory is not writable")
    return path


def _is_bag_directory(path: Path) -> bool:
    if not path.is_dir() or path.is_symlink():
        return False
    entries = list(path.iterdir())
    return bool(entries) and all(
        entry.is_file() and (entry.name == METADATA_FILE or entry.suffix == '.mcap')
        for entry in entries
    )


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
        from .reader import reindex  # noqa: PLC0415 - only on this failure path

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


def write_atomically(path: Path, text: str) -> None:
    temporary = path.with_name(path.name + '.tmp')
    temporary.write_text(text, encoding='utf-8')
    os.replace(temporary, path)
