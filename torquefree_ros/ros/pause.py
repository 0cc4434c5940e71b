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
Pause and resume (``~/pause``, ``std_srvs/SetBool``).

What the sample loop reports and what the node answers.

The rule, in one place (the service's answers, the README and the tests quote it):

* While paused no sample goes out and nothing is recorded; the simulated clock stands still. When
  the run publishes ``/clock`` (a clock of our own, or ``publish_clock``), it goes out again at its
  held value every 0.1 s wall (not recorded), as a paused Gazebo keeps publishing its time, so a
  neighbour that starts during the pause learns it.
* Resuming continues the same run: the samples after it are those of a run never paused (same
  indices ``k``, same values at ``t_k = k / publish_rate``).
* On a clock of our own (``real_time_factor`` not 1, or lock-step) the stamps continue where they
  stopped: ``epoch + k / publish_rate``, no gap. With wall-clock stamps (``real_time_factor`` 1)
  the run's epoch moves on by the time paused: the first sample after resuming is stamped as long
  after the last one before it as the pause lasted (plus its own period), so stamps stay wall-clock
  time and never go backwards, consumers see the gap, and ``stamp - t_k`` is the same for every
  sample after the pause (``epoch + shift``).
"""

from __future__ import annotations

from typing import NamedTuple

WALL_CLOCK_RULE = (
    "the run's epoch moves on by the time paused: stamps stay wall-clock time and continue from "
    'the pause, never backwards; consumers see the gap, the samples have none'
)
OWN_CLOCK_RULE = 'stamps continue where they stopped, with no gap (the simulated clock held)'


class PauseReport(NamedTuple):
    changed: bool  # False: it already was in that state
    paused: bool  # the state now
    next_index: int  # the sample that goes out next (k)
    rate: float  # publish_rate: t_k = k / rate
    clock_ns: int | None  # the value /clock holds (None: the run publishes no /clock, or none yet)
    # how long it had been paused (monotonic ns; 0 when it was running); resuming with wall-clock
    # stamps, also how far this resume moved them
    paused_for_ns: int
    wall_clock: bool  # the run's stamps are wall-clock time
    total_shift_ns: int  # how far all pauses of the run moved its stamps

    @property
    def where(self) -> str:
        return where(self.next_index, self.rate)

    def message(self) -> str:
        """Return the service's answer."""
        if not self.changed:
            if self.paused:
                return (
                    f'already paused at {self.where} for {self.paused_for_ns * 1e-9:.3f} s: '
                    'nothing changed'
                )
            return f'not paused (running, next {self.where}): nothing changed'
        if self.paused:
            held = (
                f'; /clock holds at {seconds_text(self.clock_ns)} s (sent again every 0.1 s)'
                if self.clock_ns is not None
                else ''
            )
            rule = WALL_CLOCK_RULE if self.wall_clock else OWN_CLOCK_RULE
            return (
                f'paused at {self.where}, which goes out on resuming; '
                f'no sample goes out meanwhile{held}; on resuming, {rule}'
            )
        paused = f'after {self.paused_for_ns * 1e-9:.3f} s paused'
        if self.wall_clock:
            return (
                f'resumed at {self.where} {paused}; '
                f'stamps shifted by +{seconds_text(self.paused_for_ns)} s '
                f'(+{seconds_text(self.total_shift_ns)} s in this run): {WALL_CLOCK_RULE}'
            )
        return f'resumed at {self.where} {paused}: {OWN_CLOCK_RULE}'


def where(index: int, rate: float) -> str:
    return f'sample {index} (t = {index / rate:.9g} s)'


def seconds_text(ns: int) -> str:
    """Nanoseconds as seconds with all nine decimals (exact: a reader can parse the shift back)."""
    return f'{ns // 1_000_000_000}.{ns % 1_000_000_000:09d}'
