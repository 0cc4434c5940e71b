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
The life of a node process, shared by the console scripts.

rclpy's own signal handlers would shut the context down the moment Ctrl-C arrives, so everything
said while closing (the node's last log lines, a bag's summary) would fail to reach ``/rosout``.
Instead the executor spins in a helper thread, the main thread waits for SIGINT / SIGTERM (both
raise ``KeyboardInterrupt`` there), and the context is shut down last, after the node is destroyed.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.signals import SignalHandlerOptions


def init(args=None) -> None:
    """
    Run ``rclpy.init`` without rclpy's signal handlers.

    ``cli.common.console_command`` has already made SIGTERM end the process like Ctrl-C.
    """
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)


class Spinner(threading.Thread):
    """
    A helper thread that spins ``executor`` until :meth:`stop`.

    An exception from a callback ends the spin and is kept in ``error`` for the main thread to
    report. It spins in short slices rather than calling ``executor.spin()``, so that it has left
    the executor before anyone shuts the executor down (shutting it down under a spinning thread
    can abort the process in rcl).
    """

    SLICE = 0.1  # s: the longest a stop waits for the spin to notice

    def __init__(self, executor):
        super().__init__(name='spin', daemon=True)
        self.executor = executor
        self.error: BaseException | None = None
        self._stopping = threading.Event()

    def run(self) -> None:
        try:
            while not self._stopping.is_set() and self.executor.context.ok():
                self.executor.spin_once(timeout_sec=self.SLICE)
        except ExternalShutdownException:
            pass
        except BaseException as error:  # noqa: BLE001 - handed to the main thread
            self.error = error

    def wait(self, timeout: float | None = None) -> None:
        """
        Block the main thread until the spin ends or ``timeout`` passes.

        In slices: a signal the kernel delivers to another thread does not wake the main thread
        from a blocking join, and Python runs its handler only in the main thread, once it wakes.
        """
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.is_alive():
            remaining = self.SLICE if deadline is None else deadline - time.monotonic()
            if remaining <= 0.0:
                return
            self.join(min(remaining, self.SLICE))

    def stop(self) -> None:
        self._stopping.set()
        self.join()


def shut_down(executor, node, spinner: Spinner | None = None) -> None:
    """
    Stop spinning, shut the executor down, destroy the node and shut the context down.

    The node is destroyed before the context, so its last log lines still reach /rosout. Any
    argument may be None (the process stopped before it). A second Ctrl-C or SIGTERM meanwhile is
    ignored: cut short, the bag would lose its end and rcl would abort the process on
    half-destroyed objects.
    """
    with _interrupts_ignored():
        if spinner is not None and spinner.is_alive():
            spinner.stop()
        if executor is not None:
            executor.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


@contextlib.contextmanager
def _interrupts_ignored():
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    signals = (signal.SIGINT, signal.SIGTERM)
    previous = [signal.getsignal(number) for number in signals]
    # a Python no-op, not SIG_IGN: one already pending then runs it harmlessly
    for number in signals:
        signal.signal(number, _ignore)
    try:
        yield
    finally:
        for number, handler in zip(signals, previous):
            signal.signal(number, handler)


def _ignore(signum, frame) -> None:
    pass


def exit_process(status: int):
    """
    End a ROS script's process with ``status``, skipping the interpreter's finalization.

    Called once the script has closed everything (node, bag, context). The interpreter's
    finalization is skipped because there the DDS library's static objects can be destroyed while
    one of its threads still runs, and the C++ runtime aborts ("terminate called without an active
    exception", seen about once in several hundred clean Ctrl-C exits in the test suite).
    """
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


def process_main(main):
    """
    Return the console-script entry of a ROS script: ``main()``, then :func:`exit_process`.

    (``main`` itself returns normally, for callers in a process of their own.)
    """

    def run():
        exit_process(main())

    run.__doc__ = main.__doc__
    return run
