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
The one switch and the one loader of numba's compiled kernels.

Families of kernels are compiled: the exact attitude (``core/exact/attitude_kernels.py``), the
exact gyrostat's (``core/exact/gyrostat_kernels.py``), the oblique gyrostat's
(``core/exact/gyrostat_oblique_kernels.py``), the equations of motion with their
integrators (``core/compiled/motion_kernels.py``) and the environment's
(``core/environment/environment_kernels.py``). Each family is one file, because numba rebuilds a
function's cache when *its own file* changes, not when a file it calls into does: a stale kernel
would survive an edit. Each file's functions are written as plain Python and replaced by their
compiled forms together, once, on first use (a compiled function calls what its module's globals
hold when it compiles), by a :class:`KernelFamily`.

:data:`ENABLED` says whether propagators built from now on evaluate through the kernels; without
numba, or with ``TORQUEFREE_ROS_KERNELS=numpy`` in the environment, they use the numpy/scipy
reference paths, which the tests hold the kernels to.
"""

from __future__ import annotations

import importlib.util
import os
import threading
from typing import Callable

#: numba is installed (imported only when a kernel is first asked for: it adds ~0.2 s to an import)
AVAILABLE = importlib.util.find_spec('numba') is not None
#: whether propagators built from now on evaluate through the compiled kernels
ENABLED = AVAILABLE and os.environ.get('TORQUEFREE_ROS_KERNELS', 'numba') != 'numpy'


class KernelFamily:
    """
    The functions of one file, compiled by numba together, once, on first use.

    ``namespace``: the file's globals, whose functions ``names`` are replaced by their compiled
    forms; ``options(name)``: numba options of one function beyond ``error_model="numpy"`` (a
    division by zero gives inf, as numpy's does); ``prepare(numba)``: called first, for what the
    functions read from the globals when they compile. Compiled code is cached next to the file, or
    in the user's cache directory when the install is read-only, or not at all when neither is
    writable.
    """

    def __init__(
        self,
        namespace: dict,
        names: tuple[str, ...],
        options: Callable[[str], dict] | None = None,
        prepare: Callable | None = None,
    ):
        self._namespace = namespace
        self.names = names
        self._options = options or (lambda name: {})
        self._prepare = prepare
        self._lock = threading.Lock()
        self.compiled = False

    def load(self) -> None:
        """Replace the family's functions by their compiled forms, once (thread-safe)."""
        with self._lock:
            if self.compiled:
                return
            import numba

            if self._prepare is not None:
                self._prepare(numba)
            for name in self.names:
                function = self._namespace[name]
                options = {'error_model': 'numpy', **self._options(name)}
                try:
                    self._namespace[name] = numba.njit(cache=True, **options)(function)
                except RuntimeError:  # no writable cache anywhere: compile in every process
                    self._namespace[name] = numba.njit(**options)(function)
            self.compiled = True
