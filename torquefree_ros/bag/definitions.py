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
Message definitions as rosbag2 stores them in MCAP schemas, read from the installed interfaces.

rosbag2 (``rosbag2_cpp``'s local message definition source) stores a type's ``.msg`` text followed
by every dependency, depth first, each dependency once, in sorted order of the names as written in
the ``.msg`` file, after a line of 80 ``=`` and ``MSG: <name as written>``. Without a ``.msg`` file
it falls back to the ``.idl`` files (``IDL:`` headers, the root included). The type hash
(``RIHS01_…``) comes from the ``.json`` type description installed beside the ``.msg``. No rclpy
import: the offline bag tools need only the ament index. Interfaces every ROS install has but the
PyPI wheels lack (``tf2_msgs``) are vendored under ``torquefree_ros/interfaces``, used only when
not installed.
"""

from __future__ import annotations

from dataclasses import dataclass
import functools
import json
from pathlib import Path
import re
import sys

from ament_index_python.packages import get_package_share_directory, PackageNotFoundError

# The patterns rosbag2 uses to find dependencies (``foo_msgs/Bar`` in ``foo_msgs/Bar[] bar``).
_MSG_FIELD_TYPE = re.compile(r'(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+')
_IDL_INCLUDE = re.compile(r'(?:^|\n)#include\s+(?:\"|<)([a-zA-Z0-9_/]+)\.idl(?:\"|>)')
_PRIMITIVES = frozenset(
    {
        'bool',
        'byte',
        'char',
        'float32',
        'float64',
        'int8',
        'uint8',
        'int16',
        'uint16',
        'int32',
        'uint32',
        'int64',
        'uint64',
        'string',
    }
)
_NAME = r'[a-zA-Z][a-zA-Z0-9_]*'
_TYPE_NAME = re.compile(rf'^({_NAME})/(?:({_NAME})/)?({_NAME})$')
_DELIMITER = '=' * 80 + '\n'
VENDORED_INTERFACES = Path(__file__).resolve().parents[1] / 'interfaces'
_MAX_DEPTH = 50


class DefinitionError(ValueError):
    """A message type whose definition cannot be found; the message names the type."""


@dataclass(frozen=True)
class MessageDefinition:
    type_name: str  # pkg/msg/Type
    encoding: str  # ros2msg or ros2idl
    text: str
    type_hash: str  # RIHS01_<sha256 hex>, or "" when not installed


def _split(type_name: str) -> tuple[str, str, str]:
    match = _TYPE_NAME.match(type_name)
    if match is None:
        raise DefinitionError(
            f"message type '{type_name}': expected 'package/msg/Type' or 'package/Type'"
        )
    package, namespace, name = match.groups()
    return package, namespace or 'msg', name


@functools.lru_cache(maxsize=None)
def share_directory(package: str) -> Path:
    """``share/<package>`` of an installed package (ament index, else this Python's prefix)."""
    try:
        return Path(get_package_share_directory(package))
    except (PackageNotFoundError, ValueError, OSError):
        pass
    # The PyPI wheels install the interfaces under <prefix>/share
    # without setting AMENT_PREFIX_PATH.
    share = Path(sys.prefix) / 'share' / package
    if share.is_dir():
        return share
    # what a ROS install has and the wheels lack (tf2_msgs)
    vendored = VENDORED_INTERFACES / package
    if vendored.is_dir():
        return vendored
    raise DefinitionError(
        f"package '{package}' is not installed (not in the ament index nor in {share.parent})"
    )


def _interface_file(type_name: str, extension: str) -> Path:
    package, namespace, name = _split(type_name)
    return share_directory(package) / namespace / f'{name}{extension}'


def _dependencies(text: str, extension: str, package: str) -> list[str]:
    if extension == '.idl':
        return sorted(set(_IDL_INCLUDE.findall(text)))
    found = set()
    for name in _MSG_FIELD_TYPE.findall(text):
        if name not in _PRIMITIVES:
            found.add(name if '/' in name else f'{package}/{name}')
    return sorted(found)


def _full_text(root: str, extension: str) -> str:
    seen: set[str] = set()

    def append(type_name: str, depth: int) -> str:
        if depth <= 0:
            raise DefinitionError(f"message type '{root}': dependencies nest too deep")
        path = _interface_file(type_name, extension)
        try:
            text = path.read_text(encoding='utf-8')
        except OSError:
            raise FileNotFoundError(type_name) from None
        result = text
        for dependency in _dependencies(text, extension, _split(type_name)[0]):
            if dependency not in seen:
                seen.add(dependency)
                result += '\n' + _header(dependency, extension) + append(dependency, depth - 1)
        return result

    if extension == '.idl':
        return _header(root, extension) + append(root, _MAX_DEPTH)
    return append(root, _MAX_DEPTH)


def _header(type_name: str, extension: str) -> str:
    return _DELIMITER + ('IDL: ' if extension == '.idl' else 'MSG: ') + type_name + '\n'


def _type_hash(type_name: str) -> str:
    path = _interface_file(type_name, '.json')
    try:
        description = json.loads(path.read_text(encoding='utf-8'))
    except (OSError, ValueError):
        return ''
    for entry in description.get('type_hashes', []):
        if entry.get('type_name') == type_name:
            return entry.get('hash_string', '')
    return ''


@functools.lru_cache(maxsize=None)
def message_definition(type_name: str) -> MessageDefinition:
    """Return the schema rosbag2 would write for ``type_name`` (``pkg/msg/Type``)."""
    package, namespace, name = _split(type_name)
    canonical = f'{package}/{namespace}/{name}'
    try:
        return MessageDefinition(
            canonical, 'ros2msg', _full_text(canonical, '.msg'), _type_hash(canonical)
        )
    except FileNotFoundError:
        pass
    try:
        return MessageDefinition(
            canonical, 'ros2idl', _full_text(canonical, '.idl'), _type_hash(canonical)
        )
    except FileNotFoundError as missing:
        raise DefinitionError(
            f"message type '{type_name}': no .msg or .idl definition installed for '{missing}'"
        ) from None
