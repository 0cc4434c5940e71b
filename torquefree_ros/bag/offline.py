"""A scene simulated offline, as fast as possible, into a bag (``torquefree_bag``).

No DDS: the samples come from the same ``Simulation`` and CDR encoder as the node's, so the bag holds
what the node would publish for that scene and rate (sample ``k = 0 … floor(S·HZ)`` at stamp
``epoch + k / HZ``). An energy sweep writes every member, member ``j`` under ``NAMESPACE/member_j``.
"""

from __future__ import annotations

from typing import Callable

from ..core.simulation import MAX_STAMP_S, Simulation
from ..core.timing import sample_count
from .samples import INERTIA_KEY, SampleRecorder, encode_block, resolve_topic, sample_qos
from .writer import BagWriter

BLOCK = 4096  # samples computed, encoded and written per step: memory stays flat at any duration
MAX_SAMPLES = 10**10  # per stream: ~1 TB of bag; more is a typo (1e9 s at 1 MHz), refused up front


def member_namespace(namespace: str, index: int) -> str:
    return resolve_topic(f"member_{index}", namespace)


def write_scene_bag(scene, output, duration: float, rate: float, *, epoch_ns: int = 0, propagator: str = "auto",
                    body_frame: str = "body", inertial_frame: str = "world", namespace: str = "/",
                    overwrite: bool = False, compression: str = "none", qos_depth: int = 10,
                    progress: Callable[[int, int], None] | None = None, stop: Callable[[], bool] | None = None):
    """Writes samples ``0 … floor(duration·rate)`` of ``scene`` (of each member of a sweep); returns
    the bag's metadata. Everything is checked, and the output created, before the first sample is
    computed. ``progress(samples_done, samples_total)`` is called after each block; when ``stop()``
    turns true the bag is closed there, complete, with the samples written so far."""
    count = sample_count(duration, rate)
    if count > MAX_SAMPLES:
        raise ValueError(f"duration: {duration:g} s at {rate:g} Hz is {count:.3g} samples; at most {MAX_SAMPLES:.0e} "
                         "(about a terabyte) are written")
    if epoch_ns / 1e9 + (count - 1) / rate >= MAX_STAMP_S:
        raise ValueError(f"duration: the last stamp would be {epoch_ns / 1e9 + (count - 1) / rate:.6g} s, past what "
                         f"builtin_interfaces/Time holds (2^31 s)")
    members = scene.members()
    simulations = [Simulation(member.propagator(propagator), rate, epoch_ns, outputs=scene.outputs)
                   for member in members]
    namespaces = ([member_namespace(namespace, j) for j in range(len(members))] if scene.sweep_members
                  else [namespace])
    custom = {"torquefree_ros.scene": scene.source,
              "torquefree_ros.summary": " | ".join(s.summary() for s in simulations),
              INERTIA_KEY: " ".join(repr(float(x)) for x in scene.inertia)}
    with BagWriter(output, overwrite=overwrite, compression=compression, custom_data=custom) as writer:
        recorders = [SampleRecorder.in_namespace(writer, ns, sample_qos(qos_depth)) for ns in namespaces]
        total = count * len(simulations)
        for first in range(0, count, BLOCK):
            if stop is not None and stop():
                break
            size = min(BLOCK, count - first)
            for simulation, recorder in zip(simulations, recorders):
                block = simulation.samples(first, size)
                recorder.write_block(block.stamps_ns,
                                     encode_block(block, body_frame, inertial_frame, simulation.outputs))
            if progress is not None:
                progress((first + size) * len(simulations), total)
    return writer.metadata
