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
The campaign file, checked like a scene (every error names the file and the field path).

It holds a base scene, its dispersions, the number of runs, the seed, the time grid and the
metrics::

    description: one line                    # optional
    scene: dzhanibekov                       # a library scene's name, a scene file
                                             # (relative to this file), or a scene written
                                             # inline (a mapping: body, initial, effects, ...)
    runs: 1000
    seed: 2026                               # run i draws from SeedSequence(seed).spawn(runs)[i]
    duration: 60                             # s; samples k = 0 .. floor(duration * rate),
                                             # both ends kept
    rate: 10                                 # Hz
    invalid_body: redraw                     # redraw (default) | fail
    max_redraws: 100                         # redraw: how many more bodies a run may draw
    dispersions: {TARGET: DISPERSION, ...}   # see campaigns.dispersions
    metrics: [final_rates, {settle_time: {threshold: 0.01}}, ...]   # see campaigns.metrics
    trajectories: {every: 10}                # optional: keep every 10th sample of each run, or
                                             # {rate: 1}: a rate (Hz) that divides `rate`
                                             # (see below)
    controller: {law: bdot, rate: 1}         # optional: a law run per run (campaigns.controllers)
    sensor_seeds: scene                      # scene (default) | per_run (see below)

**Sensor seeds.** ``scene`` (the default): every run's outputs keep the scene's ``seed``, so every
run's sensors draw the same noise. ``per_run``: the ``j``-th output of the scene (in the scene's
order, ``Scene.outputs``) takes in run ``i`` the seed :func:`.controllers.sensor_seed` ``(seed,
i, j)``, the first 63 bits of ``SeedSequence(seed, spawn_key=(i, j))`` (the campaign's ``seed``),
written into the run's scene (``campaigns.run_scene(campaign, i)`` gives it, seeds included).

**Trajectories** (optional; none by default). ``{every: N}`` keeps samples k = 0, N, 2N, ... up to
``samples - 1`` (``N`` in ``[1, samples - 1]``: at least two samples a run); ``{rate: HZ}`` says
the same as a rate: positive, at most ``rate``, and ``rate / HZ`` a whole number (it is ``N``).
With an output directory, each chunk writes its finished runs' kept samples
(``run, t, w_x, w_y, w_z, q_x, q_y, q_z, q_w`` and the effects' states) to ``DIR/trajectories/``
(see campaigns.store); a failed run has none.

**Impossible bodies.** A drawn body is checked as a scene's is (``RigidBody.from_inertia``:
positive moments, triangle inequality). ``redraw``: the run draws its body again, up to
``max_redraws`` times, then fails with the last reason; the ``redraws`` column counts them.
``fail``: the run fails at once (Basilisk's behaviour). Either way a failed run is a row with its
status and reason, never the end of the campaign. A nominal body on the triangle limit
(``[3, 2, 1]``, or the library's Dzhanibekov ``[1, 2, 3]``) makes about half of the draws of a
relative dispersion of its moments impossible: with ``redraw`` the kept bodies are the dispersion
*conditioned* on being physical (a one-sided distribution about the limit), with ``fail`` about
half the runs fail; the campaign measures the share of physical bodies over its first runs when it
is loaded (``body_acceptance``, kept in the table's metadata), and refuses a dispersion that gives
none.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
import math
from pathlib import Path

import numpy as np
import yaml

from .controllers import Controller, controller_target, parse_controller
from .dispersions import (
    EffectTarget,
    OrbitTarget,
    parse_target,
    RefusedDraw,
    run_generator,
    VectorTarget,
)
from .metrics import DEFAULT_METRICS, parse_metrics
from ..core.body.rigid_body import RigidBody
from ..core.checks.schema import (
    check_keys,
    child,
    choice,
    FieldError,
    fields,
    integer,
    number,
    Param,
    shown,
    text,
)
from ..core.scene import library
from ..core.scene.loader import (
    DEFAULT_SCENE_DATA,
    load_scene,
    read_document,
    Scene,
    scene_from_mapping,
    SceneError,
)
from ..core.timing.grid import MAX_RATE
from ..files.safe_files import clip

LIBRARY_DIRECTORY = Path(__file__).resolve().parent / 'library'
MAX_RUNS = 10_000_000
MAX_SAMPLES = 10_000_000  # per run: a run's samples are held whole while its metrics are computed
ACCEPTANCE_PROBE = 1000  # runs whose bodies are drawn when the campaign is loaded


class CampaignError(ValueError):
    """A campaign that cannot be run; the message starts with the file and the field path."""


@dataclass(frozen=True)
class Campaign:
    source: str  # the file, or "<mapping>"
    text: str  # the campaign file's text (a mapping: its YAML dump), kept in the results
    description: str
    scene: Scene
    scene_document: dict  # the scene's YAML mapping: runs with effects are built from a copy of it
    runs: int
    seed: int
    duration: float
    rate: float
    invalid_body: str
    max_redraws: int
    targets: tuple  # non-body targets, in draw order
    body_target: VectorTarget | None
    metrics: tuple  # MetricUse
    # share of physical bodies over the first runs' first draws
    body_acceptance: float | None = None
    # trajectories: keep samples k = 0, N, 2N, ... (None: none kept)
    trajectory_every: int | None = None
    # the law run per run (None: open loop)
    controller: Controller | None = None
    sensor_seeds: str = 'scene'  # scene | per_run

    @property
    def samples(self) -> int:
        return int(math.floor(self.duration * self.rate + 1e-9)) + 1

    @property
    def trajectory_times(self) -> np.ndarray:
        """
        Return the times of the kept samples.

        They are the campaign's own times ``k / rate``, k = 0, N, 2N, ...
        """
        return (np.arange(self.samples) / self.rate)[:: self.trajectory_every or 1]

    @property
    def trajectory_columns(self) -> tuple:
        """
        Return a trajectory part's columns.

        ``run, t``, the rates, the attitude, then the effects' states (``EFFECT[j]``,
        ``EFFECT#m[j]`` when two motion effects share a name; ``m`` counts motion effects).
        """
        effects = self.scene.effects
        names = [effect.name for effect in effects]
        internal = []
        for m, effect in enumerate(effects):
            label = effect.name if names.count(effect.name) == 1 else f'{effect.name}#{m}'
            internal += [f'{label}[{j}]' for j in range(effect.state_size)]
        return ('run', 't', 'w_x', 'w_y', 'w_z', 'q_x', 'q_y', 'q_z', 'q_w', *internal)

    @property
    def input_columns(self) -> tuple:
        targets = self.targets + ((self.body_target,) if self.body_target else ())
        return tuple(column for target in targets for column in target.columns)

    @property
    def metric_columns(self) -> tuple:
        return tuple(column for use in self.metrics for column in use.columns)

    @property
    def builds_run_scenes(self) -> bool:
        """
        Tell whether each run's scene is built and checked (:func:`.engine.scene_document`).

        A scene the plant runs, a target drawn into an effect, a fault or the orbit, or sensor
        seeds drawn per run.
        """
        return (
            self.runs_plant
            or self.sensor_seeds == 'per_run'
            or any(isinstance(target, (EffectTarget, OrbitTarget)) for target in self.targets)
        )

    @property
    def steps_plant(self) -> bool:
        """
        Tell whether the plant steps sample by sample with its sensors read.

        A controller, or a metric of the sensors' readings (:func:`.controllers.closed_loop`).
        """
        return self.controller is not None or any(use.metric.needs_sensors for use in self.metrics)

    @property
    def runs_plant(self) -> bool:
        """Tell whether the runs go through the batched plant (not ``propagate_batch``)."""
        return not self.scene.torque_free or self.steps_plant

    @property
    def needs_nominal(self) -> bool:
        return any(use.metric.needs_nominal for use in self.metrics)


def library_campaigns() -> dict[str, Path]:
    return {path.stem: path for path in sorted(LIBRARY_DIRECTORY.glob('*.yaml'))}


def load_campaign(path_or_name_or_mapping) -> Campaign:
    """
    Load a campaign: a campaign file, a library campaign's name, or a mapping.

    A mapping's scene path is relative to the working directory.
    """
    if isinstance(path_or_name_or_mapping, Campaign):
        return path_or_name_or_mapping
    if isinstance(path_or_name_or_mapping, dict):
        data = path_or_name_or_mapping
        return campaign_from_mapping(
            data, '<mapping>', yaml.safe_dump(data, sort_keys=False), Path.cwd()
        )
    name = str(path_or_name_or_mapping)
    path = Path(name)
    if not _exists(path) and library.is_scene_name(name):
        campaigns = library_campaigns()
        if name not in campaigns:
            raise CampaignError(
                f"campaign: '{clip(name)}' is neither a file nor a library campaign (library: "
                f'{", ".join(sorted(campaigns)) or "none installed"})'
            )
        path = campaigns[name]
    text_, document = read_document(path, CampaignError, 'campaign')
    return campaign_from_mapping(document, str(path), text_, path.resolve().parent)


def _exists(path: Path) -> bool:
    try:
        return path.exists()
    except (OSError, ValueError):
        return False


_TOP = {
    'description': Param(text(allow_empty=True), ''),
    'scene': Param(
        lambda value, path: value if isinstance(value, dict) else text()(value, path),
        description="a library scene's name, a scene file, or a scene written inline",
    ),
    'runs': Param(integer(1, MAX_RUNS), description='how many runs'),
    'seed': Param(
        integer(0, 2**63 - 1),
        description="the campaign's seed (run i: SeedSequence(seed).spawn(runs)[i])",
    ),
    'duration': Param(number(minimum=0.0, unit='s'), description='simulated time of each run, s'),
    'rate': Param(
        number(positive=True, maximum=MAX_RATE, unit='Hz'),
        description='samples per simulated second, Hz',
    ),
    'invalid_body': Param(choice('redraw', 'fail'), 'redraw'),
    'max_redraws': Param(integer(0, 10_000), 100),
    'dispersions': Param(lambda value, path: value, {}),  # checked against the scene below
    'metrics': Param(lambda value, path: value, None),  # checked against the scene below
    'trajectories': Param(lambda value, path: value, None),  # checked against the time grid below
    'controller': Param(lambda value, path: value, None),  # checked against the scene below
    'sensor_seeds': Param(choice('scene', 'per_run'), 'scene'),
}


def campaign_from_mapping(data, source: str, text_: str, base: Path) -> Campaign:
    try:
        values = fields(data, '', _TOP)
        scene, document = (
            _inline_scene(values['scene'], source)
            if isinstance(values['scene'], dict)
            else _scene(values['scene'], base)
        )
        if values['duration'] * values['rate'] + 1 > MAX_SAMPLES:
            raise FieldError(
                'duration',
                f'{values["duration"]:g} s at {values["rate"]:g} Hz is more than '
                f'{MAX_SAMPLES:,} samples a run',
            )
        controller = (
            None
            if values['controller'] is None
            else parse_controller(values['controller'], 'controller', scene, values['rate'])
        )
        targets, body_target = _dispersions(values['dispersions'], scene, document, controller)
        metrics = parse_metrics(
            values['metrics'] if values['metrics'] is not None else list(DEFAULT_METRICS),
            'metrics',
            scene,
            commands=controller is not None,
        )
        campaign = Campaign(
            source,
            text_,
            values['description'],
            scene,
            document,
            values['runs'],
            values['seed'],
            values['duration'],
            values['rate'],
            values['invalid_body'],
            values['max_redraws'],
            targets,
            body_target,
            metrics,
            trajectory_every=_trajectories(
                values['trajectories'],
                values['rate'],
                int(math.floor(values['duration'] * values['rate'] + 1e-9)) + 1,
            ),
            controller=controller,
            sensor_seeds=values['sensor_seeds'],
        )
        if body_target is not None:
            campaign = _with_acceptance(campaign)
        _check_plant(campaign)
    except FieldError as error:
        raise CampaignError(f'{source}: {error}') from None
    return campaign


def _scene(name: str, base: Path) -> tuple[Scene, dict]:
    candidate = base / name
    target = str(candidate) if not library.is_scene_name(name) or _exists(candidate) else name
    try:
        scene = load_scene(target)
    except SceneError as error:
        raise FieldError('scene', str(error)) from None
    if scene.source == '<built-in default>':
        document = copy.deepcopy(DEFAULT_SCENE_DATA)
    else:
        _, document = read_document(Path(scene.source))
    if scene.sweep_members:
        raise FieldError(
            'scene',
            f'{scene.source} is an energy sweep; a campaign disperses one scene (a sweep of '
            "initial rates: a 'values' dispersion of initial.angular_velocity)",
        )
    return scene, document


def _inline_scene(document: dict, source: str) -> tuple[Scene, dict]:
    """Load a scene written inline in the campaign file; its errors name ``scene.FIELD``."""
    where = f'{source}: scene'
    try:
        scene = scene_from_mapping(document, source=where)
    except SceneError as error:
        field, _, reason = str(error)[len(where) + 2:].partition(': ')
        raise FieldError(f'scene.{field}' if reason else 'scene', reason or field) from None
    if scene.sweep_members:
        raise FieldError('scene.sweep', 'a campaign disperses one scene, not an energy sweep')
    return scene, copy.deepcopy(document)


def _trajectories(value, rate: float, samples: int) -> int | None:
    """``{every: N}`` or ``{rate: HZ}`` -> N (None: no trajectories)."""
    if value is None:
        return None
    top = max(1, samples - 1)
    if not (
        isinstance(value, dict) and len(value) == 1 and next(iter(value)) in ('every', 'rate')
    ):
        if isinstance(value, dict) and len(value) == 1:
            check_keys(value, ('every', 'rate'), 'trajectories')
        raise FieldError(
            'trajectories',
            'expected {every: N} (keep every Nth sample) or {rate: HZ} (a rate that '
            f"divides the campaign's {rate:g} Hz), got {shown(value)}",
        )
    ((key, given),) = value.items()
    path = child('trajectories', key)
    if key == 'every':
        every = integer(1, top)(given, path)
    else:
        kept = number(positive=True, unit='Hz')(given, path)
        if kept > rate:
            raise FieldError(
                path, f"must be <= the campaign's rate, {rate:g} Hz, got {shown(given)}"
            )
        every = round(rate / kept)
        if abs(rate / kept - every) > 1e-9 * every:
            raise FieldError(
                path,
                f"{kept:g} Hz must divide the campaign's rate {rate:g} Hz a whole number of times "
                f'(rate / {kept:g} = {rate / kept:.6g}); {rate / max(every, 1):g} Hz would',
            )
        if every > top:
            raise FieldError(
                path,
                f'{kept:g} Hz keeps only the first sample of {samples} (duration * rate); at '
                f'least {rate / top:g} Hz',
            )
    return every


def _dispersions(value, scene: Scene, document: dict, controller: Controller | None = None):
    if not isinstance(value, dict):
        raise FieldError('dispersions', 'expected a mapping TARGET: DISPERSION')
    targets, body = [], None
    if 'body.moments' in value and 'body.inertia' in value:
        raise FieldError(
            'dispersions.body.inertia', 'disperse either body.moments or body.inertia, not both'
        )
    for key, entry in value.items():
        where = child('dispersions', key)
        if str(key).startswith('controller.'):
            targets.append(controller_target(str(key), entry, where, controller))
            continue
        target = parse_target(key, entry, where, scene, document)
        if key in ('body.moments', 'body.inertia'):
            body = target
            continue
        for other in targets:  # one number dispersed once (a vector and one of its components)
            if isinstance(target, EffectTarget) and isinstance(other, EffectTarget):
                if target.overlaps(other):
                    raise FieldError(
                        where,
                        f'disperses what dispersions.{other.path} disperses already; '
                        'disperse a number once',
                    )
        targets.append(target)
    return tuple(sorted(targets, key=lambda t: t.path)), body


def _with_acceptance(campaign: Campaign) -> Campaign:
    """
    Draw the first runs' first bodies and keep the share that are physical.

    A dispersion that gives no physical body is refused.
    """
    from .engine import body_from_draw

    probe = min(campaign.runs, ACCEPTANCE_PROBE)
    valid, first_reason = 0, None
    for run in range(probe):
        rng = run_generator(campaign.seed, run)
        for target in campaign.targets:  # the body draws after them: the same numbers as the run's
            try:
                target.draw(rng, run)
            except RefusedDraw:
                pass
        try:
            RigidBody.from_inertia(
                body_from_draw(campaign, campaign.body_target.draw(rng, run)), 'inertia'
            )
            valid += 1
        except ValueError as error:
            first_reason = first_reason or str(error).split(': ', 1)[-1]
    if valid == 0:
        raise FieldError(
            f'dispersions.{campaign.body_target.path}',
            f'gives no physical body: the first draw of each of the first {probe} runs is '
            f'impossible (run 0: {first_reason})',
        )
    from dataclasses import replace

    return replace(campaign, body_acceptance=valid / probe)


def _check_plant(campaign: Campaign) -> None:
    """Check that a scene with effects is one the batched plant can run (and read, stepped)."""
    if not campaign.runs_plant:
        return
    from ..plant import Plant

    controller = campaign.controller
    try:
        plant = Plant([campaign.scene], controller.rate if controller else campaign.rate)
        if campaign.steps_plant:
            plant.sensors()
    except ValueError as error:
        raise FieldError('scene', str(error).split(': ', 1)[-1]) from None
