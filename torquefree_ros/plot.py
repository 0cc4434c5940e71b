"""``torquefree_plot BAG_OR_SCENE``: the pictures of seed 000 for a run, as PNG files.

* ``NAME_rates.png``: the body rates ``w_i(t)``;
* ``NAME_polhode.png``: the path of ``H`` in body axes on the momentum sphere ``|H| = const``, with
  the energy ellipsoid ``H . I^-1 H = 2T`` it also lies on (one path per member of an energy sweep);
* ``NAME_phase.png``: the phase planes ``(w_i, w_i')`` of the Duffing analog
  ``w_i'' + A_i w_i + B_i w_i^3 = 0`` in principal axes.

A scene is simulated (``--duration``, ``--rate``); a bag's ``angular_velocity`` is read as
recorded, with the inertia the bag stores (``torquefree_bag`` writes it) or ``--inertia``.
matplotlib is an optional extra: ``pip install 'torquefree_ros[plot]'``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from .bag import BagError
from .bag.reader import BagReader, bag_information
from .bag.samples import INERTIA_KEY
from .cdr import decode_stamped_doubles
from .core.rigid_body import RigidBody
from .core.scene import SceneError
from .core.simulation import Simulation
from .scene_library import resolve_scene

MAX_SAMPLES = 200_000


class PlotError(ValueError):
    pass


def _pyplot():
    try:
        import matplotlib
    except ImportError:
        raise PlotError("plots need matplotlib, an optional extra: pip install 'torquefree_ros[plot]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def runs_from_scene(scene, duration: float | None, rate: float):
    """``(label, times, omega_B)`` per member; the default duration is two polhode periods."""
    runs = []
    for index, member in enumerate(scene.members()):
        simulation = Simulation(member.propagator(), rate)
        span = duration
        if span is None:
            period = simulation.regime.polhode_period
            span = 2.0 * period if math.isfinite(period) and period > 0 else 20.0
        count = min(MAX_SAMPLES, int(span * rate) + 1)
        block = simulation.samples(0, count)
        label = f"2T = {2 * simulation.kinetic_energy0:.4g} J" if scene.sweep_members else "w"
        runs.append((label, block.times, block.omega_B))
    return runs


def runs_from_bag(path: Path):
    reader = BagReader(path)
    topics = [t.name for t in reader.topics if t.name.endswith("angular_velocity")
              and t.type == "geometry_msgs/msg/Vector3Stamped"]
    if not topics:
        raise PlotError(f"bag '{path}': no angular_velocity topic (geometry_msgs/msg/Vector3Stamped)")
    stamps, omega = [], []
    for message in reader.messages(topics[:1]):
        stamp, _, values = decode_stamped_doubles(message.data, 3)
        stamps.append(stamp)
        omega.append(values)
    if len(stamps) < 3:
        raise PlotError(f"bag '{path}': {topics[0]} has {len(stamps)} messages, 3 or more are needed")
    stamps = np.array(stamps, dtype=np.int64)
    return [(topics[0], (stamps - stamps[0]) * 1e-9, np.array(omega))]


def bag_inertia(path: Path):
    """The inertia ``torquefree_bag`` stores in the bag, or None."""
    text = (bag_information(path).get("custom_data") or {}).get(INERTIA_KEY)
    return None if text is None else [float(x) for x in text.split()]


def draw(runs, body: RigidBody, name: str, output_dir: Path) -> list[Path]:
    plt = _pyplot()
    output_dir.mkdir(parents=True, exist_ok=True)
    written = []

    figure, axes = plt.subplots(figsize=(9, 4.5))
    for label, times, omega in runs:
        for i, style in zip(range(3), ("-", "--", ":")):
            axes.plot(times, omega[:, i], style, lw=1, label=f"w{i + 1} ({label})" if len(runs) > 1 else f"w{i + 1}")
    axes.set(xlabel="t (s)", ylabel="body rate (rad/s)", title=f"{name}: body rates")
    axes.legend(fontsize=7, ncol=3 if len(runs) > 1 else 1)
    written.append(_save(figure, plt, output_dir / f"{name}_rates.png"))

    figure = plt.figure(figsize=(7, 7))
    axes = figure.add_subplot(projection="3d")
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 40), np.linspace(0, np.pi, 20))
    sphere = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)])
    H_first = body.angular_momentum(runs[0][2]) @ body.principal_axes
    radius = float(np.linalg.norm(H_first[0]))
    axes.plot_wireframe(*(radius * sphere), color="0.8", lw=0.4)
    if len(runs) == 1:  # one energy: its ellipsoid, semi-axes sqrt(2 T I_i)
        two_T = float(2.0 * body.kinetic_energy(runs[0][2][0]))
        axes.plot_wireframe(*(np.sqrt(two_T * body.moments)[:, None, None] * sphere), color="tab:orange", lw=0.3)
    for label, _, omega in runs:
        H_P = body.angular_momentum(omega) @ body.principal_axes
        axes.plot(*H_P.T, lw=1.5, label=label)
    axes.set(xlabel="H1", ylabel="H2", zlabel="H3", title=f"{name}: polhode on the momentum sphere")
    axes.set_box_aspect((1, 1, 1))
    written.append(_save(figure, plt, output_dir / f"{name}_polhode.png"))

    figure, axes = plt.subplots(1, 3, figsize=(12, 4))
    for label, times, omega in runs:
        omega_P = body.to_principal(omega)
        rates = np.gradient(omega_P, times, axis=0)
        for i in range(3):
            axes[i].plot(omega_P[:, i], rates[:, i], lw=1)
    for i in range(3):
        axes[i].set(xlabel=f"w{i + 1} (rad/s)", ylabel=f"dw{i + 1}/dt (rad/s^2)",
                    title=f"I{i + 1} = {body.moments[i]:.4g} kg m^2")
    figure.suptitle(f"{name}: phase planes of the Duffing analog (principal axes)")
    written.append(_save(figure, plt, output_dir / f"{name}_phase.png"))
    return written


def _save(figure, plt, path: Path) -> Path:
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="torquefree_plot", description=__doc__.splitlines()[0])
    parser.add_argument("source", help="a bag directory, a scene file, or a library scene name")
    parser.add_argument("--output-dir", default=".", help="where the PNG files go (default: here)")
    parser.add_argument("--duration", type=float, help="simulated seconds for a scene (default: two polhode periods)")
    parser.add_argument("--rate", type=float, default=100.0, help="samples per second for a scene (default 100)")
    parser.add_argument("--inertia", type=float, nargs="+", help="the body's inertia (3 or 6 numbers) for a bag")
    args = parser.parse_args(argv)
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        parser.error(f"--duration: must be a positive number of seconds, got {args.duration!r}")
    if not (math.isfinite(args.rate) and args.rate > 0):
        parser.error(f"--rate: must be a positive number, got {args.rate!r}")
    source = Path(args.source)
    try:
        if (source / "metadata.yaml").is_file():
            inertia = args.inertia or bag_inertia(source)
            if inertia is None:
                raise PlotError(f"bag '{source}': it does not store the body's inertia; give --inertia")
            body = RigidBody.from_inertia(inertia, "--inertia")
            runs, name = runs_from_bag(source), source.name
        else:
            scene = resolve_scene(args.source)
            body = RigidBody.from_inertia(args.inertia or scene.inertia, "--inertia")
            name = Path(scene.source).stem if scene.source.endswith((".yaml", ".yml")) else "default"
            runs = runs_from_scene(scene, args.duration, args.rate)
        written = draw(runs, body, name.replace(" ", "_"), Path(args.output_dir))
    except (PlotError, SceneError, BagError, ValueError) as error:
        print(f"torquefree_plot: {error}", file=sys.stderr)
        return 2
    for path in written:
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
