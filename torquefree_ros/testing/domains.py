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
ROS domain ids for test simulators: each claims one no other process on this machine holds.

A lock file per id in the temporary directory (the same files ``test/conftest.py`` claims its
session's domain with), so parallel test processes, pytest-xdist workers included, never see each
other's participants. Discovery is kept on this machine
(``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``).
"""

from __future__ import annotations

import fcntl
import os
import tempfile
import threading

#: 0 is everyone's default domain; above 101 the ports DDS derives from the id can collide with the
#: kernel's ephemeral range on Linux (ROS 2's documented safe range is 0-101)
DOMAINS = range(1, 102)
_LOCK_NAME = 'torquefree_ros_domain_{}.lock'

_guard = threading.Lock()
# the id this process claimed last: the next claim starts after it, so an id just released (its
# participant's traffic possibly still in flight) is the last one reused
_last = 0


class DomainClaim:
    """A domain id held (by a lock on its file) until :meth:`release`."""

    def __init__(self, domain_id: int, lock_file):
        self.domain_id = domain_id
        self._file = lock_file

    def release(self) -> None:
        if self._file is not None:
            self._file.close()  # closing drops the lock
            self._file = None


def claim_domain() -> DomainClaim:
    """Claim the first free domain id after the one this process claimed last (wrapping round)."""
    global _last
    with _guard:
        ids = list(DOMAINS)
        start = ids.index(_last) + 1 if _last in ids else 0
        for domain in ids[start:] + ids[:start]:
            lock = open(os.path.join(tempfile.gettempdir(), _LOCK_NAME.format(domain)), 'w')
            try:
                fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                lock.close()
                continue
            _last = domain
            return DomainClaim(domain, lock)
    raise RuntimeError(
        f'no free ROS domain id in {DOMAINS.start}..{DOMAINS.stop - 1}: every one is held by '
        f'another test process or simulator (lock files {tempfile.gettempdir()}/'
        f'{_LOCK_NAME.format("N")})'
    )


def keep_discovery_local() -> None:
    """Read by rcl when a context is initialised; a setting the user made stays."""
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
