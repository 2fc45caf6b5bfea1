"""What a verification problem is: a ladder of resolutions per method, a measurement per
point, and the bands its results must fall in."""
from __future__ import annotations

import contextlib
import copy
import math
from collections.abc import Iterator
from contextvars import ContextVar
from dataclasses import asdict, dataclass, field
from typing import Any, ClassVar

from ..fit import fit_rate

#: the suffix of a method's curve run on the GPU backend (``peridyn verify --device gpu``)
GPU = " (GPU)"
_DEVICE: ContextVar[str] = ContextVar("peridyn_verify_device", default="cpu")


def base_method(method: str) -> str:
    """The problem's own method name of the curve ``method`` (``"Elastic (GPU)"`` -> ``"Elastic"``)."""
    return method[: -len(GPU)] if method.endswith(GPU) else method


def device_of(method: str) -> str:
    """"gpu" for a GPU curve's name, else "cpu"."""
    return "gpu" if method.endswith(GPU) else "cpu"


def current_device() -> str:
    """The device of the point being measured ("cpu" or "gpu"; see :func:`on_device`)."""
    return _DEVICE.get()


@contextlib.contextmanager
def on_device(device: str) -> Iterator[None]:
    """Within the block, :func:`simulation` builds models on ``device`` ("cpu" or "gpu")."""
    token = _DEVICE.set(device)
    try:
        yield
    finally:
        _DEVICE.reset(token)


def simulation(tree: dict[str, Any], **kwargs: Any) -> Any:
    """``peridyn.testing.build_simulation`` on the device of the point being measured: the GPU
    backend (``cuda``) inside ``on_device("gpu")``, the default CPU backend otherwise. Problems
    that list a method in ``gpu_methods`` build its models through this."""
    from ...testing import build_simulation

    return build_simulation(tree, backend="cuda" if current_device() == "gpu" else None, **kwargs)


@dataclass
class Measurement:
    """What one point of a problem measured.

    ``error``: the point's error (dimensionless unless the problem's ``error_name`` says
    otherwise); ``size``: the step the rate is fitted against (h/delta, dt in s, ...; None for a
    table problem); ``steps``: time steps or force evaluations the point ran; ``values``: other
    numbers worth a column (named with their units)."""

    error: float | None
    size: float | None = None
    steps: int = 0
    values: dict[str, Any] = field(default_factory=dict)


@dataclass
class Check:
    """One band a problem's result must fall in: ``value`` within [``low``, ``high``]."""

    problem: str
    method: str
    what: str
    value: float
    low: float = -math.inf
    high: float = math.inf
    #: what the report shows instead of ``value`` (a table problem's outcome), and instead of the band
    shown: str | None = None
    expect: str | None = None
    #: a failure known and reported as such: why the model misses this band and what a fix needs. A
    #: known failure is shown as FAIL in the report and counted apart ("known misses"); it does not
    #: set the exit status, so that ``peridyn verify`` still gates on the failures that are news
    known: str | None = None

    @property
    def counts(self) -> bool:
        """Whether this check fails the run: it fails and is not a known miss."""
        return not self.passed and self.known is None

    @property
    def passed(self) -> bool:
        return math.isfinite(self.value) and self.low <= self.value <= self.high

    def band(self) -> str:
        if self.expect is not None:
            return self.expect
        if math.isinf(self.low):
            return f"<= {self.high:.3g}"
        if math.isinf(self.high):
            return f">= {self.low:.3g}"
        return f"{self.low:.3g} .. {self.high:.3g}"

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d.update(low=_num(self.low), high=_num(self.high), value=_num(self.value), passed=self.passed, band=self.band())
        if self.known is None:
            d.pop("known")
        return d


def _num(v: float) -> float | None:
    """JSON has no inf or NaN: None stands for them."""
    return v if math.isfinite(v) else None


class Problem:
    """A verification problem. Subclasses set the class attributes and :meth:`measure`."""

    name: ClassVar[str]
    title: ClassVar[str]
    #: "curve": error against resolution, fitted rate and a figure; "table": a table (and a figure of
    #: error against wall time when ``plotted``)
    kind: ClassVar[str] = "curve"
    #: whether the report draws the points' error against their wall time: every curve, and a
    #: table whose error is an error (not a ratio to a band, a count or an outcome)
    plotted: ClassVar[bool] = True
    #: markdown: what is computed
    computes: ClassVar[str]
    #: markdown: the exact or reference answer and where it comes from
    reference: ClassVar[str]
    #: what ``resolution`` counts (e.g. "delta/h", "steps") and what ``size`` is (e.g. "h/delta")
    resolution_name: ClassVar[str]
    size_name: ClassVar[str] = "size"
    error_name: ClassVar[str] = "relative error"
    methods: ClassVar[tuple[str, ...]]
    #: the methods that also run on the GPU backend, as their own curves "<method> (GPU)" under
    #: ``peridyn verify --device gpu`` (their models built by :func:`simulation`, explicit
    #: solvers only, the fields read once the solver has finished)
    gpu_methods: ClassVar[tuple[str, ...]] = ()

    #: curves measured beside each point and drawn on the same axes: name -> (the value holding
    #: its error, the value holding its wall time in s), e.g. Verlet's run at Newmark's steps
    companions: ClassVar[dict[str, tuple[str, str]]] = {}
    #: False when a method's points depend on each other (one reads what another measured):
    #: under ``mpiexec`` one rank then measures all the points of a method
    independent_points: ClassVar[bool] = True

    #: per method: the registered material it runs where the method is not named by it (by default
    #: a method runs the material its name starts with, up to a comma: "Elastic, K/G = 1000")
    method_materials: ClassVar[dict[str, str]] = {}
    #: the relative change of a point's error that ``peridyn verify --compare`` tolerates
    compare_rtol: ClassVar[float] = 0.05

    def material_of(self, method: str) -> str:
        """The material ``method`` runs (see ``method_materials``)."""
        return self.method_materials.get(method, method.split(",")[0].strip())

    def for_material(self, material: str) -> "Problem | None":
        """This problem restricted to the methods that run ``material`` (``peridyn verify
        --material``); None when none does."""
        chosen = tuple(m for m in self.methods if self.material_of(m) == material)
        if not chosen:
            return None
        out = copy.copy(self)
        out.methods = chosen
        out.gpu_methods = tuple(m for m in self.gpu_methods if m in chosen)
        return out

    def curves(self, device: str = "cpu") -> tuple[str, ...]:
        """The curves run: every method, and with ``device="gpu"`` each GPU method's twin."""
        return self.methods + (tuple(m + GPU for m in self.gpu_methods) if device == "gpu" else ())

    def ladder(self, method: str, quick: bool) -> list[float]:
        """The resolutions to run for ``method``, coarsest first."""
        raise NotImplementedError

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        """Run one point (in-process, serial)."""
        raise NotImplementedError

    # -- bands -------------------------------------------------------------------------------
    #: per method: why no rate is fitted to its points (an error that does not converge steadily)
    unfitted: ClassVar[dict[str, str]] = {}
    #: per method: (low, high) of the fitted rate, or None for no rate band
    rate_band: ClassVar[dict[str, tuple[float, float]]] = {}
    #: per method: the largest allowed error at the finest resolution run
    finest_band: ClassVar[dict[str, float]] = {}
    #: per method: the largest allowed error at every point
    every_band: ClassVar[dict[str, float]] = {}
    #: Peridigm's own measurements of the same quantity, drawn on the same axes: dicts with
    #: "method" (the curve it belongs beside), "error", "wall (s)" and "what" (deck, machine, source)
    peridigm: ClassVar[tuple[dict[str, Any], ...]] = ()

    def rate(self, points: list[dict[str, Any]]) -> float:
        """The fitted rate of ``points`` (one method), error against size."""
        return fit_rate([p["size"] for p in points], [p["error"] for p in points])

    def checks(self, method: str, points: list[dict[str, Any]], quick: bool) -> list[Check]:
        """The bands of ``method``'s finished ``points`` (finest last); a GPU curve is held to
        its method's bands."""
        out: list[Check] = []
        if not points:
            return out
        base = base_method(method)
        if base in self.every_band:
            for p in points:
                out.append(Check(self.name, method, f"{self.error_name} at {self.resolution_name} = {p['resolution']:g}", p["error"], high=self.every_band[base]))
        if base in self.finest_band:
            p = points[-1]
            out.append(Check(self.name, method, f"{self.error_name} at the finest {self.resolution_name} = {p['resolution']:g}", p["error"], high=self.finest_band[base]))
        if base in self.rate_band and len(points) >= 3:
            lo, hi = self.rate_band[base]
            out.append(Check(self.name, method, f"fitted rate of the {self.error_name} in {self.size_name}", self.rate(points), lo, hi))
        out.extend(self.extra_checks(method, points, quick))
        return out

    def extra_checks(self, method: str, points: list[dict[str, Any]], quick: bool) -> list[Check]:
        """Further bands a problem defines (default none)."""
        return []
