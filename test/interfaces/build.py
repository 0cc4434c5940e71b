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
Build an interface package under test/interfaces/ for the tests only.

The package (tf2_msgs: not among the PyPI wheels) is built with the rosidl/ament_cmake toolchain
installed from PyPI in this Python's environment.

``build(package, prefix)`` configures, compiles and installs it into ``prefix`` and returns what a
process started afterwards needs in its environment to use it: PYTHONPATH for the module,
LD_LIBRARY_PATH for the typesupport libraries rosidl's dispatch opens by name (the wheels'
bootstrapper keeps what is set), AMENT_PREFIX_PATH for the share directory. Needs cmake and a C/C++
compiler.
"""

from __future__ import annotations

import os
from pathlib import Path
import shutil
import subprocess
import sys
import sysconfig

HERE = Path(__file__).resolve().parent


def missing_tools() -> list[str]:
    return [tool for tool in ('cmake', 'cc', 'c++') if shutil.which(tool) is None]


def build(package: str, prefix: Path) -> dict:
    environment = dict(os.environ)
    environment['PATH'] = os.pathsep.join(
        [str(Path(sys.executable).parent), environment.get('PATH', '')]
    )
    environment['AMENT_PREFIX_PATH'] = sys.prefix  # where ament_index finds the typesupports
    build_dir = prefix / 'build' / package
    configure = [
        'cmake',
        '-S',
        str(HERE / package),
        '-B',
        str(build_dir),
        '-DBUILD_TESTING=OFF',
        f'-DCMAKE_INSTALL_PREFIX={prefix}',
        f'-DCMAKE_PREFIX_PATH={sys.prefix}',
        f'-DPython3_EXECUTABLE={sys.executable}',
    ]
    for command in (
        configure,
        ['cmake', '--build', str(build_dir), '--parallel', '2'],
        ['cmake', '--install', str(build_dir)],
    ):
        result = subprocess.run(command, env=environment, capture_output=True, text=True)
        if result.returncode:
            raise RuntimeError(
                f'building {package} failed: {" ".join(command)}\n{result.stdout[-4000:]}'
                f'\n{result.stderr[-4000:]}'
            )
    site = Path(sysconfig.get_path('purelib', vars={'base': str(prefix), 'platbase': str(prefix)}))

    def prepended(name, value):
        return os.pathsep.join(filter(None, [value, os.environ.get(name)]))

    return {
        'PYTHONPATH': prepended('PYTHONPATH', str(site)),
        'LD_LIBRARY_PATH': prepended('LD_LIBRARY_PATH', str(prefix / 'lib')),
        'AMENT_PREFIX_PATH': os.pathsep.join(
            [str(prefix), os.environ.get('AMENT_PREFIX_PATH') or sys.prefix]
        ),
    }
