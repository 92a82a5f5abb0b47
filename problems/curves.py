"""Point sets: the seed paper's curves, files, and seeded noise."""

from __future__ import annotations

import codecs
import hashlib
import itertools
from array import array
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

import numpy as np

from metaknot.bspline import as_points, check_degree
from metaknot.bspline._codegen import MAX_DIMENSION
from metaknot.bspline.parameterize import check_point_count
from metaknot.validate import is_integer

__all__ = [
    "CURVES",
    "MAX_COLUMNS",
    "MAX_LINE_CHARS",
    "MAX_POINTS",
    "MAX_TEXT_BYTES",
    "PointSet",
    "add_noise",
    "archimedean_spiral",
    "check_points_file",
    "epitrochoid",
    "get_curve",
    "header_line",
    "load_points",
    "vivaldi",
]

#: Limits of a point file (:func:`load_points`, docs/input-files.md): the most points (rows),
#: values per row (the coordinates the compiled kernels take and a parameter column),
#: characters per line and bytes of a text file. One million points is the largest size
#: measured (benchmarks/bench_input.py).
MAX_POINTS = 1_000_000
MAX_COLUMNS = MAX_DIMENSION + 1
MAX_LINE_CHARS = 4096
MAX_TEXT_BYTES = 2**28
_HEAD_BYTES = 65536  # what check_points_file reads of a text file


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


def load_points(path: str | Path, *, params_column: int | None = None,
                degree: int = 1) -> PointSet:
    """Load points from a ``.npy`` file or a text table (``.csv``/``.txt``).

    A text table has one point per line, its values separated by semicolons, else by commas,
    else by whitespace; blank lines and ``#`` comments are skipped, and so is a first row with
    no number in it (a header). Decimal commas are not read: a line that reads as numbers only
    with its commas taken as decimal points (``0,5;1,25``, ``0,5 1,25``) is an error, a first
    line too (it is no header). A file may hold at most ``MAX_POINTS`` points of at most
    ``MAX_COLUMNS`` values; :func:`check_points_file` is checked first, so a file of another
    kind is refused after reading its first bytes (docs/input-files.md).

    Parameters
    ----------
    path
        File with one point per row and one coordinate per column.
    params_column
        Index of a column holding explicit parameter values (for example ``x`` of function
        data); the remaining columns become the points.
    degree
        The spline degree the points are for: fewer than ``degree + 2`` points (too few for
        one interior knot) are refused, naming the file and the degree.

    Raises
    ------
    ValueError
        Naming the file (and the line of a text file) if it is missing, of another kind,
        empty, ragged, not numeric (decimal commas included), beyond the limits, holds
        NaN/inf or too few points for ``degree``; or if ``degree`` is not one of 1..5.
    """
    degree = check_degree(degree)
    path = check_points_file(path)
    data = _read_npy(path) if path.suffix.lower() == ".npy" else _read_text(path)
    if data.ndim == 1:
        data = data[:, None]
    params = None
    if params_column is not None:
        if not -data.shape[1] <= params_column < data.shape[1] or data.shape[1] < 2:
            raise ValueError(f"{path}: params_column {params_column} is not a valid column")
        params = data[:, params_column].astype(np.float64)
        data = np.delete(data, params_column, axis=1)
    check_point_count(data.shape[0], degree, str(path))  # the file named once
    try:
        return PointSet(data, name=path.stem, params=params)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def header_line(path: str | Path) -> tuple[int, str] | None:
    """The header row :func:`load_points` skips in a text table, so that a caller can say
    which line it dropped.

    Reads the file up to its first data row only.

    Returns
    -------
    tuple of (int, str) or None
        The header's line number and its text (stripped), or ``None`` for a ``.npy`` file or
        a table whose first row holds a number.

    Raises
    ------
    ValueError
        As :func:`load_points` does for the lines read.
    """
    path = check_points_file(path)
    if path.suffix.lower() == ".npy":
        return None
    headers: list[tuple[int, str]] = []
    next(_data_rows(path, headers), None)
    return headers[0] if headers else None


def check_points_file(path: str | Path) -> Path:
    """Check a point file from its size and first bytes, before anything reads it whole.

    The file must exist and be a ``.npy`` file whose header describes a real-valued table
    within the limits that the file is long enough to hold, or a ``.csv``/``.txt`` file of at
    most ``MAX_TEXT_BYTES`` that starts as UTF-8 text (no NUL byte).

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.

    Raises
    ------
    ValueError
        Naming the file and what is wrong with it.
    """
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path}: a folder, not a point file")
    if not path.is_file():
        raise ValueError(f"point file not found: {path}")
    suffix = path.suffix.lower()
    if suffix == ".npy":
        with path.open("rb") as file:
            _npy_header(path, file)
    elif suffix in (".csv", ".txt"):
        size = path.stat().st_size
        if size > MAX_TEXT_BYTES:
            raise ValueError(f"{path}: {size:,} bytes; a text file of points may have at most "
                             f"{MAX_TEXT_BYTES:,} (and {MAX_POINTS:,} points)")
        with path.open("rb") as file:
            head = file.read(_HEAD_BYTES)
        if b"\0" in head:
            raise ValueError(f"{path}: binary data (a NUL byte at offset {head.index(0):,}), "
                             "not a text table of numbers")
        try:
            codecs.getincrementaldecoder("utf-8")().decode(head, final=False)
        except UnicodeDecodeError as exc:
            raise ValueError(f"{path}: not UTF-8 text (byte {exc.start:,}); a text table of "
                             "numbers is expected") from None
    else:
        raise ValueError(f"{path}: unsupported file type {suffix!r} (use .csv, .txt or "
                         ".npy)")
    return path


def _npy_header(path: Path, file: BinaryIO) -> None:
    """Check the header of a ``.npy`` file: a real-valued table within the limits, and a file
    long enough to hold it."""
    fmt = np.lib.format
    try:
        version = fmt.read_magic(file)
    except ValueError:
        raise ValueError(f"{path}: not a .npy file (it does not start with the .npy "
                         "signature)") from None
    readers = {(1, 0): fmt.read_array_header_1_0, (2, 0): fmt.read_array_header_2_0}
    if version not in readers:
        raise ValueError(f"{path}: .npy format version {version[0]}.{version[1]} is not "
                         "supported (use 1.0 or 2.0)")
    try:
        shape, _, dtype = readers[version](file)
    except ValueError as exc:
        raise ValueError(f"{path}: not a readable .npy header ({_quote(str(exc))})") from None
    if dtype.hasobject or dtype.kind not in "iuf":
        raise ValueError(f"{path}: values must be real numbers; got dtype "
                         f"{_quote(str(dtype))}")
    _check_table_shape(path, shape)
    data_bytes = int(np.prod(shape)) * dtype.itemsize
    held = path.stat().st_size - file.tell()
    if held < data_bytes:
        raise ValueError(f"{path}: truncated: its header describes a {shape} {dtype} array "
                         f"of {data_bytes:,} bytes; the file holds {held:,}")


def _check_table_shape(path: Path, shape: tuple[int, ...]) -> None:
    if len(shape) not in (1, 2) or 0 in shape:
        raise ValueError(f"{path}: expected a 2-D table of points; got shape {shape}")
    if shape[0] > MAX_POINTS:
        raise ValueError(f"{path}: {shape[0]:,} points; a file may hold at most "
                         f"{MAX_POINTS:,} points")
    if len(shape) == 2 and shape[1] > MAX_COLUMNS:
        raise ValueError(f"{path}: {shape[1]:,} columns; a file may have at most "
                         f"{MAX_COLUMNS} ({MAX_DIMENSION} coordinates and a parameter column)")


def _read_npy(path: Path) -> np.ndarray:
    with path.open("rb") as file:
        _npy_header(path, file)
        file.seek(0)
        try:
            return np.lib.format.read_array(file, allow_pickle=False)
        except (ValueError, OSError, EOFError) as exc:
            raise ValueError(f"{path}: not a readable .npy array ({_quote(str(exc))})") \
                from None


def _read_text(path: Path) -> np.ndarray:
    """The table of a text file, read a line at a time into one growing float buffer."""
    values = array("d")
    width = rows = width_line = 0
    for number, cells, text in _data_rows(path):
        if not width:
            width, width_line = len(cells), number
            _check_table_shape(path, (1, width))  # the limit on columns
        elif len(cells) != width:
            _check_decimal_commas(path, number, text)
            raise ValueError(f"{path}: line {number} has {len(cells)} columns, line "
                             f"{width_line} has {width}")
        if rows == MAX_POINTS:
            raise ValueError(f"{path}: more than {MAX_POINTS:,} points; a file may hold at "
                             f"most {MAX_POINTS:,} points")
        try:
            values.extend(map(float, cells))
        except ValueError:
            _check_decimal_commas(path, number, text)
            column = next(i for i, cell in enumerate(cells) if not _is_number(cell))
            cell = cells[column].strip()
            hint = " (a decimal comma? write decimal points)" if \
                _is_number(cell.replace(",", ".", 1)) else ""
            raise ValueError(f"{path}: line {number}, column {column + 1}: "
                             f"{_quote(cell)} is not a number{hint}") from None
        rows += 1
    if not rows:
        raise ValueError(f"{path}: the file holds no data rows")
    data = np.frombuffer(values, dtype=np.float64).reshape(rows, width)
    finite = np.isfinite(data).all(axis=1)
    if not finite.all():  # found again to name its line
        row = int(np.argmin(finite))
        number, cells, _ = next(itertools.islice(_data_rows(path), row, None))
        column = int(np.argmin(np.isfinite(data[row])))
        raise ValueError(f"{path}: line {number}, column {column + 1}: "
                         f"{_quote(cells[column].strip())} is not a finite number (NaN or "
                         "infinite)")
    return data


def _data_rows(path: Path, headers: list[tuple[int, str]] | None = None
               ) -> Iterator[tuple[int, list[str], str]]:
    """Line number, fields and stripped text of each data row of a text table (separated by
    semicolons, else commas, else spaces or tabs): blank lines, ``#`` comments and a first row
    without a number (a header; its line number and text appended to ``headers``) are
    skipped; a first row of numbers with decimal commas is an error
    (:func:`_check_decimal_commas`), not a header."""
    first = True
    with path.open(encoding="utf-8-sig") as file:  # a byte-order mark (spreadsheets) is dropped
        for number in itertools.count(1):
            try:
                line = file.readline(MAX_LINE_CHARS + 1)
            except UnicodeDecodeError:
                raise ValueError(f"{path}: not UTF-8 text (near line {number})") from None
            if not line:
                return
            if len(line) > MAX_LINE_CHARS and not line.endswith("\n"):
                raise ValueError(f"{path}: line {number} is longer than {MAX_LINE_CHARS:,} "
                                 "characters; a text table of points is expected")
            text = line.strip()
            if not text or text.startswith("#"):
                continue
            cells = text.split(";") if ";" in text else \
                text.split(",") if "," in text else text.split()
            if first:
                first = False
                if not any(map(_is_number, cells)):
                    _check_decimal_commas(path, number, text)
                    if headers is not None:
                        headers.append((number, text))
                    continue  # a header row: no field is a number
            yield number, cells, text


def _decimal_commas(text: str) -> bool:
    """Whether a line reads as numbers only with its commas taken as decimal points: its
    fields, separated by semicolons, else by whitespace, are numbers once the one comma each
    may hold is a point, and one has a comma (``0,5;1,25``, ``0,5 1,25``, ``0,5;2``)."""
    if "," not in text:
        return False
    fields = text.split(";") if ";" in text else text.split()
    return all(_is_number(field.strip().replace(",", ".", 1)) for field in fields)


def _check_decimal_commas(path: Path, number: int, text: str) -> None:
    """Refuse line ``number`` of ``path`` if it is written with decimal commas
    (:func:`_decimal_commas`), naming the file and the line and giving the line with decimal
    points. Called where a line cannot be read as it is (so ``0,5`` alone, two values
    separated by a comma, is read as such)."""
    if _decimal_commas(text):
        raise ValueError(f"{path}: line {number}: {_quote(text)} is written with decimal "
                         "commas, which are not read; write decimal points "
                         f"({_quote(text.replace(',', '.'))})")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _quote(text: str, limit: int = 80) -> str:
    """``repr`` of user data, cut to ``limit`` characters: error messages stay short."""
    if len(text) <= limit:
        return repr(text)
    return f"{text[:limit]!r}... ({len(text):,} characters)"


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
    if is_integer(seed):
        return str(int(seed))
    return None
