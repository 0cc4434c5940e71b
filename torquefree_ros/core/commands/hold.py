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
The hold of a run's commands: which command is in force on each sample interval, and the rules.

A command ``(stamp, values)`` holds from the first sample ``k`` with ``t_k >= stamp`` (and not
before the first interval still to be computed when it arrives) until the next command's start: the
values over ``[t_k, t_k+1)`` are the ones in force at ``t_k``. So a commanded input only changes at
sample times, and an interval is integrated the same way whether it is computed live, one sample at
a time, or offline from a recorded command stream, which makes the replay bit for bit.

The values are an n-vector: ``torque_command``'s body torque (3), ``reaction_wheels``' motor
torques or speed set-points (a number per wheel). A command may give some components only (a
``sensor_msgs/JointState`` naming some wheels): the others keep the latest accepted command's
values (``off`` before the first), and the merged vector is what holds, is recorded and replays.

Rules: a command stamped before the latest accepted one is dropped (stale); one with a non-finite
or over-``max_torque`` component, or whose ``frame_id`` is not the frame the effect expects (when
it expects one), is refused; so is a message its effect could not read as a command
(:meth:`CommandHold.refuse`: an unknown wheel, wrong lengths). Each is counted by reason and never
reaches the state. With no command for ``timeout`` simulated seconds (since the stamp of the one
in force, or since the start), the values are ``off`` (zero torque; a wheel drive off).
:func:`torque_refusal` and :func:`timed_out` are the rules on one command; the plant applies the
same two to a batch of bodies at once (:func:`torque_refusals`).

Overrides (:meth:`CommandHold.override`, an actuator's faults: ``core.faults.actuators``) change
some components of what holds on the intervals ``first .. stop - 1``, whatever the commands say:
replaced with given values, or (``values`` None) with what held on interval ``first - 1`` (``off``
before sample 0), kept once read; or (``scale``, ``bias``) turned into ``scale * value + bias``,
whatever holds (a command, or ``off``); or (``noise``) added ``noise(k)`` on interval ``k`` (a
seeded draw of the interval, ``core.faults.actuators.SeededNoise``), whatever holds. Those acting
on one interval apply in their order (:func:`overridden`, the one rule: the plant applies it to
its bodies too). They act where every reader of the hold looks (:meth:`CommandHold.held_on`), so
both propagation paths and the outputs see them.
"""

from __future__ import annotations

import bisect
from collections import Counter
import math
import threading
import time
from typing import Callable, NamedTuple

import numpy as np

from ..timing.grid import sample_stamp_ns
from ...files.safe_files import clip


class Command(NamedTuple):
    """An accepted command: it holds from sample ``start`` on."""

    start: int
    stamp_ns: int
    # what holds: a torque (N m, in the effect's frame), a motor torque or speed set-point a wheel
    values: np.ndarray
    force: np.ndarray  # torque_command: the wrench's force as received (ignored); else empty
    frame_id: str


class Override(NamedTuple):
    """Components of a hold changed on intervals ``first .. stop - 1`` (an actuator's fault)."""

    first: int
    stop: int | None  # None: to the run's end
    components: tuple  # the indices changed
    values: tuple | None  # replaced: one a component; None: what held on interval first - 1
    # or (both given, values unused) turned into scale * value + bias, one of each a component
    scale: tuple | None = None
    bias: tuple | None = None
    # or (values unused) added noise(k) on interval k: one a component, the same on every call
    noise: Callable[[int], np.ndarray] | None = None

    def covers(self, k: int) -> bool:
        return self.first <= k and (self.stop is None or k < self.stop)


def holds_last(override: Override) -> bool:
    """Tell whether ``override`` holds what held on the interval before its window."""
    return override.values is None and override.scale is None and override.noise is None


def overridden(values: np.ndarray, k: int, overrides, kept) -> np.ndarray:
    """
    Return ``values`` (what holds on interval ``k``) with the ``overrides`` covering ``k`` applied.

    In their order; ``kept(override)``: what held on interval ``override.first - 1``, for one that
    holds it. ``values`` itself when none acts, else a read-only copy.
    """
    acting = [override for override in overrides if override.covers(k)]
    if not acting:
        return values
    values = values.copy()
    for override in acting:
        components = list(override.components)
        if override.scale is not None:
            values[components] = (
                values[components] * np.array(override.scale) + np.array(override.bias)
            )
        elif override.noise is not None:
            values[components] = values[components] + override.noise(k)
        elif holds_last(override):
            values[components] = kept(override)[components]
        else:
            values[components] = override.values
    values.flags.writeable = False
    return values


def torque_refusal(torque_values: list, max_torque: float) -> str:
    """
    Return why a commanded torque is refused, or ``""``.

    ``torque_values``: its components (and any other components that must be finite, such as the
    wrench's force) as Python floats; only the first three are held to ``max_torque``.
    """
    if not all(map(math.isfinite, torque_values)):
        return 'not finite: a NaN or infinite component'
    if torque_values and max(map(abs, torque_values[:3])) > max_torque:
        return f'too large: a torque component exceeds max_torque {max_torque:g} N m'
    return ''


def torque_refusals(values: np.ndarray, max_torque: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """
    Apply :func:`torque_refusal`'s rules to a torque per body: ``(not_finite, too_large)``.

    ``values (N, 3)``, ``max_torque (N,)``; each a boolean ``(N,)``.
    """
    not_finite = ~np.isfinite(values).all(axis=1)
    # (a NaN compares False without a warning; the plant steps through this every sample)
    too_large = ~not_finite & (np.abs(values).max(axis=1) > max_torque)
    return not_finite, too_large


def timed_out(now_ns, since_ns, timeout_ns):
    """
    Apply the timeout rule: no command for ``timeout`` since ``since_ns``.

    Integers, or arrays of them.
    """
    return now_ns - since_ns >= timeout_ns


class CommandHold:
    """
    The commands of one run and the values they hold on each sample interval.

    ``width`` values a command (3: a torque); ``off`` (a number or ``width`` of them, read-only)
    hold while no command is in force; a component over ``max_torque`` in magnitude is refused.
    ``start(rate, epoch_ns)`` puts it on the run's sample grid. Thread-safe: commands arrive on one
    thread while the samples are computed on another; :meth:`seal` fixes the values of the
    intervals about to be computed, so a command arriving meanwhile holds from the next interval.
    """

    def __init__(
        self, timeout: float, max_torque: float = math.inf, width: int = 3, off=0.0
    ):
        self.timeout_ns = round(timeout * 1e9)
        self.max_torque = max_torque
        self.width = int(width)
        self.off = np.broadcast_to(np.asarray(off, dtype=float), (self.width,)).copy()
        self.off.flags.writeable = False
        self.rate = 1.0
        self.epoch_ns = 0
        # the frame_id commands must carry ("" until the run sets it; None: any)
        self.frame_id: str | None = ''
        # accepted, in order; sealing forgets those no longer in force
        self.commands: list[Command] = []
        self._starts: list[int] = []
        self.accepted = 0
        self.sealed = -1  # intervals 0 .. sealed have their torque fixed
        self.refused: Counter = Counter()
        self.force_seen = False
        self._lock = threading.Lock()
        self._arrived = threading.Condition(self._lock)
        self.overrides: tuple[Override, ...] = ()
        self._before_override: dict[Override, np.ndarray] = {}  # what a 'last' override keeps

    def start(self, rate: float, epoch_ns: int) -> None:
        """Put the hold on a run's sample grid: ``rate`` Hz, sample 0 stamped ``epoch_ns``."""
        self.rate, self.epoch_ns = float(rate), int(epoch_ns)

    def shift(self, offset_ns: int) -> None:
        """
        Move the grid and the commands kept by ``offset_ns``.

        For a paused run resuming on wall-clock stamps: its epoch moved on, and a command's timeout
        counts simulated time, which stood still.
        """
        with self._lock:  # commands arrive on another thread meanwhile
            self.epoch_ns += int(offset_ns)
            self.commands[:] = [
                command._replace(stamp_ns=command.stamp_ns + int(offset_ns))
                for command in self.commands
            ]

    # -- the grid -------------------------------------------------------------------------------
    def stamp_ns(self, k: int) -> int:
        """Return the stamp of sample ``k``, as the simulation stamps it."""
        return sample_stamp_ns(k, self.rate, self.epoch_ns)

    def index_at_or_after(self, stamp_ns: int) -> int:
        """Return the first sample ``k >= 0`` whose stamp is at or after ``stamp_ns``."""
        k = max(0, math.ceil((stamp_ns - self.epoch_ns) * 1e-9 * self.rate))
        while k > 0 and self.stamp_ns(k - 1) >= stamp_ns:
            k -= 1
        while self.stamp_ns(k) < stamp_ns:
            k += 1
        return k

    def interval_at(self, t: float) -> int:
        """
        Return the sample interval ``[t_k, t_k+1)`` holding ``t``.

        ``t`` in s since the start; ``t_k = k / rate``.
        """
        k = math.floor(t * self.rate)
        if (k + 1) / self.rate <= t:
            k += 1
        elif k / self.rate > t:
            k -= 1
        return max(k, 0)

    # -- commands in ----------------------------------------------------------------------------
    def receive(
        self,
        stamp_ns: int,
        values,
        force=(),
        frame_id: str = '',
        arrival_ns: int | None = None,
        indices=None,
    ) -> tuple[bool, str]:
        """
        Accept a command or refuse it; return ``(accepted, reason)``.

        The reason's first words name the rule. ``values``: the ``width`` components, or with
        ``indices`` those components alone (the others keep the latest accepted command's values,
        ``off`` before the first). ``force``: more numbers that must be finite (a wrench's force,
        kept as received). ``arrival_ns``: replaying a recording, the stamp it was logged at stands
        for the moment it arrived (the samples before it had been computed).
        """
        values = np.array(values, dtype=float).ravel()
        force = np.array(force, dtype=float).ravel()
        with self._lock:
            if arrival_ns is not None:
                self.sealed = max(self.sealed, self.index_at_or_after(arrival_ns) - 1)
            reason = self._refusal(stamp_ns, values, force, frame_id, indices)
            if reason:
                self.refused[reason.split(':', 1)[0]] += 1
                return False, reason
            if indices is not None:  # the components not given keep the latest values
                merged = (self.commands[-1].values if self.commands else self.off).copy()
                merged[list(indices)] = values
                values = merged
            start = max(self.index_at_or_after(stamp_ns), self.sealed + 1)
            self._append(Command(start, int(stamp_ns), values, force, frame_id))
            return True, ''

    def refuse(self, reason: str) -> tuple[bool, str]:
        """
        Count a command refused before it reached the hold; return ``(False, reason)``.

        A message its effect could not read as a command (an unknown wheel's name, wrong lengths):
        counted under the reason's first words, as the hold's own refusals.
        """
        with self._lock:
            self.refused[reason.split(':', 1)[0]] += 1
        return False, reason

    def _refusal(self, stamp_ns, values, force, frame_id, indices) -> str:
        given = self.width if indices is None else len(indices)
        if values.size != given:
            return f'wrong length: {values.size} values for {given} components'
        # on Python floats: one command at a time, where numpy's per-call cost is most of the work
        reason = torque_refusal(values.tolist() + force.tolist(), self.max_torque)
        if reason:
            return reason
        if self.frame_id is not None and frame_id != self.frame_id:
            return (
                f'wrong frame: header.frame_id is {clip(repr(frame_id), 80)}, '
                f"the command's frame is {self.frame_id!r}"
            )
        if self.commands and stamp_ns < self.commands[-1].stamp_ns:
            return 'stale: stamped before the latest accepted command'
        return ''

    def _append(self, command: Command) -> None:
        if self._starts and command.start < self._starts[-1]:
            raise ValueError(
                f'command holding from sample {command.start} after one from {self._starts[-1]}'
            )
        if any(command.force.ravel().tolist()):
            self.force_seen = True
        self.commands.append(command)
        self._starts.append(command.start)
        self.accepted += 1
        self._arrived.notify_all()

    # -- the torque out -------------------------------------------------------------------------
    def seal(self, through: int) -> list[Command]:
        """
        Fix the torque of intervals ``0 .. through``.

        Returns the commands that start holding in the newly sealed intervals (what a recorder
        writes). Commands superseded before interval ``through - 1`` are forgotten, so a long run
        keeps a bounded list.
        """
        with self._lock:
            first = bisect.bisect_right(self._starts, self.sealed)
            self.sealed = max(self.sealed, through)
            sealed = self.commands[first: bisect.bisect_right(self._starts, self.sealed)]
            for override in self.overrides:  # read before the commands it needs are forgotten
                if holds_last(override) and override.first - 1 <= through:
                    self._kept(override)
            # the one in force on through - 1
            keep = bisect.bisect_right(self._starts, through - 1) - 1
            if keep > 0:
                del self.commands[:keep], self._starts[:keep]
            return sealed

    def in_force(self, k: int) -> Command | None:
        """Return the command holding on interval ``k`` (None: none yet, or timed out)."""
        with self._lock:  # sealing may trim the lists meanwhile
            index = bisect.bisect_right(self._starts, k) - 1
            command = self.commands[index] if index >= 0 else None
        if command is None or timed_out(self.stamp_ns(k), command.stamp_ns, self.timeout_ns):
            return None
        return command

    def timed_out(self, k: int) -> bool:
        """
        Tell whether interval ``k`` has had no command in force for ``timeout``.

        Counted since the last command, or the start.
        """
        with self._lock:
            index = bisect.bisect_right(self._starts, k) - 1
            since = self.commands[index].stamp_ns if index >= 0 else self.epoch_ns
        return timed_out(self.stamp_ns(k), since, self.timeout_ns)

    def values_at(self, t: float) -> np.ndarray:
        """Return the values held on the sample interval holding ``t`` (``off`` when none)."""
        return self.held_on(self.interval_at(t))

    def held_on(self, k: int) -> np.ndarray:
        """Return the values held on interval ``k``: the command's (``off``: none), overridden."""
        with self._lock:
            return self._held_on(k)

    def _held_on(self, k: int) -> np.ndarray:  # (under the lock)
        index = bisect.bisect_right(self._starts, k) - 1
        command = self.commands[index] if index >= 0 else None
        if command is None or timed_out(self.stamp_ns(k), command.stamp_ns, self.timeout_ns):
            values = self.off
        else:
            values = command.values
        return overridden(values, k, self.overrides, self._kept)

    def _kept(self, override: Override) -> np.ndarray:  # (under the lock)
        kept = self._before_override.get(override)
        if kept is None:
            kept = self.off if override.first == 0 else self._held_on(override.first - 1)
            self._before_override[override] = kept
        return kept

    def override(self, overrides) -> None:
        """
        Put ``overrides`` in force (those before are dropped); an override kept keeps its values.

        The caller starts them no earlier than the first interval still to be computed.
        """
        with self._lock:
            self.overrides = tuple(overrides)
            self._before_override = {
                override: kept
                for override, kept in self._before_override.items()
                if override in self.overrides
            }

    def answered(self, stamp_ns: int) -> bool:
        """Lock-step: an accepted command is stamped at or after ``stamp_ns``."""
        with self._lock:
            return self._answered(stamp_ns)

    def _answered(self, stamp_ns: int) -> bool:  # (under the lock)
        return bool(self.commands) and self.commands[-1].stamp_ns >= stamp_ns

    def wait_for(self, stamp_ns: int, timeout: float, interrupted) -> bool:
        """
        Wait (lock-step) for an accepted command stamped at or after ``stamp_ns``.

        Wall clock, at most ``timeout`` s; ``interrupted()`` is polled so that a reset or a stop
        need not wait.
        """
        deadline = time.monotonic() + timeout
        with self._lock:
            while not self._answered(stamp_ns):
                remaining = deadline - time.monotonic()
                if remaining <= 0.0 or interrupted():
                    return False
                self._arrived.wait(min(remaining, 0.05))
            return True
