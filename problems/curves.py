"""Point sets: the seed paper's curves, files, and seeded noise."""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from metaknot.bspline import as_points

__all__ = [
    "CURVES",
    "PointSet",
    "add_noise",
    "archimedean_spiral",
    "epitrochoid",
    "get_curve",
    "load_points",
    "vivaldi",
]


@dataclass(frozen=True, eq=False)
class PointSet:
    """Data points to approximate, with optional explicit parameter values.

    Attributes
    ----------
    points
        Array of shape ``(N, d)``.
    name
        Label used in run records and reports.
    params
        Explicit parameter values (function data ``y = f(x)``: the ``x``), or ``None`` to
        parameterize the points.
    noise, noise_seed
        Standard deviation of the Gaussian noise added by :func:`add_noise` (0: none) and a
        description of the seed it was drawn with (recorded with every run).
    """

    points: np.ndarray
    name: str = "points"
    params: np.ndarray | None = field(default=None)
    noise: float = 0.0
    noise_seed: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "points", as_points(self.points, degree=1, name=self.name))
        if self.params is not None:
            params = np.asarray(self.params, dtype=np.float64)
            if params.shape != (self.points.shape[0],):
                raise ValueError(
                    f"{self.name}: params must have shape ({self.points.shape[0]},); "
                    f"got {params.shape}"
                )
            object.__setattr__(self, "params", params)

    @property
    def n_points(self) -> int:
        return int(self.points.shape[0])

    @property
    def dim(self) -> int:
        return int(self.points.shape[1])

    @property
    def fingerprint(self) -> str:
        """Short SHA-256 of the points (and explicit parameters): equal data, equal print."""
        digest = hashlib.sha256(np.ascontiguousarray(self.points, dtype="<f8").tobytes())
        digest.update(str(self.points.shape).encode())
        if self.params is not None:
            digest.update(np.ascontiguousarray(self.params, dtype="<f8").tobytes())
        return digest.hexdigest()[:16]

    def describe(self) -> dict[str, object]:
        """What run records store about the data."""
        return {"data": self.name, "data_fingerprint": self.fingerprint,
                "n_points": self.n_points, "dim": self.dim, "noise": self.noise,
                "noise_seed": self.noise_seed}

    @property
    def scale(self) -> float:
        """Diagonal of the bounding box: the length scale for relative tolerances."""
        return float(np.linalg.norm(np.ptp(self.points, axis=0))) or 1.0


def epitrochoid(n_points: int = 361, a: float = 5.0, b: float = 1.0, h: float = 4.0) -> PointSet:
    """The seed's epitrochoid: ``t`` from -180 to 180 degrees (361 points: 1-degree steps)."""
    t = np.radians(np.linspace(-180.0, 180.0, n_points))
    ratio = a / b + 1.0
    x = (a + b) * np.cos(t) - h * np.cos(ratio * t)
    y = (a + b) * np.sin(t) - h * np.sin(ratio * t)
    return PointSet(np.column_stack((x, y)), name="epitrochoid")


def archimedean_spiral(n_points: int = 100, a: float = 2.0) -> PointSet:
    """The seed's Archimedean spiral ``r = a t``, ``t`` in ``[0, pi]`` (100 points)."""
    t = np.linspace(0.0, np.pi, n_points)
    r = a * t
    return PointSet(np.column_stack((r * np.cos(t), r * np.sin(t))), name="archimedean")


def vivaldi(n_points: int = 241, a: float = 0.5) -> PointSet:
    """The seed's Vivaldi curve (3-D), ``t`` from -360 to 360 degrees (241 points)."""
    t = np.radians(np.linspace(-360.0, 360.0, n_points))
    pts = np.column_stack((a * (1.0 + np.cos(t)), a * np.sin(t), 2.0 * a * np.sin(t / 2.0)))
    return PointSet(pts, name="vivaldi")


CURVES: dict[str, Callable[..., PointSet]] = {
    "epitrochoid": epitrochoid,
    "archimedean": archimedean_spiral,
    "vivaldi": vivaldi,
}


def get_curve(name: str, **kwargs: float) -> PointSet:
    """A seed curve by name (``epitrochoid``, ``archimedean``, ``vivaldi``)."""
    try:
        factory = CURVES[name]
    except KeyError:
        raise ValueError(
            f"unknown curve {name!r}; choose one of {', '.join(sorted(CURVES))} "
            "or load points from a file"
        ) from None
    return factory(**kwargs)


def load_points(path: str | Path, *, params_column: int | None = None) -> PointSet:
    """Load points from a ``.npy`` file or a CSV file (comma-separated, optional header row).

    Parameters
    ----------
    path
        File with one point per row and one coordinate per column.
    params_column
        Index of a column holding explicit parameter values (for example ``x`` of function
        data); the remaining columns become the points.

    Raises
    ------
    ValueError
        If the file is missing, empty, ragged, not numeric or holds NaN/inf.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"point file not found: {path}")
    if path.suffix.lower() == ".npy":
        try:
            data = np.load(path, allow_pickle=False)
        except (ValueError, OSError, EOFError) as exc:
            raise ValueError(f"{path}: not a readable .npy array ({exc})") from None
    elif path.suffix.lower() in (".csv", ".txt"):
        data = _read_csv(path)
    else:
        raise ValueError(f"{path}: unsupported file type {path.suffix!r} (use .csv or .npy)")
    data = np.asarray(data)
    if data.ndim == 1:
        data = data[:, None]
    if data.ndim != 2 or data.size == 0:
        raise ValueError(f"{path}: expected a 2-D table of points; got shape {data.shape}")
    if not (np.issubdtype(data.dtype, np.integer) or np.issubdtype(data.dtype, np.floating)):
        raise ValueError(f"{path}: values must be real numbers; got dtype {data.dtype}")
    params = None
    if params_column is not None:
        if not -data.shape[1] <= params_column < data.shape[1] or data.shape[1] < 2:
            raise ValueError(f"{path}: params_column {params_column} is not a valid column")
        params = data[:, params_column].astype(np.float64)
        data = np.delete(data, params_column, axis=1)
    try:
        return PointSet(data, name=path.stem, params=params)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def _read_csv(path: Path) -> np.ndarray:
    lines = [ln.strip() for ln in path.read_text().splitlines()]
    lines = [ln for ln in lines if ln and not ln.startswith("#")]
    if not lines:
        raise ValueError(f"{path}: the file holds no data rows")
    rows = [ln.split(",") for ln in lines]
    if not any(_is_number(v) for v in rows[0]):
        rows = rows[1:]  # a header row: no field is a number
    if not rows:
        raise ValueError(f"{path}: the file holds a header but no data rows")
    widths = {len(r) for r in rows}
    if len(widths) != 1:
        raise ValueError(f"{path}: rows have different numbers of columns {sorted(widths)}")
    try:
        return np.array([[float(v) for v in r] for r in rows])
    except ValueError as exc:
        raise ValueError(f"{path}: non-numeric value ({exc})") from None


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def add_noise(data: PointSet, sigma: float,
              seed: int | np.random.SeedSequence | np.random.Generator | None) -> PointSet:
    """Copy of ``data`` with Gaussian noise of standard deviation ``sigma`` on every coordinate.

    ``seed`` (an int, a ``SeedSequence`` or a ``Generator``) makes the noise reproducible; ints
    and seed sequences are recorded in the result's ``noise_seed``.
    """
    if not np.isfinite(sigma) or sigma < 0:
        raise ValueError(f"noise sigma must be a finite value >= 0; got {sigma}")
    rng = np.random.default_rng(seed)
    noisy = data.points + rng.normal(0.0, sigma, size=data.points.shape)
    return PointSet(noisy, name=f"{data.name}+noise{sigma:g}", params=data.params,
                    noise=float(sigma), noise_seed=describe_seed(seed))


def describe_seed(seed: object) -> str | None:
    """A seed as text: an int as itself, a ``SeedSequence`` as ``entropy/spawn,key``."""
    if isinstance(seed, np.random.SeedSequence):
        key = ",".join(str(k) for k in seed.spawn_key)
        return f"{seed.entropy}/{key}" if key else str(seed.entropy)
    if isinstance(seed, int | np.integer) and not isinstance(seed, bool):
        return str(int(seed))
    return None
