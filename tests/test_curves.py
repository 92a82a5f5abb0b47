"""Seed curves, point files and seeded noise (metaknot.problems.curves).

Expected coordinates are recomputed here from the formulas of the seed paper (section IV B-D),
independently of the implementation.
"""

from __future__ import annotations

import numpy as np
import pytest

from metaknot.problems import (
    CURVES,
    PointSet,
    add_noise,
    archimedean_spiral,
    check_points_file,
    curves,
    epitrochoid,
    get_curve,
    header_line,
    load_points,
    vivaldi,
)

# --------------------------------------------------------------------------------------------
# seed curves
# --------------------------------------------------------------------------------------------


def _epitrochoid_reference(a=5.0, b=1.0, h=4.0):
    t = np.deg2rad(np.arange(-180, 181, 1))  # -180..180 degrees in 1-degree steps
    x = (a + b) * np.cos(t) - h * np.cos((a / b + 1) * t)
    y = (a + b) * np.sin(t) - h * np.sin((a / b + 1) * t)
    return np.stack([x, y], axis=1)


def _spiral_reference(a=2.0, n=100):
    t = np.pi * np.arange(n) / (n - 1)  # 0..pi, both ends included
    r = a * t
    return np.stack([r * np.cos(t), r * np.sin(t)], axis=1)


def _vivaldi_reference(a=0.5):
    t = np.deg2rad(np.arange(-360, 361, 3))  # 241 points over 720 degrees
    return np.stack([a * (1 + np.cos(t)), a * np.sin(t), 2 * a * np.sin(t / 2)], axis=1)


@pytest.mark.parametrize(
    ("name", "n_points", "dim"),
    [("epitrochoid", 361, 2), ("archimedean", 100, 2), ("vivaldi", 241, 3)],
)
def test_seed_curve_sizes(name, n_points, dim):
    data = get_curve(name)
    assert isinstance(data, PointSet)
    assert data.points.shape == (n_points, dim)
    assert data.n_points == n_points
    assert data.dim == dim
    assert data.points.dtype == np.float64
    assert data.params is None
    assert np.isfinite(data.points).all()


def test_curve_registry_names():
    assert set(CURVES) == {"epitrochoid", "archimedean", "vivaldi"}
    assert get_curve("epitrochoid").name == "epitrochoid"
    assert get_curve("archimedean").name == "archimedean"
    assert get_curve("vivaldi").name == "vivaldi"


def test_epitrochoid_coordinates():
    ref = _epitrochoid_reference()
    assert ref.shape == (361, 2)
    np.testing.assert_allclose(epitrochoid().points, ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(get_curve("epitrochoid").points, ref, rtol=0, atol=1e-12)
    # closed curve: t = -180 and t = 180 degrees give the same point, at (-(a+b) + h, 0)
    pts = epitrochoid().points
    np.testing.assert_allclose(pts[0], pts[-1], atol=1e-12)
    np.testing.assert_allclose(pts[180], [6.0 - 4.0, 0.0], atol=1e-12)  # t = 0


def test_archimedean_coordinates():
    ref = _spiral_reference()
    np.testing.assert_allclose(archimedean_spiral().points, ref, rtol=0, atol=1e-12)
    pts = get_curve("archimedean").points
    np.testing.assert_allclose(pts[0], [0.0, 0.0], atol=1e-15)  # r = 0 at t = 0
    np.testing.assert_allclose(pts[-1], [-2 * np.pi, 0.0], atol=1e-12)  # r = 2 pi at t = pi
    # r = a t: the distance from the origin grows linearly along the parameter
    r = np.linalg.norm(pts, axis=1)
    np.testing.assert_allclose(np.diff(r), 2 * np.pi / 99, rtol=1e-9)


def test_vivaldi_coordinates():
    ref = _vivaldi_reference()
    assert ref.shape == (241, 3)
    np.testing.assert_allclose(vivaldi().points, ref, rtol=0, atol=1e-12)
    pts = get_curve("vivaldi").points
    # Viviani-type curve: it lies on the sphere x^2 + y^2 + z^2 = 2 a x ... with a = 0.5:
    # x^2 + y^2 + z^2 = (2a)^2 = 1 and (x - a)^2 + y^2 = a^2 (cylinder).
    np.testing.assert_allclose(np.sum(pts**2, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose((pts[:, 0] - 0.5) ** 2 + pts[:, 1] ** 2, 0.25, atol=1e-12)


def test_curve_parameters_are_honoured():
    data = get_curve("archimedean", n_points=11, a=3.0)
    assert data.points.shape == (11, 2)
    np.testing.assert_allclose(data.points, _spiral_reference(a=3.0, n=11), atol=1e-12)
    other = epitrochoid(a=3.0, b=1.0, h=1.0)
    np.testing.assert_allclose(other.points, _epitrochoid_reference(3.0, 1.0, 1.0), atol=1e-12)


def test_unknown_curve_name():
    with pytest.raises(ValueError, match="unknown curve 'spirograph'") as info:
        get_curve("spirograph")
    for name in ("epitrochoid", "archimedean", "vivaldi"):
        assert name in str(info.value)


def test_point_set_scale_is_bounding_box_diagonal():
    pts = _epitrochoid_reference()
    diag = np.sqrt(np.sum((pts.max(axis=0) - pts.min(axis=0)) ** 2))
    assert get_curve("epitrochoid").scale == pytest.approx(diag, rel=1e-12)


# --------------------------------------------------------------------------------------------
# load_points
# --------------------------------------------------------------------------------------------


def _write_csv(path, rows, header=None):
    lines = [] if header is None else [header]
    lines += [",".join(repr(float(v)) for v in row) for row in rows]
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture
def table():
    rng = np.random.default_rng(12345)
    return rng.normal(size=(25, 3)) * [1.0, 10.0, 1e-3]


def test_load_csv_without_header(tmp_path, table):
    path = tmp_path / "cloud.csv"
    _write_csv(path, table)
    data = load_points(path)
    np.testing.assert_array_equal(data.points, table)  # repr round-trips floats exactly
    assert data.name == "cloud"
    assert data.params is None


def test_load_csv_with_header(tmp_path, table):
    path = tmp_path / "with_header.csv"
    _write_csv(path, table, header="x,y,z")
    data = load_points(str(path))  # a plain string path works too
    np.testing.assert_array_equal(data.points, table)
    assert data.points.shape == (25, 3)


def test_semicolons_separate_values_as_commas_do(tmp_path, table):
    """A semicolon-separated export (with a header) gives the points a comma-separated one
    does; a decimal comma there is refused with a hint, not read as two values."""
    body = "\n".join(";".join(repr(float(v)) for v in row) for row in table)
    (tmp_path / "semi.csv").write_text("x;y;z\n" + body + "\n")
    np.testing.assert_array_equal(load_points(tmp_path / "semi.csv").points, table)
    (tmp_path / "comma.csv").write_text("x;y\n1,5;2,25\n")
    with pytest.raises(ValueError, match=r"line 2: '1,5;2,25' is written with decimal commas, "
                                         r"which are not read; write decimal points "
                                         r"\('1\.5;2\.25'\)"):
        load_points(tmp_path / "comma.csv")
    (tmp_path / "points.dat").write_text("1 2\n")
    with pytest.raises(ValueError, match=r"unsupported file type '\.dat' \(use \.csv, \.txt or "
                                         r"\.npy\)"):
        load_points(tmp_path / "points.dat")


@pytest.mark.parametrize(("content", "line", "text", "points"), [
    ("0,5;1,25\n1,5;2\n2,5;2,75\n", 1, "0,5;1,25", "0.5;1.25"),
    ("0,5 1,25\n1,5 2\n2,5 2,75\n", 1, "0,5 1,25", "0.5 1.25"),
    ("0,5\t1,25\n", 1, "0,5\t1,25", "0.5\t1.25"),
    ("# scan\n\n0,5;1,25\n", 3, "0,5;1,25", "0.5;1.25"),
    ("0.5;1.25\n1.5;2\n2,5;2,75\n", 3, "2,5;2,75", "2.5;2.75"),
    ("0.5 1.25\n1.5 2\n2,5 2,75\n", 3, "2,5 2,75", "2.5 2.75"),
    ("0.5 1.25\n1,5 2\n", 2, "1,5 2", "1.5 2"),
    ("x;y\n0,5;1,25\n", 2, "0,5;1,25", "0.5;1.25"),
], ids=["semicolons-first", "spaces-first", "tab-first", "after-comments", "semicolons-later",
        "spaces-later", "one-comma-later", "after-a-header"])
def test_decimal_commas_are_refused_naming_the_line(tmp_path, content, line, text,
                                                   points) -> None:
    """A line written with decimal commas is an error naming the file and the line, the first
    line too: it was taken for a header and dropped (``0,5;1,25``), or read as a number
    followed by '5 1' (``0,5 1,25``), or a later line's commas as more columns."""
    (tmp_path / "scan.csv").write_text(content)
    with pytest.raises(ValueError) as info:
        load_points(tmp_path / "scan.csv")
    assert str(info.value) == (
        f"{tmp_path / 'scan.csv'}: line {line}: {text!r} is written with decimal commas, which "
        f"are not read; write decimal points ({points!r})")


def test_a_header_is_skipped_and_named_and_comma_separated_numbers_are_read(tmp_path) -> None:
    """A first row without a number (``x,y``) is skipped, and :func:`header_line` names it;
    a first row of comma-separated numbers with decimal points is data."""
    (tmp_path / "header.csv").write_text("# from a scanner\nx,y\n0.5,1.25\n1,2\n2,3\n")
    (tmp_path / "data.csv").write_text("0.5,1.25\n1,2\n2,3\n")
    np.save(tmp_path / "data.npy", [[0.5, 1.25], [1, 2], [2, 3]])
    expected = [[0.5, 1.25], [1, 2], [2, 3]]
    for name in ("header.csv", "data.csv", "data.npy"):
        np.testing.assert_array_equal(load_points(tmp_path / name).points, expected)
    assert header_line(tmp_path / "header.csv") == (2, "x,y")
    assert header_line(tmp_path / "data.csv") is None
    assert header_line(tmp_path / "data.npy") is None


@pytest.mark.parametrize(("rows", "degree", "need"), [(1, 1, 3), (1, 3, 5), (4, 3, 5),
                                                      (3, 2, 4)])
def test_too_few_points_name_the_file_once_and_the_degree(tmp_path, rows, degree,
                                                          need) -> None:
    """``load_points(degree=p)`` refuses fewer than p + 2 points naming the file once (it
    said ``one.csv: one: a degree-1 fit needs ...`` whatever the degree)."""
    (tmp_path / "one.csv").write_text("".join(f"{i}.5,{i * i}\n" for i in range(rows)))
    kwargs = {} if degree == 1 else {"degree": degree}
    with pytest.raises(ValueError) as info:
        load_points(tmp_path / "one.csv", **kwargs)
    assert str(info.value) == (f"{tmp_path / 'one.csv'}: a degree-{degree} fit needs at least "
                               f"{need} points; got {rows}")
    with pytest.raises(ValueError, match="degree must be between 1 and 5, got 6"):
        load_points(tmp_path / "one.csv", degree=6)


def test_load_csv_skips_comments_and_blank_lines(tmp_path, table):
    path = tmp_path / "commented.csv"
    body = "\n".join(",".join(repr(float(v)) for v in row) for row in table)
    path.write_text("# produced by a scanner\n\nx,y,z\n" + body + "\n\n")
    np.testing.assert_array_equal(load_points(path).points, table)


def test_load_npy_round_trip(tmp_path, table):
    path = tmp_path / "cloud.npy"
    np.save(path, table)
    data = load_points(path)
    np.testing.assert_array_equal(data.points, table)
    assert data.points.dtype == np.float64


def test_load_seed_curve_round_trip(tmp_path):
    curve = get_curve("vivaldi")
    np.save(tmp_path / "viv.npy", curve.points)
    _write_csv(tmp_path / "viv.csv", curve.points, header="x,y,z")
    np.testing.assert_array_equal(load_points(tmp_path / "viv.npy").points, curve.points)
    np.testing.assert_array_equal(load_points(tmp_path / "viv.csv").points, curve.points)


@pytest.mark.parametrize("suffix", [".csv", ".npy"])
def test_params_column(tmp_path, suffix):
    x = np.linspace(-1.0, 2.0, 30)
    y = np.sin(3 * x)
    path = tmp_path / f"function{suffix}"
    if suffix == ".csv":
        _write_csv(path, np.stack([x, y], axis=1), header="x,y")
    else:
        np.save(path, np.stack([x, y], axis=1))
    data = load_points(path, params_column=0)
    np.testing.assert_array_equal(data.params, x)
    np.testing.assert_array_equal(data.points, y[:, None])
    assert data.dim == 1
    # negative index: the last column
    data = load_points(path, params_column=-1)
    np.testing.assert_array_equal(data.params, y)
    np.testing.assert_array_equal(data.points, x[:, None])


def test_params_column_middle(tmp_path, table):
    path = tmp_path / "three.npy"
    np.save(path, table)
    data = load_points(path, params_column=1)
    np.testing.assert_array_equal(data.params, table[:, 1])
    np.testing.assert_array_equal(data.points, table[:, [0, 2]])


def test_params_column_invalid(tmp_path, table):
    path = tmp_path / "three.npy"
    np.save(path, table)
    for bad in (3, -4, 10):
        with pytest.raises(ValueError, match="params_column"):
            load_points(path, params_column=bad)
    single = tmp_path / "single.npy"
    np.save(single, table[:, :1])
    with pytest.raises(ValueError, match="params_column"):
        load_points(single, params_column=0)  # nothing would be left for the points


def test_load_missing_file(tmp_path):
    with pytest.raises(ValueError, match="not found"):
        load_points(tmp_path / "nope.csv")
    with pytest.raises(ValueError, match="a folder, not a point file"):
        load_points(tmp_path)


@pytest.mark.parametrize("suffix", [".csv", ".npy"])
def test_load_empty_file(tmp_path, suffix):
    path = tmp_path / f"empty{suffix}"
    path.write_bytes(b"")
    with pytest.raises(ValueError, match=f"empty{suffix}"):  # a ValueError naming the file
        load_points(path)


def test_load_csv_header_only_or_comments_only(tmp_path):
    path = tmp_path / "header.csv"
    path.write_text("x,y\n")
    with pytest.raises(ValueError, match="no data rows"):
        load_points(path)
    path = tmp_path / "comments.csv"
    path.write_text("# nothing here\n\n")
    with pytest.raises(ValueError, match="no data rows"):
        load_points(path)


def test_load_empty_npy_array(tmp_path):
    path = tmp_path / "none.npy"
    np.save(path, np.zeros((0, 2)))
    with pytest.raises(ValueError, match=r"none\.npy"):
        load_points(path)


def test_load_ragged_rows(tmp_path):
    path = tmp_path / "ragged.csv"
    path.write_text("1,2\n3,4\n5,6,7\n8,9\n")
    with pytest.raises(ValueError, match="columns"):
        load_points(path)


def test_load_non_numeric(tmp_path):
    path = tmp_path / "words.csv"
    path.write_text("x,y\n1,2\n3,four\n5,6\n7,8\n")
    with pytest.raises(ValueError, match=r"words\.csv: line 3, column 2: 'four' is not a number"):
        load_points(path)
    npy = tmp_path / "words.npy"
    np.save(npy, np.array([["a", "b"], ["c", "d"], ["e", "f"]]))
    with pytest.raises(ValueError, match="values must be real numbers; got dtype '<U1'"):
        load_points(npy)


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf"])
def test_load_csv_nan(tmp_path, bad):
    path = tmp_path / "holes.csv"
    path.write_text(f"1,2\n3,{bad}\n5,6\n7,8\n")
    with pytest.raises(ValueError, match="NaN") as info:
        load_points(path)
    assert f"holes.csv: line 2, column 2: '{bad}'" in str(info.value)  # the file and line


def test_load_npy_nan(tmp_path, table):
    table[4, 1] = np.nan
    path = tmp_path / "holes.npy"
    np.save(path, table)
    with pytest.raises(ValueError, match="NaN"):
        load_points(path)


def test_load_complex_npy_is_rejected(tmp_path):
    # complex values cannot be points; silently dropping the imaginary part loses data
    path = tmp_path / "complex.npy"
    np.save(path, np.array([[1 + 1j, 2], [3, 4], [5, 6j], [7, 8]]))
    with pytest.raises(ValueError, match=r"complex\.npy"):
        load_points(path)


@pytest.mark.parametrize("content", [b"this is not an npy file at all", bytes(4096),
                                     np.random.default_rng(0).bytes(4096)],
                         ids=["text", "zeros", "random"])
def test_load_corrupt_npy(tmp_path, content):
    path = tmp_path / "corrupt.npy"
    path.write_bytes(content)  # not "pickled (object) data": no .npy signature at all
    with pytest.raises(ValueError, match=r"corrupt\.npy: not a \.npy file \(it does not start"):
        load_points(path)


def _npy_header(path, shape, data=b""):
    with path.open("wb") as file:
        np.lib.format.write_array_header_1_0(
            file, {"descr": "<f8", "fortran_order": False, "shape": shape})
        file.write(data)


@pytest.mark.parametrize(("shape", "message"), [
    ((1_000_001, 2), "1,000,001 points; a file may hold at most 1,000,000 points"),
    ((10, 5), "5 columns; a file may have at most 4 (3 coordinates and a parameter column)"),
    ((10, 2), "truncated: its header describes a (10, 2) float64 array of 160 bytes; the file "
              "holds 8"),
    ((2, 5, 2), r"expected a 2-D table of points; got shape (2, 5, 2)"),
])
def test_a_npy_header_is_checked_before_the_data_is_read(tmp_path, shape, message):
    path = tmp_path / "claims.npy"
    _npy_header(path, shape, data=bytes(8))
    for check in (check_points_file, load_points):
        with pytest.raises(ValueError) as info:
            check(path)
        assert str(info.value) == f"{path}: {message}"


@pytest.mark.parametrize(("content", "message"), [
    (b"1,2\n" + bytes(range(256)) * 4, "binary data (a NUL byte at offset 4), not a text table"),
    ("x (\u00b5m),y\n1,2\n".encode("latin-1"), "not UTF-8 text (byte 3)"),
    (b"1" * 10_000_000, "line 1 is longer than 4,096 characters"),
    (b"1,2\n3," + b"x" * 4000 + b"\n5,6\n",
     "line 2, column 2: '" + "x" * 80 + "'... (4,000 characters) is not a number"),
], ids=["binary", "latin-1", "long-line", "long-cell"])
def test_a_file_that_is_no_text_table_is_refused_in_a_short_line(tmp_path, content, message):
    path = tmp_path / "scan.csv"
    path.write_bytes(content)
    with pytest.raises(ValueError) as info:
        load_points(path)
    assert str(info.value).startswith(f"{path}: {message}")
    assert len(str(info.value)) < 150 + len(str(path))


def test_only_the_first_bytes_are_checked_before_reading(tmp_path):
    path = tmp_path / "late.csv"
    path.write_bytes(b"1,2\n" * 20_000 + b"3,\0\n")  # the NUL lies beyond the first 64 KiB
    check_points_file(path)
    with pytest.raises(ValueError, match=r"line 20001, column 2: '\\x00' is not a number"):
        load_points(path)


def test_the_limits_of_a_text_file(tmp_path, monkeypatch):
    monkeypatch.setattr(curves, "MAX_POINTS", 5)
    path = tmp_path / "many.csv"
    path.write_text("x,y\n" + "".join(f"{i},{i * i}\n" for i in range(5)))
    assert load_points(path).n_points == 5
    path.write_text("x,y\n" + "".join(f"{i},{i * i}\n" for i in range(6)))
    with pytest.raises(ValueError, match="more than 5 points; a file may hold at most 5 points"):
        load_points(path)
    path.write_text("1,2,3,4,5\n" * 5)
    with pytest.raises(ValueError, match="5 columns; a file may have at most 4"):
        load_points(path)
    monkeypatch.setattr(curves, "MAX_TEXT_BYTES", 20)
    path.write_text("1,2\n" * 6)  # 24 bytes
    with pytest.raises(ValueError, match="24 bytes; a text file of points may have at most 20"):
        check_points_file(path)


def test_values_separated_by_whitespace(tmp_path):
    path = tmp_path / "columns.txt"
    path.write_text("x y\n1 2\n3\t4\n  5   6  \n7, 8\n")
    np.testing.assert_array_equal(load_points(path).points, [[1, 2], [3, 4], [5, 6], [7, 8]])


def test_a_byte_order_mark_is_dropped(tmp_path):
    path = tmp_path / "spreadsheet.csv"
    path.write_bytes(b"\xef\xbb\xbf1,2\r\n3,4\r\n5,6\r\n")  # as spreadsheets save "CSV UTF-8"
    np.testing.assert_array_equal(load_points(path).points, [[1, 2], [3, 4], [5, 6]])


@pytest.mark.parametrize("suffix", [".json", ".xlsx", ""])
def test_load_unsupported_suffix(tmp_path, suffix):
    path = tmp_path / f"points{suffix}"
    path.write_text("1,2\n3,4\n5,6\n")
    with pytest.raises(ValueError, match="unsupported"):
        load_points(path)


def test_load_txt_is_read_as_csv(tmp_path, table):
    path = tmp_path / "points.txt"
    _write_csv(path, table)
    np.testing.assert_array_equal(load_points(path).points, table)


# --------------------------------------------------------------------------------------------
# add_noise
# --------------------------------------------------------------------------------------------


def test_add_noise_reproducible_by_seed():
    data = get_curve("epitrochoid")
    a = add_noise(data, 0.05, seed=7)
    b = add_noise(data, 0.05, seed=7)
    np.testing.assert_array_equal(a.points, b.points)
    # a Generator in the same state gives the same noise as its seed
    c = add_noise(data, 0.05, seed=np.random.default_rng(7))
    np.testing.assert_array_equal(a.points, c.points)


def test_add_noise_differs_between_seeds():
    data = get_curve("epitrochoid")
    a = add_noise(data, 0.05, seed=1)
    b = add_noise(data, 0.05, seed=2)
    assert not np.allclose(a.points, b.points)
    assert np.mean(a.points != b.points) > 0.99


@pytest.mark.parametrize(("name", "sigma"), [("epitrochoid", 0.1), ("vivaldi", 0.01)])
def test_add_noise_standard_deviation(name, sigma):
    data = get_curve(name)
    original = data.points.copy()
    noisy = add_noise(data, sigma, seed=2024)
    np.testing.assert_array_equal(data.points, original)  # the input is not modified
    assert noisy.points.shape == data.points.shape
    diff = noisy.points - data.points
    n = diff.size
    # sample std of n Gaussian draws: relative standard error ~ 1/sqrt(2n)
    assert np.std(diff) == pytest.approx(sigma, rel=6 / np.sqrt(2 * n))
    assert abs(np.mean(diff)) < 6 * sigma / np.sqrt(n)
    # noise on every coordinate, independent between coordinates
    for j in range(data.dim):
        assert np.std(diff[:, j]) == pytest.approx(sigma, rel=6 / np.sqrt(2 * data.n_points))


def test_add_noise_zero_sigma_and_params_kept():
    x = np.linspace(0.0, 1.0, 20)
    data = PointSet(np.sin(x)[:, None], name="f", params=x)
    same = add_noise(data, 0.0, seed=3)
    np.testing.assert_array_equal(same.points, data.points)
    noisy = add_noise(data, 0.1, seed=3)
    np.testing.assert_array_equal(noisy.params, x)


@pytest.mark.parametrize("sigma", [-0.1, np.nan, np.inf])
def test_add_noise_bad_sigma(sigma):
    with pytest.raises(ValueError, match="sigma"):
        add_noise(get_curve("archimedean"), sigma, seed=0)
