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

"""``torquefree_plot BAG_OR_SCENE``: body rates, polhode and Duffing phase planes as PNG files."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
import sys

from .common import console_command
from .. import plot
from ..bag import BagError
from ..core.body.rigid_body import RigidBody
from ..core.scene.loader import load_scene, SceneError


@console_command('torquefree_plot')
def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog='torquefree_plot',
        description='Draw a scene (simulated) or a bag (as recorded): NAME_rates.png (body '
        'rates), NAME_polhode.png (H on the momentum sphere with the energy ellipsoid) and '
        "NAME_phase.png (the Duffing phase planes). Needs matplotlib: pip install '.[plot]'.",
    )
    parser.add_argument(
        'source',
        metavar='BAG_OR_SCENE',
        help='a bag directory, a scene file, or a library scene name',
    )
    parser.add_argument(
        '--output-dir',
        default='.',
        metavar='DIR',
        help='where the PNG files go, created if missing (default: the current directory)',
    )
    parser.add_argument(
        '--duration',
        type=float,
        metavar='SECONDS',
        help="simulated time for a scene, s (default: the scene's watch, else two polhode "
        'periods)',
    )
    parser.add_argument(
        '--rate',
        type=float,
        default=100.0,
        metavar='HZ',
        help='samples per simulated second for a scene, Hz (default: 100)',
    )
    parser.add_argument(
        '--inertia',
        type=float,
        nargs='+',
        metavar='I',
        help='for a bag that does not store it: 3 principal moments or 6 tensor elements, kg m^2',
    )
    args = parser.parse_args(argv)
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        parser.error(f'--duration: must be a positive number of seconds, got {args.duration!r}')
    if not (math.isfinite(args.rate) and args.rate > 0):
        parser.error(f'--rate: must be a positive number, got {args.rate!r}')
    source = Path(args.source)
    try:
        if (source / 'metadata.yaml').is_file():
            inertia = args.inertia or plot.bag_inertia(source)
            if inertia is None:
                raise plot.PlotError(
                    f"bag '{source}': it does not store the body's inertia; give --inertia"
                )
            body = RigidBody.from_inertia(inertia, '--inertia')
            runs, name = plot.runs_from_bag(source), source.name
        else:
            scene = load_scene(args.source)
            body = RigidBody.from_inertia(args.inertia or scene.inertia, '--inertia')
            name = (
                Path(scene.source).stem if scene.source.endswith(('.yaml', '.yml')) else 'default'
            )
            runs = plot.runs_from_scene(scene, args.duration, args.rate)
        written = plot.draw(runs, body, name.replace(' ', '_'), Path(args.output_dir))
    except (plot.PlotError, SceneError, BagError, ValueError) as error:
        print(f'torquefree_plot: {error}', file=sys.stderr)
        return 2
    for path in written:
        print(path)
    return 0


if __name__ == '__main__':
    sys.exit(main())
