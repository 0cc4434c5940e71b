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
The run-time changes of the sensors (faults, noise) as a bag records them, for a replay.

A recording node writes, on the topic ``sensor_changes`` (``std_msgs/msg/String``, in its
namespace), the ``faults`` and ``sensor_noise`` parameter texts in force from a sample on, as JSON
``{"faults": TEXT, "sensor_noise": TEXT}``, logged at the stamp of that sample: at the start of a
run whose parameters name any, and at each change while it runs. The offline replay
(``bag.offline``) applies each at the first sample stamped at or after its log time.
"""

from __future__ import annotations

import json
import struct
from typing import NamedTuple

from .cdr import CDR_LE
from .reader import BagReader
from .writer import BagError

SENSOR_CHANGES = 'sensor_changes'
STRING = 'std_msgs/msg/String'
_LENGTH = struct.Struct('<I')


class SensorChange(NamedTuple):
    log_time_ns: int
    faults: str  # the faults parameter's text
    sensor_noise: str  # the sensor_noise parameter's text


def change_text(faults: str, sensor_noise: str) -> str:
    """Return the JSON a bag carries for the texts in force."""
    return json.dumps({'faults': faults, 'sensor_noise': sensor_noise}, sort_keys=True)


def encode_string(data: str) -> bytes:
    """Encode a ``std_msgs/msg/String`` (CDR, little-endian): its length with the NUL, the text."""
    raw = data.encode('utf-8') + b'\0'
    return CDR_LE + _LENGTH.pack(len(raw)) + raw


def decode_string(message: bytes) -> str:
    """Decode a ``std_msgs/msg/String``; ``ValueError`` when it is not one."""
    if len(message) < 8 or message[:4] != CDR_LE:
        raise ValueError('not a little-endian CDR message')
    (length,) = _LENGTH.unpack_from(message, 4)
    if length < 1 or 8 + length > len(message) or message[8 + length - 1] != 0:
        raise ValueError(f'a string of {length} bytes does not fit the message')
    end = 8 + length - 1
    return message[8:end].decode('utf-8')


def read_sensor_changes(bag, topic: str) -> list[SensorChange]:
    """Read a bag's recorded sensor changes on ``topic`` (none when it lacks it), in log order."""
    reader = bag if isinstance(bag, BagReader) else BagReader(bag)
    types = {t.name: t.type_name for t in reader.topics}
    if topic not in types:
        return []
    if types[topic] != STRING:
        raise BagError(f"bag '{reader.path}': topic '{topic}' is {types[topic]}, not {STRING}")
    changes = []
    for message in reader.messages([topic]):
        try:
            document = json.loads(decode_string(message.data))
            faults, noise = document['faults'], document['sensor_noise']
            if not isinstance(faults, str) or not isinstance(noise, str):
                raise ValueError('faults and sensor_noise must be texts')
        except (ValueError, KeyError, TypeError, UnicodeDecodeError) as error:
            raise BagError(
                f"bag '{reader.path}': a message on '{topic}' at {message.log_time_ns} ns is "
                f'not a sensor change ({error})'
            ) from None
        changes.append(SensorChange(message.log_time_ns, faults, noise))
    return changes
