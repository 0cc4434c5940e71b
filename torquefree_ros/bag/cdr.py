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
Vectorised CDR encoding of the simulator's stamped messages, a block of samples at a time.

The layout is what ``rclpy.serialization.serialize_message`` (Fast-CDR, XCDR1 little-endian)
writes: a 4-byte encapsulation header, then ``std_msgs/Header`` (``int32 sec``, ``uint32 nanosec``,
``string frame_id`` as ``uint32`` length including the NUL, the bytes, the NUL), padding to an
8-byte boundary counted from the end of the encapsulation header, then the ``float64`` fields. Our
padding is zero (Fast-CDR leaves it uninitialised). Tests decode both encodings and compare the
values.

numpy only: no ROS import, so the offline bag tools can use it too.
"""

from __future__ import annotations

from collections.abc import Sequence
import operator
import struct

import numpy as np

CDR_LE = b'\x00\x01\x00\x00'
_INT32_MAX = 2**31 - 1
_STAMP_AND_LENGTH = struct.Struct('<iII')  # Header: stamp.sec, stamp.nanosec, len(frame_id) + 1


def _stamp_fields(stamps_ns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if len(stamps_ns) == 1:  # one sample at a time (a closed loop): no ufuncs on one element
        sec, nanosec = divmod(int(stamps_ns[0]), 1_000_000_000)
        if not -_INT32_MAX - 1 <= sec <= _INT32_MAX:
            raise ValueError('stamps: builtin_interfaces/Time seconds must fit in int32')
        return np.array([sec], dtype=np.int64), np.array([nanosec], dtype=np.int64)
    stamps_ns = np.asarray(stamps_ns, dtype=np.int64)
    sec, nanosec = np.divmod(stamps_ns, np.int64(1_000_000_000))
    if stamps_ns.size and (sec.min() < -_INT32_MAX - 1 or sec.max() > _INT32_MAX):
        raise ValueError('stamps: builtin_interfaces/Time seconds must fit in int32')
    return sec, nanosec


class MessageBlock(Sequence):
    """
    Messages of one size in one buffer, as the vectorised encoders make them.

    ``block[i]`` is message ``i``'s bytes (made when asked: the node publishes one at a time),
    while the bag writer takes the whole buffer at once (``bag.bulk``).
    """

    __slots__ = ('buffer', 'size')

    def __init__(self, buffer: bytes, size: int):
        self.buffer, self.size = buffer, size

    def __len__(self) -> int:
        return len(self.buffer) // self.size if self.size else 0

    def __getitem__(self, index):
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        index = operator.index(index)
        count = len(self)
        if index < 0:
            index += count
        if not 0 <= index < count:
            raise IndexError('message index out of range')
        return self.buffer[index * self.size: (index + 1) * self.size]

    def count(self, value) -> int:
        return 0 if value is None else super().count(value)  # never None: no scan for it


def _split(records: np.ndarray) -> MessageBlock:
    return MessageBlock(records.tobytes(), records.dtype.itemsize)


def encode_stamped_doubles(stamps_ns, frame_id: str, values) -> MessageBlock:
    """
    Encode a message per row: a Header (``frame_id``, ``stamps_ns[i]``), then the row's float64s.

    Rows of 3 give ``geometry_msgs/Vector3Stamped``, rows of 4 ``geometry_msgs/QuaternionStamped``
    (``x, y, z, w``).
    """
    values = np.asarray(values, dtype=np.float64)
    frame = _frame_bytes(frame_id, 'frame_id')
    sec, nanosec = _stamp_fields(stamps_ns)
    text_end = 12 + len(frame) + 1  # offsets from the end of the encapsulation header
    data_offset = -(-text_end // 8) * 8
    count, width = values.shape
    if count == 1:  # a closed loop's one sample at a time: packed directly, the same bytes
        padding = bytes(4 + data_offset - (16 + len(frame) + 1))
        message = (
            CDR_LE
            + struct.pack('<iII', int(sec[0]), int(nanosec[0]), len(frame) + 1)
            + frame
            + b'\x00'
            + padding
            + struct.pack(f'<{width}d', *values[0].tolist())
        )
        return MessageBlock(message, len(message))
    record = np.dtype(
        {
            'names': ['encapsulation', 'sec', 'nanosec', 'length', 'frame_id', 'data'],
            'formats': ['V4', '<i4', '<u4', '<u4', f'V{len(frame) + 1}', ('<f8', (width,))],
            'offsets': [0, 4, 8, 12, 16, 4 + data_offset],
            'itemsize': 4 + data_offset + 8 * width,
        }
    )
    records = np.zeros(count, dtype=record)
    records['encapsulation'] = np.void(CDR_LE)
    records['sec'] = sec
    records['nanosec'] = nanosec
    records['length'] = len(frame) + 1
    records['frame_id'] = np.void(frame + b'\x00')
    records['data'] = values
    return _split(records)


def encode_transforms(stamps_ns, frame_id: str, child_frame_id: str, values) -> MessageBlock:
    """
    Encode a ``tf2_msgs/TFMessage`` holding one ``geometry_msgs/TransformStamped`` per row.

    Each holds a sequence length (1), the Header with ``frame_id`` and ``stamps_ns[i]``,
    ``child_frame_id``, then the row's 7 float64s (translation ``x, y, z``, rotation
    ``x, y, z, w``).
    """
    return _encode_header_child_doubles(
        stamps_ns, frame_id, child_frame_id, values, sequence_count=1
    )


def encode_transform_lists(stamps_ns, frame_pairs, values) -> MessageBlock:
    """
    Encode a ``tf2_msgs/TFMessage`` per row holding a ``TransformStamped`` per frame pair.

    ``frame_pairs``: ``(frame_id, child_frame_id)`` of each transform, in order; every transform
    of a message carries ``stamps_ns[i]``; the row holds 7 float64s a transform (translation
    ``x, y, z``, rotation ``x, y, z, w``). With one pair, the bytes of :func:`encode_transforms`.
    """
    values = np.asarray(values, dtype=np.float64)
    count = len(frame_pairs)
    if count == 0 or values.ndim != 2 or values.shape[1] != 7 * count:
        raise ValueError(
            f'transform rows: expected 7 float64s per transform ({count} frame pairs), '
            f'got shape {values.shape}'
        )
    sec, nanosec = _stamp_fields(stamps_ns)
    names, formats, offsets, fills = ['encapsulation', 'count'], ['V4', '<u4'], [0, 4], []
    at = 4  # from the end of the encapsulation header: after the sequence's length
    for index, (frame_id, child_frame_id) in enumerate(frame_pairs):
        frame = _frame_bytes(frame_id, 'frame_id')
        child = _frame_bytes(child_frame_id, 'child_frame_id')
        # each TransformStamped starts on an 8-byte boundary (the previous one ends with doubles)
        child_length_at = -(-(at + 12 + len(frame) + 1) // 4) * 4
        data_at = -(-(child_length_at + 4 + len(child) + 1) // 8) * 8
        fields = (
            ('sec', '<i4', at, sec),
            ('nanosec', '<u4', at + 4, nanosec),
            ('length', '<u4', at + 8, len(frame) + 1),
            ('frame_id', f'V{len(frame) + 1}', at + 12, np.void(frame + b'\x00')),
            ('child_length', '<u4', child_length_at, len(child) + 1),
            ('child', f'V{len(child) + 1}', child_length_at + 4, np.void(child + b'\x00')),
            ('data', ('<f8', (7,)), data_at, values[:, 7 * index: 7 * index + 7]),
        )
        for name, form, offset, fill in fields:
            names.append(f'{name}{index}')
            formats.append(form)
            offsets.append(4 + offset)
            fills.append(fill)
        at = data_at + 56
    record = np.dtype(
        {'names': names, 'formats': formats, 'offsets': offsets, 'itemsize': 4 + at}
    )
    records = np.zeros(values.shape[0], dtype=record)
    records['encapsulation'] = np.void(CDR_LE)
    records['count'] = count
    for name, fill in zip(names[2:], fills):
        records[name] = fill
    return _split(records)


#: nav_msgs/Odometry's float64s after child_frame_id: pose.pose (7), pose.covariance (36),
#: twist.twist (6), twist.covariance (36)
ODOMETRY_DOUBLES = 85
_POSE_AT, _TWIST_AT = 0, 43


def encode_odometry(stamps_ns, frame_id: str, child_frame_id: str, values) -> MessageBlock:
    """
    Encode a ``nav_msgs/Odometry`` per row of 13 float64s.

    A row is ``pose.pose`` (position ``x, y, z``, orientation ``x, y, z, w``), then ``twist.twist``
    (linear, angular); both covariances are zero (exact values).
    """
    values = np.asarray(values, dtype=np.float64)
    if values.ndim != 2 or values.shape[1] != 13:
        raise ValueError(
            'odometry rows: expected 13 float64s per row (pose 7, twist 6), '
            f'got shape {values.shape}'
        )
    doubles = np.zeros((values.shape[0], ODOMETRY_DOUBLES))
    doubles[:, _POSE_AT: _POSE_AT + 7] = values[:, 0:7]
    doubles[:, _TWIST_AT: _TWIST_AT + 6] = values[:, 7:13]
    return _encode_header_child_doubles(stamps_ns, frame_id, child_frame_id, doubles)


def _encode_header_child_doubles(
    stamps_ns, frame_id: str, child_frame_id: str, values, sequence_count: int | None = None
) -> MessageBlock:
    """
    Encode a message per row with a Header, a ``child_frame_id`` string and the row's float64s.

    The layout: [a sequence length], a Header with ``frame_id`` and the stamp, a ``child_frame_id``
    string, then the row's float64s: TransformStamped in a TFMessage, Odometry.
    """
    values = np.asarray(values, dtype=np.float64)
    frame, child = (
        _frame_bytes(frame_id, 'frame_id'),
        _frame_bytes(child_frame_id, 'child_frame_id'),
    )
    sec, nanosec = _stamp_fields(stamps_ns)
    width = values.shape[1]
    # offsets from the end of the encapsulation header: [count], sec, nanosec, length, frame_id,
    # then child_frame_id's length on a 4-byte boundary, its bytes, the doubles on an 8-byte one
    header_at = 0 if sequence_count is None else 4
    child_length_at = -(-(header_at + 12 + len(frame) + 1) // 4) * 4
    data_at = -(-(child_length_at + 4 + len(child) + 1) // 8) * 8
    names = [
        'encapsulation',
        'sec',
        'nanosec',
        'length',
        'frame_id',
        'child_length',
        'child',
        'data',
    ]
    formats = [
        'V4',
        '<i4',
        '<u4',
        '<u4',
        f'V{len(frame) + 1}',
        '<u4',
        f'V{len(child) + 1}',
        ('<f8', (width,)),
    ]
    offsets = [
        0,
        4 + header_at,
        8 + header_at,
        12 + header_at,
        16 + header_at,
        4 + child_length_at,
        8 + child_length_at,
        4 + data_at,
    ]
    if sequence_count is not None:
        names, formats, offsets = names + ['count'], formats + ['<u4'], offsets + [4]
    record = np.dtype(
        {
            'names': names,
            'formats': formats,
            'offsets': offsets,
            'itemsize': 4 + data_at + 8 * width,
        }
    )
    records = np.zeros(values.shape[0], dtype=record)
    records['encapsulation'] = np.void(CDR_LE)
    if sequence_count is not None:
        records['count'] = sequence_count
    records['sec'] = sec
    records['nanosec'] = nanosec
    records['length'] = len(frame) + 1
    records['frame_id'] = np.void(frame + b'\x00')
    records['child_length'] = len(child) + 1
    records['child'] = np.void(child + b'\x00')
    records['data'] = values
    return _split(records)


def _frame_bytes(frame_id: str, name: str) -> bytes:
    frame = frame_id.encode('utf-8')
    if b'\x00' in frame:
        raise ValueError(f'{name}: must not contain NUL characters')
    return frame


def encode_times(stamps_ns) -> MessageBlock:
    """``builtin_interfaces/Time`` alone: the layout of ``rosgraph_msgs/Clock``."""
    sec, nanosec = _stamp_fields(stamps_ns)
    if sec.shape[0] == 1:  # one sample at a time (a closed loop): packed directly, the same bytes
        return MessageBlock(CDR_LE + struct.pack('<iI', int(sec[0]), int(nanosec[0])), 12)
    record = np.dtype(
        {
            'names': ['encapsulation', 'sec', 'nanosec'],
            'formats': ['V4', '<i4', '<u4'],
            'offsets': [0, 4, 8],
            'itemsize': 12,
        }
    )
    records = np.zeros(sec.shape[0], dtype=record)
    records['encapsulation'] = np.void(CDR_LE)
    records['sec'] = sec
    records['nanosec'] = nanosec
    return _split(records)


class CdrTemplate:
    """
    A message of a fixed layout written once, numbers as placeholders.

    A block of messages is that many copies with the numbers put in at the offsets recorded while
    writing. Messages of one template share their strings and sequence lengths, hence their padding
    and offsets.
    """

    def __init__(self):
        self._buffer = bytearray(CDR_LE)
        self._fields: dict[str, tuple[int, np.dtype, int]] = {}  # name -> offset, type, count
        self._stamps: list[tuple[str, str]] = []
        self._pack_cache: tuple | None = None  # (buffer length, _packs)

    def _put(self, dtype: str, values, name: str | None = None) -> None:
        dtype = np.dtype(dtype)
        values = np.atleast_1d(np.asarray(values, dtype=dtype))
        # aligned from the header's end
        self._buffer += bytes(-(len(self._buffer) - 4) % dtype.itemsize)
        if name is not None:
            if name in self._fields:
                raise ValueError(f"template field '{name}' written twice")
            self._fields[name] = (len(self._buffer), dtype, values.size)
        self._buffer += values.tobytes()

    def int32(self, value: int = 0, name: str | None = None) -> None:
        self._put('<i4', value, name)

    def uint32(self, value: int = 0, name: str | None = None) -> None:
        self._put('<u4', value, name)

    def float32(self, values, name: str | None = None) -> None:
        self._put('<f4', values, name)

    def float64(self, values, name: str | None = None) -> None:
        self._put('<f8', values, name)

    def boolean(self, value: bool) -> None:
        self._put('u1', int(value))

    def string(self, text: str, field: str = 'string') -> None:
        data = _frame_bytes(text, field)
        self.uint32(len(data) + 1)
        self._buffer += data + b'\x00'

    def stamp(self, name: str) -> None:
        """Write a ``builtin_interfaces/Time`` that :meth:`fill` sets to each message's stamp."""
        self.int32(0, f'{name}.sec')
        self.uint32(0, f'{name}.nanosec')
        self._stamps.append((f'{name}.sec', f'{name}.nanosec'))

    def fill(self, stamps_ns, columns: dict) -> MessageBlock:
        """
        Make one message per stamp, with every stamp field set to it and the columns put in.

        ``columns[name][i]`` goes into field ``name`` of message ``i`` (or one value for all);
        fields not given keep the template's values.
        """
        sec, nanosec = _stamp_fields(stamps_ns)
        count = sec.shape[0]
        if count == 1 and self._packs is not None:
            return self._fill_one(int(sec[0]), int(nanosec[0]), columns)
        template = np.frombuffer(self._buffer, dtype=np.uint8)
        messages = np.empty((count, template.size), dtype=np.uint8)
        messages[:] = template
        values = dict(columns)
        for sec_name, nanosec_name in self._stamps:
            values[sec_name], values[nanosec_name] = sec, nanosec
        for name, column in values.items():
            offset, dtype, width = self._fields[name]
            # the field in every message, as a (count, width) array of its type
            # (unaligned: numpy copes)
            field = messages[:, offset: offset + dtype.itemsize * width].view(dtype)
            field[...] = np.asarray(column).reshape(-1, width) if np.ndim(column) else column
        return MessageBlock(messages.tobytes(), messages.shape[1])

    @property
    def _packs(self) -> dict | None:
        """
        Return every field's struct packing, for one message at a time: name -> (offset, format).

        For a closed loop's samples; None when a field is float32 (struct refuses what numpy rounds
        to infinity).
        """
        if self._pack_cache is None or self._pack_cache[0] != len(self._buffer):
            codes = {'<f8': 'd', '<i4': 'i', '<u4': 'I'}
            packs = {
                name: (offset, '<' + codes[dtype.str] * width)
                for name, (offset, dtype, width) in self._fields.items()
                if dtype.str in codes
            }
            self._pack_cache = (
                len(self._buffer),
                packs if len(packs) == len(self._fields) else None,
            )
        return self._pack_cache[1]

    def _fill_one(self, sec: int, nanosec: int, columns: dict) -> MessageBlock:
        packs = self._packs
        message = bytearray(self._buffer)
        for sec_name, nanosec_name in self._stamps:
            struct.pack_into('<i', message, packs[sec_name][0], sec)
            struct.pack_into('<I', message, packs[nanosec_name][0], nanosec)
        for name, column in columns.items():
            offset, form = packs[name]
            values = (
                np.asarray(column, dtype=np.float64 if form[1] == 'd' else np.int64)
                .ravel()
                .tolist()
            )
            struct.pack_into(form, message, offset, *values)
        return MessageBlock(bytes(message), len(message))


def decode_stamped_doubles(message: bytes, width: int) -> tuple[int, str, np.ndarray]:
    """
    Decode ``(stamp_ns, frame_id, values)`` from a message :func:`encode_stamped_doubles` wrote.

    The message is a Header, then ``width`` float64s: the inverse, for tools that read bags without
    rclpy. ``ValueError`` when the bytes are not such a message.
    """
    if message[:4] != CDR_LE:
        raise ValueError('not a little-endian CDR message (encapsulation header)')
    # struct, not numpy: the node decodes its commands one at a time with it
    try:
        sec, nanosec, length = _STAMP_AND_LENGTH.unpack_from(message, 4)
        text_end = 12 + length
        start = 4 + -(-text_end // 8) * 8
        values = struct.unpack_from(f'<{width}d', message, start)
    except struct.error as error:
        raise ValueError(f'truncated: {error}') from None
    frame = message[16: 16 + length - 1].decode('utf-8')
    return sec * 1_000_000_000 + nanosec, frame, np.array(values)


# -- sensor_msgs/JointState: a Header, string[] name, float64[] position, velocity, effort ------
_UINT32 = struct.Struct('<I')


def _joint_state_layout(frame_id: str, names, lengths) -> tuple[bytearray, list[int]]:
    """
    Return a JointState's bytes with zero stamp and values, and where each float64 array starts.

    Fast-CDR's layout: each sequence's ``uint32`` length on a 4-byte boundary, its doubles on an
    8-byte one (an empty sequence has no doubles, hence no padding), boundaries counted from the
    end of the encapsulation header.
    """
    buffer = bytearray(CDR_LE)

    def align(size: int) -> None:
        buffer.extend(bytes(-(len(buffer) - 4) % size))

    def string(value: str, field: str) -> None:
        data = _frame_bytes(value, field)
        align(4)
        buffer.extend(_UINT32.pack(len(data) + 1) + data + b'\x00')

    buffer.extend(struct.pack('<iI', 0, 0))
    string(frame_id, 'frame_id')
    align(4)
    buffer.extend(_UINT32.pack(len(names)))
    for name in names:
        string(name, 'name')
    offsets = []
    for length in lengths:
        align(4)
        buffer.extend(_UINT32.pack(length))
        if length:
            align(8)
        offsets.append(len(buffer))
        buffer.extend(bytes(8 * length))
    return buffer, offsets


def encode_joint_state(stamp_ns: int, frame_id: str, names, position, velocity, effort) -> bytes:
    """Encode one ``sensor_msgs/JointState`` (any of its arrays may be empty)."""
    arrays = [[float(x) for x in values] for values in (position, velocity, effort)]
    buffer, offsets = _joint_state_layout(frame_id, names, [len(a) for a in arrays])
    sec, nanosec = _stamp_fields([stamp_ns])
    struct.pack_into('<iI', buffer, 4, int(sec[0]), int(nanosec[0]))
    for offset, values in zip(offsets, arrays):
        struct.pack_into(f'<{len(values)}d', buffer, offset, *values)
    return bytes(buffer)


def encode_joint_states(stamps_ns, frame_id: str, names, values) -> MessageBlock:
    """
    Encode a ``sensor_msgs/JointState`` per row: position, velocity and effort of every joint.

    A row of ``values`` is ``3 n`` float64s for the ``n`` joints ``names``: the positions, then
    the velocities, then the efforts.
    """
    values = np.asarray(values, dtype=np.float64)
    count, n = values.shape[0], len(names)
    if values.ndim != 2 or values.shape[1] != 3 * n:
        raise ValueError(
            f'joint state rows: expected {3 * n} float64s per row (position, velocity and '
            f'effort of {n} joints), got shape {values.shape}'
        )
    buffer, offsets = _joint_state_layout(frame_id, names, [n, n, n])
    sec, nanosec = _stamp_fields(stamps_ns)
    if count == 1:  # a closed loop's one sample at a time: packed directly, the same bytes
        struct.pack_into('<iI', buffer, 4, int(sec[0]), int(nanosec[0]))
        row = values[0].tolist()
        for j, offset in enumerate(offsets):
            struct.pack_into(f'<{n}d', buffer, offset, *row[j * n: (j + 1) * n])
        return MessageBlock(bytes(buffer), len(buffer))
    messages = np.empty((count, len(buffer)), dtype=np.uint8)
    messages[:] = np.frombuffer(bytes(buffer), dtype=np.uint8)
    messages[:, 4:8].view('<i4')[:, 0] = sec
    messages[:, 8:12].view('<u4')[:, 0] = nanosec
    for j, offset in enumerate(offsets):
        messages[:, offset: offset + 8 * n].view('<f8')[:] = values[:, j * n: (j + 1) * n]
    return MessageBlock(messages.tobytes(), messages.shape[1])


def decode_joint_state(message: bytes) -> tuple[int, str, list, tuple, tuple, tuple]:
    """
    Decode ``(stamp_ns, frame_id, names, position, velocity, effort)`` from a JointState.

    Little-endian CDR, with struct (the node decodes its wheel commands one at a time with it); a
    message that is not one, or is cut short, raises ``ValueError``.
    """
    if message[:4] != CDR_LE:
        raise ValueError('not a little-endian CDR message (encapsulation header)')
    size = len(message)

    def aligned(at: int, to: int) -> int:
        return at + (-(at - 4) % to)

    def length(at: int, item: int) -> tuple[int, int]:
        at = aligned(at, 4)
        (count,) = _UINT32.unpack_from(message, at)
        if count * item > size - at - 4:
            raise ValueError(f'a sequence of {count} items runs past the message ({size} bytes)')
        return count, at + 4

    def string(at: int) -> tuple[str, int]:
        count, at = length(at, 1)
        if count < 1:
            raise ValueError('a string without its terminating NUL')
        return message[at: at + count - 1].decode('utf-8'), at + count

    try:
        sec, nanosec = struct.unpack_from('<iI', message, 4)
        frame_id, at = string(12)
        names_count, at = length(at, 5)  # (a name is at least its length and NUL)
        names = []
        for _ in range(names_count):
            name, at = string(at)
            names.append(name)
        arrays = []
        for _ in range(3):
            count, at = length(at, 8)
            if count:
                at = aligned(at, 8)
            arrays.append(struct.unpack_from(f'<{count}d', message, at))
            at += 8 * count
    except struct.error as error:
        raise ValueError(f'a JointState cut short ({size} bytes): {error}') from None
    return sec * 1_000_000_000 + nanosec, frame_id, names, *arrays
