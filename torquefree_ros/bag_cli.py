"""``torquefree_bag``: simulates a scene offline, as fast as possible, into a rosbag2 MCAP bag.

No DDS: the samples come from the same ``Simulation`` and CDR encoder as the node's, so the bag holds
what the node would publish for that scene and rate (sample ``k = 0 … floor(S·HZ)`` at stamp
``epoch + k / HZ``). ``--reindex BAG`` rebuilds the ``metadata.yaml`` of a bag whose recorder died.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

from .bag import BagError, BagWriter, reindex
from .bag.samples import INERTIA_KEY, SampleRecorder, encode_block, sample_qos
from .bag.writer import COMPRESSIONS
from .core import PROPAGATORS
from .core.scene import SceneError
from .core.simulation import Simulation
from .core.timing import sample_times
from .scene_library import resolve_scene

BLOCK = 4096  # samples computed, encoded and written per step: memory stays flat at any duration


def write_scene_bag(scene, output, duration: float, rate: float, *, epoch_ns: int = 0, propagator: str = "auto",
                    body_frame: str = "body", inertial_frame: str = "world", namespace: str = "/",
                    overwrite: bool = False, compression: str = "none", qos_depth: int = 10):
    """Writes samples ``0 … floor(duration·rate)`` of ``scene``; returns the bag's metadata.
    The output is checked (and created) before the first sample is computed."""
    count = sample_times(duration, rate).shape[0]
    simulation = Simulation(scene.propagator(propagator), rate, epoch_ns, outputs=scene.outputs)
    custom = {"torquefree_ros.scene": scene.source, "torquefree_ros.summary": simulation.summary(),
              INERTIA_KEY: " ".join(repr(float(x)) for x in scene.inertia)}
    with BagWriter(output, overwrite=overwrite, compression=compression, custom_data=custom) as writer:
        recorder = SampleRecorder.in_namespace(writer, namespace, sample_qos(qos_depth))
        for first in range(0, count, BLOCK):
            block = simulation.samples(first, min(BLOCK, count - first))
            recorder.write_block(block.stamps_ns, encode_block(block, body_frame, inertial_frame, simulation.outputs))
    return writer.metadata


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="torquefree_bag",
        description="Simulate a scene offline into a rosbag2 (Jazzy) MCAP bag: angular_velocity "
        "(Vector3Stamped), attitude (QuaternionStamped) and the outputs the scene names (imu, euler_angles), "
        "samples k = 0 … floor(duration·rate).")
    parser.add_argument("scene", nargs="?", help="scene file, or the name of an installed scene ('default')")
    parser.add_argument("--duration", type=float, help="simulated seconds")
    parser.add_argument("--rate", type=float, help="samples per simulated second (Hz)")
    parser.add_argument("--output", help="bag directory to create")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing bag directory")
    parser.add_argument("--compression", choices=sorted(COMPRESSIONS), default="none",
                        help="MCAP chunk compression (default none, like rosbag2)")
    parser.add_argument("--start-time", type=float, default=0.0, help="stamp of sample 0, seconds (default 0)")
    parser.add_argument("--propagator", default="auto", choices=["auto", *sorted(PROPAGATORS)])
    parser.add_argument("--body-frame", default="body")
    parser.add_argument("--inertial-frame", default="world")
    parser.add_argument("--namespace", default="/", help="namespace of the topics (default /)")
    parser.add_argument("--reindex", metavar="BAG", help="only rebuild metadata.yaml of BAG from its .mcap file")
    return parser


def bag_main(argv=None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.reindex:
        try:
            metadata = reindex(args.reindex)
        except (BagError, OSError) as error:
            print(f"torquefree_bag: {error}", file=sys.stderr)
            return 1
        print(f"{args.reindex}: {metadata.message_count} messages indexed")
        return 0
    missing = [flag for flag, value in (("SCENE", args.scene), ("--duration", args.duration),
                                        ("--rate", args.rate), ("--output", args.output)) if value is None]
    if missing:
        parser.error(f"missing {', '.join(missing)}")
    if not math.isfinite(args.start_time) or args.start_time < 0 or args.start_time >= 2**31:
        parser.error(f"--start-time: must be in [0, 2^31) s, got {args.start_time!r}")
    if not args.namespace.startswith("/"):
        parser.error(f"--namespace: must start with '/', got {args.namespace!r}")
    try:
        scene = resolve_scene(args.scene)
        started = time.perf_counter()
        metadata = write_scene_bag(
            scene, args.output, args.duration, args.rate, epoch_ns=round(args.start_time * 1e9),
            propagator=args.propagator, body_frame=args.body_frame, inertial_frame=args.inertial_frame,
            namespace=args.namespace, overwrite=args.overwrite, compression=args.compression)
    except (SceneError, ValueError) as error:
        parser.error(str(error))
    except BagError as error:
        print(f"torquefree_bag: {error}", file=sys.stderr)
        return 1
    elapsed = time.perf_counter() - started
    samples = metadata.topics[0].message_count if metadata.topics else 0
    print(f"{args.output}: {samples} samples ({metadata.message_count} messages) in {elapsed:.2f} s, "
          f"{samples / max(elapsed, 1e-9):.0f} samples/s")
    return 0


if __name__ == "__main__":
    sys.exit(bag_main())
