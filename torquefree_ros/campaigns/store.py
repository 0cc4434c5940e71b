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
A campaign's output directory, written as the campaign goes, so that an interrupted one resumes.

Its files::

    DIR/campaign.yaml                     the campaign file's text (written when the campaign
                                          starts)
    DIR/parts/manifest.json               what the parts were made of: the campaign file's text,
                                          the scene and the versions (see results.provenance)
    DIR/parts/runs-START-STOP.parquet     one finished chunk, runs START .. STOP-1, its columns as
                                          the engine gave them (float64 bit for bit; no nulls yet)
    DIR/runs.parquet                      the table (results.build_table), assembled when every run
                                          is in a part; parts/ is removed after it
    DIR/trajectories/runs-START-STOP.parquet   when the campaign file asks for trajectories: one
                                          chunk's finished runs' kept samples, a row per run and
                                          time (columns Campaign.trajectory_columns, float64 plain,
                                          by run then t); they stay:
                                          ``pyarrow.dataset.dataset(DIR/"trajectories")`` opens
                                          them lazily (or dask.dataframe, with pandas)

Every file is written whole: to a temporary name in its directory, then ``os.replace`` (a reader
sees the old file or the new one, never half of one). A part is written by the driver as its chunk
completes, so a part on disk is a chunk that finished, whatever happened to the process after.

**Resuming** (:meth:`CampaignDirectory.prepare` with ``resume=True``): the manifest (or a finished
table's metadata) must name the same campaign file text, the same scene and the same versions, or
the directory is refused with what differs (runs made by other versions need not be bit for bit
this run's). The runs no part holds are then computed, in chunks of the requested size, and the
table is assembled from old and new parts: bit for bit the table of an uninterrupted run (a run's
row depends only on the campaign and the run's index). A part that cannot be read whole (a crash
between the write and the rename's reaching the disk) is computed again. A chunk's trajectory part
is written before its results part, and a results part counts as done only beside its whole
trajectory part (when the campaign keeps trajectories): otherwise both are removed and the chunk is
computed again, so the trajectory files of a resumed campaign hold the same rows as an
uninterrupted run's.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
import re

from .results import CAMPAIGN_FILE, provenance, RESULTS_FILE

PARTS_DIRECTORY = 'parts'
TRAJECTORIES_DIRECTORY = 'trajectories'
MANIFEST_FILE = 'manifest.json'
_PART = re.compile(r'^runs-(\d+)-(\d+)\.parquet$')
_STRING_COLUMNS = ('status', 'reason')


class ResumeError(ValueError):
    """An output directory that holds another campaign's runs (the message says what differs)."""


def part_name(start: int, stop: int) -> str:
    return f'runs-{start:09d}-{stop:09d}.parquet'


def write_whole(path: Path, write) -> None:
    """Call ``write(temporary_path)``, then rename the file onto ``path``."""
    temporary = path.with_name(f'.{path.name}.{os.getpid()}.tmp')
    try:
        write(temporary)
        os.replace(temporary, path)
    finally:
        if temporary.exists():
            temporary.unlink()


class CampaignDirectory:
    """
    The output directory of one campaign.

    :meth:`prepare` it, :meth:`missing` says what to compute, :meth:`write_part` keeps each
    finished chunk, :meth:`finish` writes the table.
    """

    def __init__(self, directory: Path, campaign, finished_table=None, parts: dict | None = None):
        self.directory = directory
        self.campaign = campaign
        # the table, when the directory already holds it whole
        self.finished_table = finished_table
        self.parts = parts or {}  # start -> stop of the parts on disk

    @property
    def parts_directory(self) -> Path:
        return self.directory / PARTS_DIRECTORY

    @property
    def trajectories_directory(self) -> Path:
        return self.directory / TRAJECTORIES_DIRECTORY

    @property
    def results_path(self) -> Path:
        return self.directory / RESULTS_FILE

    @property
    def done_runs(self) -> int:
        return sum(stop - start for start, stop in self.parts.items())

    # -- opening ----------------------------------------------------------------------------------
    @classmethod
    def prepare(
        cls, directory, campaign, *, overwrite: bool = False, resume: bool = False
    ) -> 'CampaignDirectory':
        """
        Make the directory ready for ``campaign``.

        With ``overwrite`` it is emptied of a campaign's files, with ``resume`` checked and read;
        otherwise it must hold no campaign yet.
        """
        if overwrite and resume:
            raise ValueError(
                'overwrite and resume exclude each other: overwrite starts over, resume continues'
            )
        store = cls(Path(directory), campaign)
        if store.directory.exists() and not store.directory.is_dir():
            raise NotADirectoryError(f'{store.directory}: exists and is not a directory')
        if overwrite:
            store._remove_campaign_files()
        elif store.results_path.exists():
            if not resume:
                raise FileExistsError(
                    f'{store.results_path} exists (a finished campaign): --resume returns it, '
                    '--overwrite runs the campaign again'
                )
            store.finished_table = store._read_finished()
            return store
        elif store._manifest_path.exists():
            if not resume:
                raise FileExistsError(
                    f'{store.directory} holds an unfinished campaign ({store._count_parts()} of '
                    f'{campaign.runs} runs in {store.parts_directory}): --resume continues it, '
                    '--overwrite starts over'
                )
            store._check(store._read_manifest(), store._manifest_path)
            store.parts = store._scan_parts()
        elif store._part_files():
            raise FileExistsError(
                f'{store.parts_directory} holds part files but no {MANIFEST_FILE} (what made them '
                'is unknown): --overwrite starts over'
            )
        elif store._trajectory_files():
            raise FileExistsError(
                f'{store.trajectories_directory} holds trajectory files but there is no campaign '
                f'({RESULTS_FILE} or {PARTS_DIRECTORY}/{MANIFEST_FILE}) that made them: '
                '--overwrite starts over'
            )
        store._start()
        return store

    @property
    def _manifest_path(self) -> Path:
        return self.parts_directory / MANIFEST_FILE

    def _read_manifest(self) -> dict:
        try:
            found = json.loads(self._manifest_path.read_text(encoding='utf-8'))
        except (OSError, ValueError) as error:
            raise ResumeError(
                f'{self._manifest_path}: cannot be read ({error}); --overwrite starts over'
            ) from None
        if not isinstance(found, dict):
            raise ResumeError(
                f"{self._manifest_path}: not a campaign's manifest; --overwrite starts over"
            )
        return found

    def _start(self) -> None:
        self.parts_directory.mkdir(parents=True, exist_ok=True)
        manifest = json.dumps(provenance(self.campaign), indent=1, sort_keys=True)
        write_whole(self._manifest_path, lambda path: path.write_text(manifest, encoding='utf-8'))
        write_whole(
            self.directory / CAMPAIGN_FILE,
            lambda path: path.write_text(self.campaign.text, encoding='utf-8'),
        )

    def _check(self, found: dict, where: Path) -> None:
        """Refuse a directory whose runs were made of another campaign file, scene or versions."""
        expected = provenance(self.campaign)
        differences = []
        if found.get('campaign') != expected['campaign']:
            where_ = _first_difference(found.get('campaign'), expected['campaign'])
            differences.append(f'its campaign file differs from {self.campaign.source}{where_}')
        if found.get('scene') != expected['scene']:
            differences.append(f'its scene ({self.campaign.scene.source}) differs')
        old, new = found.get('versions') or {}, expected['versions']
        changed = [
            f'{name} {old.get(name)} (now {new.get(name)})'
            for name in sorted(set(old) | set(new))
            if old.get(name) != new.get(name)
        ]
        if changed:
            differences.append(
                'it was made with '
                + ', '.join(changed)
                + ", and runs made by other versions need not be bit for bit this run's"
            )
        if differences:
            raise ResumeError(
                f'{where}: cannot resume: '
                + '; '.join(differences)
                + '. --overwrite starts over, or choose another output directory'
            )

    def _read_finished(self):
        import pyarrow.parquet as pq

        try:
            table = pq.read_table(self.results_path)
        except (OSError, ValueError) as error:  # pyarrow's ArrowInvalid is a ValueError
            raise ResumeError(
                f"{self.results_path}: cannot be read as a campaign's table ({error}); "
                '--overwrite runs the campaign again'
            ) from None
        self._check(provenance_of(table, self.results_path), self.results_path)
        return table

    def _part_files(self) -> list[tuple[int, int, Path]]:
        return _parts_in(self.parts_directory)

    def _count_parts(self) -> int:
        return sum(stop - start for start, stop, _ in self._part_files())

    def _scan_parts(self) -> dict:
        """
        Find the parts that are whole: start -> stop; remove a torn one.

        A torn part's runs are computed again.
        """
        import pyarrow.parquet as pq

        # a write interrupted before its rename
        for leftover in self.parts_directory.glob('.*.tmp'):
            leftover.unlink()
        parts, previous = {}, None
        for start, stop, path in self._part_files():
            if not 0 <= start < stop <= self.campaign.runs:
                raise ResumeError(
                    f'{path}: runs {start} to {stop - 1} are not runs of this campaign '
                    f'(0 to {self.campaign.runs - 1})'
                )
            try:
                whole = pq.read_metadata(path).num_rows == stop - start
            except (OSError, ValueError):
                whole = False
            if whole and self.campaign.trajectory_every:
                whole = self._trajectory_part_whole(start, stop, path)
            if not whole:
                path.unlink()
                (self.trajectories_directory / part_name(start, stop)).unlink(missing_ok=True)
                continue
            if previous is not None and start < previous[1]:
                raise ResumeError(
                    f'{path}: overlaps {self.parts_directory / part_name(*previous)}; '
                    '--overwrite starts over'
                )
            parts[start], previous = stop, (start, stop)
        # a trajectory part written before a results part that never was
        for start, stop, path in self._trajectory_files():
            if parts.get(start) != stop:
                path.unlink()
        return parts

    def _trajectory_part_whole(self, start: int, stop: int, results_part: Path) -> bool:
        """
        Tell whether the chunk's trajectory part is there, readable and whole.

        Whole: with this campaign's columns and a row per finished run and kept time.
        """
        import pyarrow.parquet as pq

        try:
            found = pq.read_metadata(self.trajectories_directory / part_name(start, stop))
            finished = (
                pq.read_table(results_part, columns=['status'])
                .column('status')
                .to_pylist()
                .count('ok')
            )
        except (OSError, ValueError, KeyError):
            return False
        return (
            tuple(found.schema.names) == self.campaign.trajectory_columns
            and found.num_rows == finished * self.campaign.trajectory_times.size
        )

    def _trajectory_files(self) -> list[tuple[int, int, Path]]:
        if self.trajectories_directory.is_dir():
            # a write interrupted before its rename
            for leftover in self.trajectories_directory.glob('.*.tmp'):
                leftover.unlink()
        return _parts_in(self.trajectories_directory)

    def _remove_campaign_files(self) -> None:
        """Remove only the files a campaign writes: a directory's other contents stay."""
        for _, _, path in self._part_files():
            path.unlink()
        if self.parts_directory.is_dir():
            for path in list(self.parts_directory.glob('.*.tmp')) + [self._manifest_path]:
                if path.exists():
                    path.unlink()
            try:
                self.parts_directory.rmdir()
            except OSError:
                pass  # something else lives there: leave it
        if self.results_path.exists():
            self.results_path.unlink()
        for _, _, path in self._trajectory_files():
            path.unlink()
        try:
            self.trajectories_directory.rmdir()
        except OSError:
            pass  # absent, or something else lives there

    # -- the runs ---------------------------------------------------------------------------------
    def missing(self, size: int) -> list[tuple[int, int]]:
        """Return the chunks (of at most ``size`` runs) that no part holds, in run order."""
        ranges, cursor = [], 0
        for start, stop in sorted(self.parts.items()) + [(self.campaign.runs, self.campaign.runs)]:
            for low in range(cursor, start, size):
                ranges.append((low, min(low + size, start)))
            cursor = max(cursor, stop)
        return ranges

    def write_part(self, start: int, stop: int, columns: dict) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.table(
            {
                name: (pa.array(values, pa.string()) if name in _STRING_COLUMNS else values)
                for name, values in columns.items()
            }
        )
        # floats stored plain (no dictionary):
        # every bit of a float, NaN payloads included, comes back
        write_whole(
            self.parts_directory / part_name(start, stop),
            lambda path: pq.write_table(
                table, path, compression='zstd', use_dictionary=list(_STRING_COLUMNS)
            ),
        )
        self.parts[start] = stop

    def write_trajectories(self, start: int, stop: int, columns: dict) -> None:
        """
        Write a chunk's kept samples as ``trajectories/runs-START-STOP.parquet``.

        The file is written whole, before the chunk's results part (see :meth:`write_part`).
        """
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.table(
            {
                name: pa.array(columns[name], pa.int64() if name == 'run' else pa.float64())
                for name in self.campaign.trajectory_columns
            }
        )
        self.trajectories_directory.mkdir(parents=True, exist_ok=True)
        write_whole(
            self.trajectories_directory / part_name(start, stop),
            lambda path: pq.write_table(table, path, compression='zstd', use_dictionary=False),
        )

    def read_part(self, start: int) -> dict:
        """
        Read a part's columns as the engine gave them.

        They are numpy arrays; ``status`` and ``reason`` are lists.
        """
        import pyarrow.parquet as pq

        path = self.parts_directory / part_name(start, self.parts[start])
        try:
            table = pq.read_table(path)
        except (OSError, ValueError) as error:
            raise ResumeError(
                f'{path}: cannot be read ({error}); remove it and resume to compute its runs again'
            ) from None
        return {
            name: (
                table.column(name).to_pylist()
                if name in _STRING_COLUMNS
                else table.column(name).to_numpy()
            )
            for name in table.column_names
        }

    def finish(self, table) -> Path:
        """Write ``runs.parquet`` whole, then remove the parts."""
        import pyarrow.parquet as pq

        write_whole(
            self.results_path, lambda path: pq.write_table(table, path, compression='zstd')
        )
        for _, _, path in self._part_files():
            path.unlink()
        self._manifest_path.unlink(missing_ok=True)
        try:
            self.parts_directory.rmdir()
        except OSError:
            pass
        self.finished_table = table
        return self.results_path


def provenance_of(table, where) -> dict:
    """Return what made a finished table (its metadata), in the manifest's form."""
    meta = table.schema.metadata or {}
    try:
        return {
            'campaign': meta[b'torquefree_ros.campaign'].decode('utf-8'),
            'scene': json.loads(meta[b'torquefree_ros.scene']),
            'versions': json.loads(meta[b'torquefree_ros.versions']),
        }
    except (KeyError, ValueError):
        raise ResumeError(
            f"{where}: not a campaign's table (its metadata lacks the campaign, the scene or the "
            'versions)'
        ) from None


def _first_difference(old, new) -> str:
    if not isinstance(old, str):
        return ''
    old_lines, new_lines = old.splitlines(), new.splitlines()
    for number, (a, b) in enumerate(zip(old_lines, new_lines), start=1):
        if a != b:
            return f' at line {number} ({a.strip()[:60]!r}, now {b.strip()[:60]!r})'
    return f' (line {min(len(old_lines), len(new_lines)) + 1}: one has more lines)'


def _parts_in(directory: Path) -> list[tuple[int, int, Path]]:
    """
    List ``(start, stop, path)`` of the part files in ``directory``, by start.

    None when the directory does not exist.
    """
    found = []
    if directory.is_dir():
        for path in directory.iterdir():
            match = _PART.match(path.name)
            if match:
                found.append((int(match.group(1)), int(match.group(2)), path))
    return sorted(found)
