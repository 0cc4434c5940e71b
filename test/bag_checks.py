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
Independent readers for the bag tests, and what the tests read out of the messages they decode.

The ``mcap`` library with mcap-ros2-support's decoder, and ``rosbags`` (AnyReader with the Jazzy
typestore). Neither shares code with our writer.
"""

from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
import numpy as np
from rosbags.highlevel import AnyReader
from rosbags.typesys import get_typestore, Stores
import yaml

SEPARATOR = '=' * 80 + '\n'


def mcap_file(bag: Path) -> Path:
    return bag / f'{bag.name}_0.mcap'


def read_with_mcap(bag: Path) -> dict:
    """Read a bag with mcap: topic -> list of (log_time, publish_time, decoded message)."""
    out: dict = {}
    with open(mcap_file(bag), 'rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            out.setdefault(channel.topic, []).append(
                (message.log_time, message.publish_time, decoded)
            )
    return out


def stamps_and_last_messages(bag: Path) -> tuple[dict, dict, dict, dict]:
    """
    Read a long bag's log times, message counts and last messages, without decoding every message.

    Returns topic -> log times (mcap's reader), topic -> count (rosbags'), and each topic's last
    message decoded by each reader.
    """
    log_times: dict = {}
    last_mcap: dict = {}
    with open(mcap_file(bag), 'rb') as stream:
        reader = make_reader(stream)
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            log_times.setdefault(channel.topic, []).append(message.log_time)
            last_mcap[channel.topic] = (schema, channel, message)
    decoders = DecoderFactory()
    decoded_mcap = {
        topic: decoders.decoder_for(channel.message_encoding, schema)(message.data)
        for topic, (schema, channel, message) in last_mcap.items()
    }
    counts: dict = {}
    last_raw: dict = {}
    with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        for connection, _, raw in reader.messages():
            counts[connection.topic] = counts.get(connection.topic, 0) + 1
            last_raw[connection.topic] = (connection, raw)
        decoded_rosbags = {
            topic: reader.deserialize(raw, connection.msgtype)
            for topic, (connection, raw) in last_raw.items()
        }
    return log_times, counts, decoded_mcap, decoded_rosbags


def summary(bag: Path):
    with open(mcap_file(bag), 'rb') as stream:
        reader = make_reader(stream)
        return reader.get_header(), reader.get_summary(), list(reader.iter_metadata())


def read_with_rosbags(bag: Path) -> tuple[dict, dict]:
    """
    Read a bag with rosbags.

    Returns topic -> list of (timestamp, deserialized message); topic -> connection.
    """
    messages: dict = {}
    with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        connections = {c.topic: c for c in reader.connections}
        for connection, timestamp, raw in reader.messages():
            messages.setdefault(connection.topic, []).append(
                (timestamp, reader.deserialize(raw, connection.msgtype))
            )
    return messages, connections


def metadata(bag: Path) -> dict:
    return yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']


def stamp_ns(header) -> int:
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def vectors(messages) -> np.ndarray:
    return np.array([[m.vector.x, m.vector.y, m.vector.z] for *_, m in messages])


def quaternions(messages) -> np.ndarray:
    return np.array(
        [[m.quaternion.x, m.quaternion.y, m.quaternion.z, m.quaternion.w] for *_, m in messages]
    )


def transform_table(message) -> tuple[list, list, np.ndarray]:
    """
    Read a tf2_msgs/TFMessage as (frame pairs, stamps in ns, a row of numbers per transform).

    The message as any reader decodes it (rclpy, rosbags, mcap): pairs are ``(header.frame_id,
    child_frame_id)``; a row is the translation x, y, z then the rotation x, y, z, w, the layout of
    the ``tf`` output's rows.
    """
    transforms = message.transforms
    rows = [
        [
            t.transform.translation.x,
            t.transform.translation.y,
            t.transform.translation.z,
            t.transform.rotation.x,
            t.transform.rotation.y,
            t.transform.rotation.z,
            t.transform.rotation.w,
        ]
        for t in transforms
    ]
    return (
        [(t.header.frame_id, t.child_frame_id) for t in transforms],
        [stamp_ns(t.header) for t in transforms],
        np.array(rows).reshape(len(transforms), 7),
    )
