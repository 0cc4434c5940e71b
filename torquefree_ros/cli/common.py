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
What every console script does the same way: interrupts, closed pipes and progress.

Ctrl-C / SIGTERM and a closed pipe end the process quietly (no traceback), and long work reports
progress on a terminal only.
"""

from __future__ import annotations

import functools
import math
import os
import signal
import sys
import threading
import time

INTERRUPTED = 130  # 128 + SIGINT, what a shell reports for a command stopped by Ctrl-C
BROKEN_PIPE = 141  # 128 + SIGPIPE, what `yes | head` reports for `yes`


def console_command(prog: str):
    """
    Decorate a console script's ``main(argv) -> int``: quiet interrupts and closed pipes.

    SIGTERM is treated like Ctrl-C, an interrupt exits with 130 and one line on stderr, a reader
    that closed our stdout (``| head``) exits with 141 silently. A ROS script's own handlers
    (``rclpy.init``) take over the signals once it has started.
    """

    def wrap(main):
        @functools.wraps(main)
        def run(argv=None) -> int:
            if threading.current_thread() is threading.main_thread():
                signal.signal(signal.SIGTERM, _interrupt)
            try:
                status = main(argv)
                sys.stdout.flush()
                return status
            except KeyboardInterrupt:
                print(f'{prog}: interrupted', file=sys.stderr)
                return INTERRUPTED
            except BrokenPipeError:
                # stdout's buffer cannot be flushed at exit either:
                # point it at /dev/null (Python docs)
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, sys.stdout.fileno())
                return BROKEN_PIPE

        return run

    return wrap


def _interrupt(signum, frame):
    raise KeyboardInterrupt


class GracefulStop:
    """
    A context in which SIGINT and SIGTERM stop the work at its next safe point.

    While active, SIGINT and SIGTERM ask the work to stop at its next safe point (``stop()`` turns
    true) instead of interrupting it anywhere: a file being written is closed whole. A second
    signal interrupts at once. Outside the main thread it does nothing (signals are delivered
    there).
    """

    def __init__(self):
        self.signal: int | None = None
        self._previous = {}

    def __call__(self) -> bool:
        return self.signal is not None

    def _handle(self, signum, frame):
        if self.signal is not None:
            raise KeyboardInterrupt
        self.signal = signum

    def __enter__(self) -> 'GracefulStop':
        if threading.current_thread() is threading.main_thread():
            for signum in (signal.SIGINT, signal.SIGTERM):
                self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)


class Progress:
    """
    One status line on stderr (samples/s, simulated time, ETA), on a terminal only.

    It is rewritten at most twice a second, and only when stderr is a terminal: piped or logged
    output stays clean. ``rate_hz`` converts samples to simulated time; ``streams`` samples are
    computed per simulated instant (sweeps).
    """

    def __init__(self, rate_hz: float, streams: int = 1, stream=None, period: float = 0.5):
        self.rate_hz, self.streams, self.period = rate_hz, streams, period
        self.stream = sys.stderr if stream is None else stream
        self.enabled = bool(getattr(self.stream, 'isatty', lambda: False)())
        self._start = self._last = time.monotonic()
        self._shown = False

    def report(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        now = time.monotonic()
        if now - self._last < self.period and done < total:
            return
        self._last = now
        self.stream.write('\r' + self.line(done, total, now - self._start) + '\033[K')
        self.stream.flush()
        self._shown = True

    def line(self, done: int, total: int, elapsed: float) -> str:
        speed = done / elapsed if elapsed > 0 else math.inf
        eta = (total - done) / speed if done and speed > 0 else math.inf
        percent = 100.0 * done / total if total else 100.0
        simulated = done / self.streams / self.rate_hz
        return (
            f'{done:,}/{total:,} samples ({percent:.0f} %), simulated {simulated:,.6g} s, '
            f'{speed:,.0f} samples/s, ETA {_duration(eta)}'
        )

    def close(self) -> None:
        if self._shown:
            self.stream.write('\r\033[K')
            self.stream.flush()


def _duration(seconds: float) -> str:
    if not math.isfinite(seconds):
        return '--'
    minutes, secs = divmod(int(round(seconds)), 60)
    hours, minutes = divmod(minutes, 60)
    return f'{hours}:{minutes:02d}:{secs:02d}' if hours else f'{minutes}:{secs:02d}'
