"""The end of a node process, shared by the console scripts: stop spinning, destroy, shut down."""

from __future__ import annotations

import rclpy


def shut_down(executor, node, spinner=None) -> None:
    """Any argument may be None (the process stopped before creating it)."""
    if executor is not None:
        executor.shutdown()
    if spinner is not None:
        spinner.join(timeout=5.0)
    if node is not None:
        node.destroy_node()
    rclpy.try_shutdown()
