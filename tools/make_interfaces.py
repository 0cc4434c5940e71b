#!/usr/bin/env python3
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
Regenerate the vendored interface files under torquefree_ros/interfaces/ from their ``.msg``.

The ``.idl`` and the type description ``.json`` with its RIHS01 hash, made with the rosidl tools
in the environment and the installed dependencies. Prints the files it wrote; ``--check`` only
compares.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
import sys
import tempfile

ROOT = Path(__file__).resolve().parents[1] / 'torquefree_ros' / 'interfaces'
MESSAGES = {'tf2_msgs': ['TFMessage']}
DEPENDENCIES = ('geometry_msgs', 'std_msgs', 'builtin_interfaces')


def generate(package: str, name: str, output: Path) -> dict[str, str]:
    """``{".idl": text, ".json": text}`` generated from ROOT/package/msg/name.msg."""
    from rosidl_adapter.msg import convert_msg_to_idl
    from rosidl_generator_type_description import generate_type_hash
    from torquefree_ros.bag.definitions import share_directory

    idl_root = output / 'idl'
    (idl_root / 'msg').mkdir(parents=True)
    idl = convert_msg_to_idl(
        ROOT / package, package, Path('msg') / f'{name}.msg', idl_root / 'msg'
    )
    arguments = output / 'arguments.json'
    arguments.write_text(
        json.dumps(
            {
                'package_name': package,
                'output_dir': str(output / 'json'),
                'idl_tuples': [f'{idl_root}:msg/{idl.name}'],
                'include_paths': [
                    f'{dependency}:{share_directory(dependency)}' for dependency in DEPENDENCIES
                ],
            }
        )
    )
    (description,) = generate_type_hash(str(arguments))
    return {'.idl': idl.read_text(), '.json': Path(description).read_text()}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument(
        '--check',
        action='store_true',
        help='compare with the vendored files; exit 1 if they differ',
    )
    args = parser.parse_args()
    differ = False
    for package, names in MESSAGES.items():
        for name in names:
            with tempfile.TemporaryDirectory() as tmp:
                for suffix, text in generate(package, name, Path(tmp)).items():
                    target = ROOT / package / 'msg' / f'{name}{suffix}'
                    if args.check:
                        differ |= target.read_text() != text
                    else:
                        target.write_text(text)
                        print(target)
    return 1 if differ else 0


if __name__ == '__main__':
    sys.exit(main())
