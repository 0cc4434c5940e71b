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
Reads rosbag2 MCAP bags (ours and others'), also a file cut short by a crash.

A complete file is read through its summary and indexes. A file without a footer (a killed
recorder, a full disk) is scanned record by record up to its last complete chunk; :func:`reindex`
then copies what is readable into a complete file and writes its ``metadata.yaml``.

Every CRC the file carries is checked: each chunk's as its messages are read, the summary's when
the file is opened (a summary that does not match is not trusted: the file is scanned instead), and
the data section's (which covers the message indexes, the header and the metadata records between
the chunks) by :func:`reindex`.
"""

from __future__ import annotations

from dataclasses import dataclass
import os
from pathlib import Path
import struct
from typing import Iterator, NamedTuple
import zlib

from mcap.exceptions import EndOfFile, McapError
from mcap.reader import SeekingReader
from mcap.records import Channel, DataEnd, Message, Schema
from mcap.stream_reader import CRCValidationError, StreamReader
from mcap.writer import MCAP0_MAGIC

from .definitions import MessageDefinition
from .files import BagError
from .metadata import METADATA_FILE
from .qos import BagQos
from ..files.safe_files import check_regular_file, clip, load_yaml, read_regular_file


@dataclass
class BagTopic:
    name: str
    type_name: str
    offered_qos_profiles: tuple[BagQos, ...]
    type_description_hash: str
    message_count: int
    definition: MessageDefinition  # as stored in the bag's schema


class BagMessage(NamedTuple):
    topic: str
    log_time_ns: int
    publish_time_ns: int
    data: bytes


def _qos_profiles(channel: Channel, where: str) -> tuple[BagQos, ...]:
    text = channel.metadata.get('offered_qos_profiles', '')
    if not text:
        return ()
    try:
        return tuple(
            BagQos.from_yaml(item) for item in (load_yaml(text, f"topic '{channel.topic}'") or [])
        )
    except (ValueError, KeyError, TypeError, AttributeError) as error:
        raise BagError(
            f"{where}: topic '{channel.topic}': unreadable offered_qos_profiles: {error}"
        ) from None


# rosbag2's metadata.yaml of a bag with thousands of topics and files still fits
MAX_METADATA_BYTES = 16 << 20
# OSError: a damaged offset seeks before the file's start
_READ_ERRORS = (
    McapError,
    ValueError,
    EOFError,
    struct.error,
    KeyError,
    IndexError,
    TypeError,
    UnicodeDecodeError,
    OSError,
)
_MAGIC_BYTES = 8
# opcode, record length, summary_start, summary_offset_start, summary_crc
_FOOTER = struct.Struct('<BQQQI')
_DATA_END = struct.Struct('<BQI')  # opcode, record length, data_section_crc
_CRC_BLOCK = 1 << 20

_OUTSIDE_DAMAGE = 'bytes between its chunks are damaged (the data section CRC does not match)'


class _BoundedReads:
    """
    A bag file whose reads never ask for more than is left in it.

    A damaged length field then reads short (mcap says EndOfFile) instead of allocating the
    gigabytes it claims.
    """

    def __init__(self, file):
        self._file = file
        self.size = os.fstat(file.fileno()).st_size
        self._position = file.tell()

    def read(self, length: int = -1) -> bytes:
        left = max(self.size - self._position, 0)
        data = self._file.read(left if length is None or length < 0 else min(length, left))
        self._position += len(data)
        return data

    def seek(self, offset: int, whence: int = os.SEEK_SET) -> int:
        self._position = self._file.seek(offset, whence)
        return self._position

    def tell(self) -> int:
        return self._position

    def seekable(self) -> bool:
        return True

    def __enter__(self) -> '_BoundedReads':
        return self

    def __exit__(self, *_) -> None:
        self._file.close()

    def crc32(self, start: int, end: int) -> int:
        self.seek(start)
        crc = 0
        while self._position < end:
            block = self.read(min(_CRC_BLOCK, end - self._position))
            if not block:
                break
            crc = zlib.crc32(block, crc)
        return crc

    def footer(self) -> tuple[int, int] | None:
        """
        Return (summary_start, summary_crc) of the footer and magic that end the file.

        None if the file does not end with them.
        """
        if self.size < 2 * _MAGIC_BYTES + _FOOTER.size:
            return None
        self.seek(self.size - _MAGIC_BYTES - _FOOTER.size)
        opcode, length, summary_start, _, summary_crc = _FOOTER.unpack(self.read(_FOOTER.size))
        if (opcode, length) != (0x02, _FOOTER.size - 9) or self.read(_MAGIC_BYTES) != MCAP0_MAGIC:
            return None
        return summary_start, summary_crc


def _open(path: Path) -> _BoundedReads:
    return _BoundedReads(open(path, 'rb'))


def bag_information(path) -> dict:
    """
    Read the ``rosbag2_bagfile_information`` mapping of a bag directory's ``metadata.yaml``.

    It is read with bounds (a regular file of at most 16 MiB, bounded YAML: ``core.safe_files``).
    """
    metadata = Path(path) / METADATA_FILE
    try:
        text = read_regular_file(metadata, MAX_METADATA_BYTES).decode('utf-8')
        information = load_yaml(text, str(metadata))['rosbag2_bagfile_information']
        if not isinstance(information, dict):
            raise TypeError('rosbag2_bagfile_information is not a mapping')
        return information
    except OSError as error:
        raise BagError(
            f"bag '{path}': cannot read {METADATA_FILE}: {error.strerror or error}"
        ) from None
    except UnicodeDecodeError as error:
        raise BagError(
            f"bag '{path}': unreadable {METADATA_FILE}: not UTF-8 text (byte {error.start})"
        ) from None
    except (ValueError, KeyError, TypeError) as error:
        raise BagError(f"bag '{path}': unreadable {METADATA_FILE}: {clip(str(error))}") from None


def storage_file(path) -> Path:
    """
    Return the ``.mcap`` file of a bag directory, or the file itself.

    A directory's file is the one its metadata names, else the only one.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        _check_regular(path, path)
        return path
    if not path.is_dir():
        raise BagError(f"bag '{path}': no such bag directory or file")
    metadata = path / METADATA_FILE
    if metadata.is_file():
        info = bag_information(path)
        try:
            files = info['relative_file_paths']
            storage = info['storage_identifier']
        except (KeyError, TypeError) as error:
            raise BagError(f"bag '{path}': unreadable {METADATA_FILE}: {error}") from None
        if storage != 'mcap':
            raise BagError(f"bag '{path}': storage '{storage}' is not supported (only mcap)")
        if not isinstance(files, list) or len(files) != 1 or not isinstance(files[0], str):
            raise BagError(
                f"bag '{path}': {clip(repr(files))} as storage files; one file name is supported"
            )
        file = path / Path(files[0]).name
        _check_regular(path, file)
        return file
    candidates = sorted(path.glob('*.mcap'))
    if len(candidates) != 1:
        raise BagError(f"bag '{path}': expected one .mcap file, found {len(candidates)}")
    _check_regular(path, candidates[0])
    return candidates[0]


def _check_regular(bag: Path, file: Path) -> None:
    """Refuse special files before anyone opens them (a FIFO would block the reader for good)."""
    try:
        check_regular_file(file)
    except OSError as error:
        raise BagError(f"bag '{bag}': cannot read '{file}': {error.strerror or error}") from None
    except ValueError as error:
        raise BagError(f"bag '{bag}': {error}") from None


class BagReader:
    """Topics and messages of a bag; ``complete`` is False for a file that lost its end."""

    def __init__(self, path, scan: bool = False):
        """
        Open a bag (a directory or its ``.mcap`` file) and read its topics.

        ``scan``: read record by record even if the file has its summary (to recover a damaged
        one).
        """
        self.path = Path(path)
        self.file_path = storage_file(self.path)
        self._topics: dict[int, BagTopic] = {}
        self.span_ns: tuple[int, int] | None = None  # first and last log time
        # where and why a scan of a file without its end stopped before the file's end
        # ("" if it did not)
        self.damage = ''
        # damage that lost no message (the summary, the bytes between the chunks);
        # reindex repairs it
        self.repairable = ''
        try:
            with _open(self.file_path) as stream:
                self._check_header(stream)
                self.complete = not scan and self._read_summary(stream)
                if not self.complete:
                    stream.seek(0)
                    for channel, message in self._scan(stream):
                        self._topics[channel.id].message_count += 1
                        self._extend_span(message.log_time)
        except OSError as error:
            raise BagError(
                f"bag '{self.path}': cannot read '{self.file_path}': {error.strerror or error}"
            ) from None

    @property
    def topics(self) -> list[BagTopic]:
        return list(self._topics.values())

    @property
    def message_count(self) -> int:
        return sum(topic.message_count for topic in self._topics.values())

    def messages(self, topics=None) -> Iterator[BagMessage]:
        """
        Yield the messages, optionally of some topics, in log-time order.

        A file without its end is read in file order. Damage found on the way (a CRC mismatch, a
        broken record) raises ``BagError`` saying how many messages came before it.
        """
        wanted = None if topics is None else set(topics)
        count = 0
        with _open(self.file_path) as stream:
            if self.complete:
                found = SeekingReader(stream, validate_crcs=True).iter_messages(
                    topics=wanted, log_time_order=True
                )
                pairs = ((channel, message) for _, channel, message in found)
            else:
                pairs = self._scan(stream)
            try:
                for channel, message in pairs:
                    if wanted is None or channel.topic in wanted:
                        count += 1
                        yield BagMessage(
                            channel.topic, message.log_time, message.publish_time, message.data
                        )
            except _READ_ERRORS as error:
                raise BagError(
                    f"bag '{self.path}': damaged after {count} messages "
                    f'({type(error).__name__}: {clip(str(error))}); the rest is lost. '
                    f'`torquefree_bag --reindex {self.path}` keeps the readable part'
                ) from None

    def check_data_section(self) -> str:
        """
        Check the data section CRC of a complete file; return what did not match, or "".

        The CRC also covers the bytes no chunk CRC does (message indexes, header, metadata
        records); "" also when the writer left it 0. Reads the file once.
        """
        with _open(self.file_path) as stream:
            footer = stream.footer()
            if footer is None:
                return ''
            data_end = (footer[0] or stream.size - _MAGIC_BYTES - _FOOTER.size) - _DATA_END.size
            if data_end < _MAGIC_BYTES:
                return ''
            stream.seek(data_end)
            opcode, length, crc = _DATA_END.unpack(stream.read(_DATA_END.size))
            if (opcode, length) != (0x0F, 4):
                return 'the record before its summary is not a whole DataEnd record'
            if crc == 0 or stream.crc32(0, data_end) == crc:
                return ''
        return _OUTSIDE_DAMAGE

    # -- reading ----------------------------------------------------------------------------------
    def _check_header(self, stream) -> None:
        try:
            next(iter(StreamReader(stream, skip_magic=False).records))
        except (StopIteration, *_READ_ERRORS) as error:
            detail = clip(str(error), 100) or f'{type(error).__name__}: it ends inside its header'
            raise BagError(
                f"bag '{self.path}': '{self.file_path.name}' is not an MCAP file ({detail})"
            ) from None
        stream.seek(0)

    def _read_summary(self, stream: _BoundedReads) -> bool:
        try:
            footer = stream.footer()
            if footer is None:
                return False  # cut off, or its end is damaged: scanned
            if footer[0] and footer[1]:
                summary_start, summary_crc = footer
                if stream.crc32(summary_start, stream.size - _MAGIC_BYTES - 4) != summary_crc:
                    self.repairable = 'its summary is damaged (CRC mismatch)'
                    return False
            stream.seek(0)
            summary = SeekingReader(stream, validate_crcs=True).get_summary()
        except _READ_ERRORS:
            return False
        if summary is None or summary.statistics is None:
            return False
        counts = summary.statistics.channel_message_counts
        for channel_id, channel in summary.channels.items():
            self._add_topic(
                channel, summary.schemas.get(channel.schema_id), counts.get(channel_id, 0)
            )
        stats = summary.statistics
        if stats.message_count:
            self.span_ns = (stats.message_start_time, stats.message_end_time)
        return True

    def _add_topic(self, channel: Channel, schema: Schema | None, count: int) -> None:
        type_name = schema.name if schema else ''
        type_hash = channel.metadata.get('topic_type_hash', '')
        definition = MessageDefinition(
            type_name,
            schema.encoding if schema else '',
            schema.data.decode('utf-8', 'replace') if schema else '',
            type_hash,
        )
        self._topics[channel.id] = BagTopic(
            channel.topic,
            type_name,
            _qos_profiles(channel, f"bag '{self.path}'"),
            type_hash,
            count,
            definition,
        )

    def _extend_span(self, log_time: int) -> None:
        span = self.span_ns
        self.span_ns = (
            (log_time, log_time)
            if span is None
            else (min(span[0], log_time), max(span[1], log_time))
        )

    def _scan(self, stream) -> Iterator[tuple[Channel, Message]]:
        """Messages up to the first record that is cut off or damaged (a file without its end)."""
        schemas: dict[int, Schema] = {}
        channels: dict[int, Channel] = {}
        try:
            for record in StreamReader(stream, validate_crcs=True).records:
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = record
                    if record.id not in self._topics:
                        self._add_topic(record, schemas.get(record.schema_id), 0)
                elif isinstance(record, Message) and record.channel_id in channels:
                    yield channels[record.channel_id], record
        except (EOFError, EndOfFile):
            return  # cut off: the end of what was written completely
        except CRCValidationError as error:
            if isinstance(error.record, DataEnd):  # every chunk before it was whole
                self.repairable = _OUTSIDE_DAMAGE
            else:
                self.damage = (
                    f'CRCValidationError at byte {stream.tell():,}: {clip(str(error), 100)}'
                )
        except _READ_ERRORS as error:
            # a damaged record (bytes changed, not only cut off): what follows it is lost
            self.damage = (
                f'{type(error).__name__} at byte {stream.tell():,}: {clip(str(error), 100)}'
            )
