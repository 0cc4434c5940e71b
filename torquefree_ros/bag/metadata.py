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
rosbag2's bag metadata, version 9 (Jazzy).

It is ``metadata.yaml`` beside the ``.mcap`` file and the same mapping in the MCAP ``rosbag2``
metadata record (key ``serialized_metadata``). Keys and order follow ``rosbag2_storage/yaml.hpp``;
lists are indented under their key as yaml-cpp writes them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import yaml

from .qos import BagQos

VERSION = 9
ROS_DISTRO = 'jazzy'
STORAGE_IDENTIFIER = 'mcap'
METADATA_FILE = 'metadata.yaml'
TOP_KEY = 'rosbag2_bagfile_information'
# rosbag2's starting time before the first message (std::chrono::time_point::max()).
NO_MESSAGE_TIME = 2**63 - 1


@dataclass
class TopicRecord:
    name: str
    type_name: str
    offered_qos_profiles: tuple[BagQos, ...] = ()
    type_description_hash: str = ''
    serialization_format: str = 'cdr'
    message_count: int = 0

    def to_yaml(self) -> dict:
        return {
            'topic_metadata': {
                'name': self.name,
                'type': self.type_name,
                'serialization_format': self.serialization_format,
                'offered_qos_profiles': [qos.to_yaml() for qos in self.offered_qos_profiles],
                'type_description_hash': self.type_description_hash,
            },
            'message_count': self.message_count,
        }


@dataclass
class BagMetadata:
    relative_file_path: str
    topics: list[TopicRecord] = field(default_factory=list)
    first_time_ns: int | None = None
    last_time_ns: int | None = None
    custom_data: dict[str, str] = field(default_factory=dict)

    @property
    def message_count(self) -> int:
        return sum(topic.message_count for topic in self.topics)

    def to_yaml(self) -> dict:
        """Return the mapping ``YAML::convert<BagMetadata>::encode`` produces."""
        if self.first_time_ns is None:
            starting, duration = NO_MESSAGE_TIME, 0
        else:
            starting, duration = self.first_time_ns, self.last_time_ns - self.first_time_ns
        count = self.message_count
        return {
            'version': VERSION,
            'storage_identifier': STORAGE_IDENTIFIER,
            'duration': {'nanoseconds': duration},
            'starting_time': {'nanoseconds_since_epoch': starting},
            'message_count': count,
            'topics_with_message_count': [topic.to_yaml() for topic in self.topics],
            'compression_format': '',
            'compression_mode': '',
            'relative_file_paths': [self.relative_file_path],
            'files': [
                {
                    'path': self.relative_file_path,
                    'starting_time': {'nanoseconds_since_epoch': starting},
                    'duration': {'nanoseconds': duration},
                    'message_count': count,
                }
            ],
            'custom_data': dict(self.custom_data) or None,
            'ros_distro': ROS_DISTRO,
        }


class _IndentedDumper(yaml.SafeDumper):
    """Indents block sequences under their key, as yaml-cpp (and so rosbag2) does."""

    def increase_indent(self, flow=False, indentless=False):
        return super().increase_indent(flow, False)


def dump(mapping: dict) -> str:
    return yaml.dump(
        mapping,
        Dumper=_IndentedDumper,
        sort_keys=False,
        default_flow_style=False,
        allow_unicode=True,
        width=4096,
    )


def metadata_file_text(metadata: BagMetadata) -> str:
    return dump({TOP_KEY: metadata.to_yaml()})
