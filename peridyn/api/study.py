"""``Study``: many runs of one deck with varied parameters, a results table, resumable.

Each run has its own folder ``<folder>/run_0001`` (numbered from 1 in the order of the
parameter sets) holding its output files, the deck it ran (``deck.yaml``) and ``status.json``:
``{"parameters", "status": "running" | "done" | "failed", "results", "error", "wall"}``. A run
whose ``status.json`` says ``done`` for the same parameters is skipped when the study runs
again; a run that was interrupted (``running``), failed, or whose parameters changed is run
again. The table (``results.csv`` and ``results.json`` in the study folder) has one row per run:
``run``, ``status``, the parameters (by deck path), and what ``extract`` returned.
"""
from __future__ import annotations

import csv
import itertools
import json
import logging
import os
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..core.resources import usable_cores
from .checks import ArgumentError, ArgumentTypeError, a_callable, whole_number
from .decks import DeckLike, deck_tree, plain

CALL = "Study"

log = logging.getLogger("peridyn.api")

#: what ``extract`` returns: quantity name -> number (or anything JSON can hold)
Extract = Callable[[Any], Mapping[str, Any]]


def set_deck_value(tree: dict, path: str, value: Any) -> None:
    """Set ``tree[a][b][c] = value`` for the deck path ``"a/b/c"`` (sections created when
    missing; the deck's validation reports keys that mean nothing)."""
    keys = [k for k in path.split("/") if k]
    if not keys:
        raise ValueError(f"empty deck path {path!r}")
    node = tree
    for k in keys[:-1]:
        child = node.setdefault(k, {})
        if not isinstance(child, dict):
            raise ValueError(f"deck path {path!r}: {k!r} holds a value, not a section")
        node = child
    node[keys[-1]] = value


def _plain(value: Any) -> Any:
    """A JSON-friendly copy (numpy numbers as Python numbers)."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "tolist"):
        return value.tolist()
    return value


def check_parameters(parameters: Any) -> list[dict[str, Any]]:
    """The parameter sets as plain dicts (numpy values as Python values, lists as a YAML deck
    reads them); an ArgumentError for anything that is not a non-empty sequence of mappings of
    deck paths to values a deck can hold."""
    from ..deck.files import dump_yaml

    if isinstance(parameters, (str, bytes, Mapping)) or not isinstance(parameters, Iterable):
        raise ArgumentTypeError(f"parameters must be a list of mappings (one per run), not {type(parameters).__name__}",
                                path=(CALL, "parameters"), fix="give [{'Materials/Glass/Density': 2440.0}, ...] or Study.grid(...)")
    out = []
    for k, params in enumerate(parameters):
        if not isinstance(params, Mapping):
            raise ArgumentTypeError(f"parameters[{k}] is a {type(params).__name__}, not a mapping deck path -> value",
                                    path=(CALL, "parameters"), fix="give {'Section/Key': value}")
        for path, value in params.items():
            if not isinstance(path, str) or not [p for p in path.split("/") if p]:
                raise ArgumentError(f"parameters[{k}]: {path!r} is not a deck path", path=(CALL, "parameters"),
                                    fix="name a deck value by its keys joined by '/', e.g. 'Materials/Glass/Density'")
            try:
                dump_yaml({"v": plain(value)}, top_key=None)
            except (ValueError, TypeError, RecursionError) as exc:
                raise ArgumentError(f"parameters[{k}][{path!r}]: a deck cannot hold {value!r} ({exc})", path=(CALL, "parameters"),
                                    fix="give a bool, int, float, str, a list of one kind of them, or a mapping") from None
        out.append(plain(dict(params)))
    if not out:
        raise ArgumentError("a study needs at least one parameter set", path=(CALL, "parameters"), fix="give one mapping per run")
    return out


class Study:
    """Runs of one deck, each with some deck values changed.

    ``deck``: a deck file or a dict deck; ``parameters``: one mapping per run, deck path
    (``"Materials/Glass/Critical Stretch"``, keys joined by ``/``) -> value; ``folder``: the
    study's folder (created); ``extract(model) -> {name: value}``: what to keep of a finished
    run (a module-level function when ``processes > 1``: it travels to the worker processes);
    ``directory``: where the relative file names of a dict deck are read from (a deck file's
    own folder for a file).
    """

    def __init__(self, deck: DeckLike, parameters: Sequence[Mapping[str, Any]], folder: str | os.PathLike,
                 extract: Extract | None = None, *, directory: str | os.PathLike | None = None) -> None:
        if not isinstance(deck, (Mapping, str, os.PathLike)):
            raise ArgumentTypeError(f"deck must be a deck file name or a dict deck, not {type(deck).__name__}", path=(CALL, "deck"),
                                    fix="give 'deck.yaml' or the deck's sections as a dict")
        if not isinstance(folder, (str, os.PathLike)):
            raise ArgumentTypeError(f"folder must be a folder name, not {type(folder).__name__}", path=(CALL, "folder"), fix="give a path")
        if directory is not None and not isinstance(directory, (str, os.PathLike)):
            raise ArgumentTypeError(f"directory must be a folder name, not {type(directory).__name__}", path=(CALL, "directory"),
                                    fix="give a path, or None")
        if extract is not None:
            a_callable(CALL, "extract", extract, "extract(model) -> {name: value}")
        if not isinstance(deck, Mapping):
            directory = Path(deck).resolve().parent if directory is None else directory
        self.tree = deck_tree(deck)
        self.directory = Path(directory).resolve() if directory is not None else Path.cwd()
        self.parameters = check_parameters(parameters)
        self.folder = Path(folder)
        self.extract = extract

    @staticmethod
    def grid(**axes: Iterable[Any]) -> list[dict[str, Any]]:
        """Every combination of the values given per deck path (keyword names cannot hold
        ``/``: pass ``Study.grid(**{"Materials/Glass/Density": [1, 2], ...})``)."""
        names = list(axes)
        for name in names:
            values = axes[name]
            if isinstance(values, (set, frozenset)):  # no order: the runs' numbering would change from one session to the next
                raise ArgumentTypeError(f"{name}: the values of an axis are a list, not a set (a set has no order, so the runs "
                                        "would be numbered differently in another session)", path=("Study.grid", name),
                                        fix=f"give {name}=[value, ...] in the order the runs are numbered")
            if isinstance(values, (str, bytes, Mapping)) or not isinstance(values, Iterable):
                raise ArgumentTypeError(f"{name}: the values of an axis are a list, not {type(values).__name__} {values!r}",
                                        path=("Study.grid", name), fix=f"give {name}=[value, ...] (a list of one value for a fixed one)")
            if not list(values):
                raise ArgumentError(f"{name}: an axis needs at least one value", path=("Study.grid", name), fix="give a non-empty list")
        return [dict(zip(names, combo)) for combo in itertools.product(*(list(axes[n]) for n in names))]

    def run_folder(self, k: int) -> Path:
        """The folder of run ``k`` (0-based index into ``parameters``)."""
        return self.folder / f"run_{k + 1:04d}"

    def status(self, k: int) -> dict[str, Any] | None:
        """The ``status.json`` of run ``k``, or None when it never started."""
        path = self.run_folder(k) / "status.json"
        try:
            return json.loads(path.read_text())
        except (FileNotFoundError, json.JSONDecodeError):
            return None

    def pending(self) -> list[int]:
        """Runs still to do: never started, interrupted, failed, or run with other parameters."""
        out = []
        for k, params in enumerate(self.parameters):
            st = self.status(k)
            if not (st and st.get("status") == "done" and st.get("parameters") == params):
                out.append(k)
        return out

    def run(self, processes: int = 1) -> list[dict[str, Any]]:
        """Run the pending runs (in this process, or in ``processes`` worker processes, each
        with its share of the cores for its numba threads) and write the table. Returns the
        table's rows. A run that fails is marked ``failed`` in its row (its error in
        ``status.json``) and the others go on; Ctrl-C stops the study, and the next ``run``
        picks up from the runs not done."""
        processes = whole_number("Study.run", "processes", processes, 1)
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:  # a file in the way (FileExistsError), no permission, a name too long
            raise ArgumentError(f"folder {str(self.folder)!r} cannot be a folder: {exc.strerror}", path=("Study", "folder"),
                                fix="give a folder (it is created with its parents) that is not a file") from None
        todo = self.pending()
        log.info("study %s: %d run(s), %d to do", self.folder, len(self.parameters), len(todo))
        jobs = [(self.tree, str(self.directory), self.parameters[k], str(self.run_folder(k)), self.extract) for k in todo]
        try:
            if processes <= 1 or len(jobs) <= 1:
                for job in jobs:
                    run_one(*job)
            else:
                self._run_pool(jobs, processes)
        finally:
            self.write_table()
        return self.table()

    @staticmethod
    def _run_pool(jobs: list[tuple], processes: int) -> None:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        cores = usable_cores()
        workers = min(processes, len(jobs))
        # the workers start fresh (spawn) and read these before numba loads: threads x workers = cores
        env = {"NUMBA_NUM_THREADS": str(max(1, cores // workers)), "OMP_WAIT_POLICY": "PASSIVE",
               "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
        saved = {k: os.environ.get(k) for k in env}
        os.environ.update(env)
        try:
            with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn")) as pool:
                for future in [pool.submit(run_one, *job) for job in jobs]:
                    future.result()
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v

    def table(self) -> list[dict[str, Any]]:
        """One row per run: ``run`` (folder name), ``status``, the parameters, the results."""
        rows = []
        for k, params in enumerate(self.parameters):
            st = self.status(k) or {}
            state = st.get("status", "pending") if st.get("parameters", params) == params else "pending"
            row: dict[str, Any] = {"run": self.run_folder(k).name, "status": state, **params}
            if state == "done":
                row.update(st.get("results") or {})
            elif state == "failed":
                row["error"] = st.get("error", "")
            rows.append(row)
        return rows

    def write_table(self) -> None:
        """Write ``results.csv`` and ``results.json`` in the study folder."""
        rows = self.table()
        columns: list[str] = []
        for row in rows:
            columns.extend(c for c in row if c not in columns)
        (self.folder / "results.json").write_text(json.dumps(rows, indent=1) + "\n")
        with open(self.folder / "results.csv", "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=columns)
            writer.writeheader()
            for row in rows:
                writer.writerow({c: row.get(c, "") for c in columns})


def run_one(tree: dict, directory: str, parameters: dict[str, Any], folder: str, extract: Extract | None) -> str:
    """One run of a study (module level: worker processes call it). Returns its status."""
    import copy

    from ..core.errors import InputError, InstabilityError
    from ..deck.files import dump_yaml
    from .model import Model

    run_dir = Path(folder)
    run_dir.mkdir(parents=True, exist_ok=True)
    status_path = run_dir / "status.json"

    def record(state: str, **more: Any) -> None:
        tmp = status_path.with_suffix(".tmp")
        tmp.write_text(json.dumps({"parameters": parameters, "status": state, **more}, indent=1) + "\n")
        os.replace(tmp, status_path)  # a reader never sees half a file

    record("running")
    wall0 = time.perf_counter()
    deck = copy.deepcopy(tree)
    try:
        for path, value in parameters.items():
            set_deck_value(deck, path, value)
        (run_dir / "deck.yaml").write_text(f"# run of a study; relative file names are relative to {directory}\n" + dump_yaml(deck))
        model = Model(deck, directory=directory, output_dir=run_dir)
        with model:
            model.run()
            results = _plain(dict(extract(model))) if extract is not None else {}
    except (InputError, InstabilityError, ValueError, ArithmeticError) as exc:
        text = exc.one_line() if isinstance(exc, InputError) else f"{type(exc).__name__}: {exc}"
        log.error("%s: %s", run_dir.name, text)
        record("failed", error=text, wall=time.perf_counter() - wall0)
        return "failed"
    record("done", results=results, wall=time.perf_counter() - wall0)
    log.info("%s: done in %.2f s", run_dir.name, time.perf_counter() - wall0)
    return "done"
