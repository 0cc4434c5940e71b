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
The vectorised CDR encoder against rclpy's own serializer.

Decode ours with rclpy and compare the values; compare our bytes with rclpy's everywhere except the
alignment padding (Fast-CDR leaves padding uninitialised).
"""

from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from torquefree_ros.bag.cdr import (
    decode_joint_state,
    encode_joint_state,
    encode_joint_states,
    encode_stamped_doubles,
    encode_times,
)

stamps = st.lists(st.integers(0, 2**31 * 10**9 - 1), min_size=1, max_size=20)
frame_ids = st.text(
    alphabet=st.characters(blacklist_characters='\x00', blacklist_categories=('Cs',)), max_size=12
)
doubles = st.floats(allow_nan=False, width=64)


def _padding(frame_id: str) -> range:
    end = 4 + 12 + len(frame_id.encode()) + 1
    return range(end, 4 + -(-(end - 4) // 8) * 8)


@settings(max_examples=300, deadline=None)
@given(stamps=stamps, frame_id=frame_ids, data=st.data())
def test_stamped_doubles_equal_rclpy(stamps, frame_id, data):
    for message_type, field, width in (
        (Vector3Stamped, 'vector', 3),
        (QuaternionStamped, 'quaternion', 4),
    ):
        values = np.array(
            data.draw(
                st.lists(
                    st.lists(doubles, min_size=width, max_size=width),
                    min_size=len(stamps),
                    max_size=len(stamps),
                )
            )
        )
        encoded = encode_stamped_doubles(np.array(stamps, dtype=np.int64), frame_id, values)
        names = 'xyzw'[:width]
        for stamp, row, ours in zip(stamps, values, encoded):
            message = deserialize_message(ours, message_type)
            assert (message.header.stamp.sec, message.header.stamp.nanosec) == divmod(stamp, 10**9)
            assert message.header.frame_id == frame_id
            assert [getattr(getattr(message, field), n) for n in names] == row.tolist()
            theirs = serialize_message(message)
            assert len(theirs) == len(ours)
            skip = set(_padding(frame_id))
            assert bytes(b for i, b in enumerate(ours) if i not in skip) == bytes(
                b for i, b in enumerate(theirs) if i not in skip
            )
            # one message alone is packed directly rather than through a block: the same bytes
            assert (
                encode_stamped_doubles(
                    np.array([stamp], dtype=np.int64), frame_id, row[np.newaxis]
                )[0]
                == ours
            )


@settings(max_examples=100, deadline=None)
@given(stamps=stamps)
def test_clock_equals_rclpy(stamps):
    for stamp, ours in zip(stamps, encode_times(np.array(stamps, dtype=np.int64))):
        message = Clock()
        message.clock.sec, message.clock.nanosec = divmod(stamp, 10**9)
        assert ours == serialize_message(message)  # no padding in a Clock: byte-identical
        assert deserialize_message(ours, Clock) == message
        # alone: packed directly, the same
        assert encode_times(np.array([stamp], dtype=np.int64))[0] == ours


names = st.lists(
    st.text(
        alphabet=st.characters(blacklist_characters='\x00', blacklist_categories=('Cs',)),
        min_size=1,
        max_size=9,
    ),
    max_size=5,
)


def _joint_state(stamp, frame_id, name, position, velocity, effort):
    message = JointState()
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp, 10**9)
    message.header.frame_id, message.name = frame_id, name
    message.position, message.velocity, message.effort = position, velocity, effort
    return message


@settings(max_examples=300, deadline=None)
@given(stamp=stamps.map(lambda s: s[0]), frame_id=frame_ids, name=names, data=st.data())
def test_joint_states_decode_and_encode_as_rclpy_does(stamp, frame_id, name, data):
    """
    A JointState of any names and any lengths (empty arrays too: no padding for those).

    Decoded with struct from rclpy's bytes, and ours decoded by rclpy; ours equal rclpy's bytes
    but for the padding (Fast-CDR leaves it uninitialised) and the bytes rclpy may leave after
    the message's end.
    """
    arrays = [data.draw(st.lists(doubles, max_size=5)) for _ in range(3)]
    theirs = serialize_message(_joint_state(stamp, frame_id, name, *arrays))
    assert decode_joint_state(theirs) == (stamp, frame_id, name, *map(tuple, arrays))
    ours = encode_joint_state(stamp, frame_id, name, *arrays)
    decoded = deserialize_message(ours, JointState)
    assert (decoded.header.stamp.sec, decoded.header.stamp.nanosec) == divmod(stamp, 10**9)
    assert (decoded.header.frame_id, list(decoded.name)) == (frame_id, name)
    for field, values in zip(('position', 'velocity', 'effort'), arrays):
        assert list(getattr(decoded, field)) == values
    assert len(theirs) >= len(ours)
    differing = [i for i, (a, b) in enumerate(zip(ours, theirs)) if a != b]
    assert all(ours[i] == 0 for i in differing)  # (our padding)
    # a block of joint states (the wheel_states output), every row through rclpy
    count, n = len(data.draw(stamps)), len(name)
    rows = np.array(data.draw(st.lists(doubles, min_size=3 * n * count, max_size=3 * n * count)))
    rows = rows.reshape(count, 3 * n)
    times = np.arange(count, dtype=np.int64) + min(stamp, 2**31 * 10**9 - 1 - count)
    for t, row, message in zip(times, rows, encode_joint_states(times, frame_id, name, rows)):
        assert message == encode_joint_state(int(t), frame_id, name, *row.reshape(3, n))
        decoded = deserialize_message(message, JointState)
        assert list(decoded.effort) == row[2 * n:].tolist()


def test_a_joint_state_cut_short_or_of_huge_lengths_is_refused():
    message = encode_joint_state(5, 'body', ['a', 'b'], [], [1.0, 2.0], [])
    for end in range(4, len(message)):
        with pytest.raises(ValueError):
            decode_joint_state(message[:end])
    huge = bytearray(message)
    huge[24:28] = (2**32 - 1).to_bytes(4, 'little')  # the count of names
    with pytest.raises(ValueError, match='runs past the message'):
        decode_joint_state(bytes(huge))
    with pytest.raises(ValueError, match='little-endian'):
        decode_joint_state(b'\x00\x00' + message[2:])
