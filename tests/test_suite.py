"""The benchmark suite's instances: how many, which families, deterministic points (pinned),
definitions against their sources, noise, closedness, plugins."""

from __future__ import annotations

import hashlib
import importlib
import json
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import BSpline

from metaknot.bspline.curve import closure
from metaknot.problems import KnotSelection
from metaknot.suite import FAMILIES, Instance, base_instances, get_instance, instances
from metaknot.suite.functions import KANG_COEFFICIENTS, KANG_KNOTS

instances_module = importlib.import_module("metaknot.suite.instances")
HASHES = Path(__file__).parent / "data" / "suite-hashes.json"


#: Points and parameters are pinned to this fraction of the instance's scale (and of the unit
#: parameter range): numpy's vectorised exp, sin, ... differ in the last bit between CPUs
#: (AVX-512 against AVX2 code paths), which exact bytes would count as a changed suite.
PINNED_RESOLUTION = 1e-8


def _quantized(values: np.ndarray, scale: float) -> bytes:
    return np.ascontiguousarray(np.rint(np.asarray(values) / (scale * PINNED_RESOLUTION)),
                                dtype="<i8").tobytes()


def points_hash(instance: Instance) -> str:
    data = instance.point_set()
    points = np.asarray(data.points, dtype=np.float64)
    scale = float(np.abs(points).max()) or 1.0
    digest = hashlib.sha256(_quantized(points, scale))
    digest.update(repr(points.shape).encode())
    if data.params is not None:
        digest.update(_quantized(data.params, 1.0))
    return digest.hexdigest()[:16]


def write_pinned_hashes() -> None:
    """Pin the current points (``python -m tests.test_suite``): only for a deliberate change
    of the suite, which gives the changed instances new ids."""
    HASHES.write_text(json.dumps({i.id: points_hash(i) for i in base_instances()}, indent=1,
                                 sort_keys=True)
                      + "\n")


def test_the_suite_has_at_least_48_base_instances_in_at_least_6_families():
    base = base_instances()
    assert len(base) >= 48 and len(FAMILIES) >= 6
    ids = [i.id for i in base]
    assert len(set(ids)) == len(ids)
    assert all(i.id.replace("_", "").isalnum() and i.id.islower() for i in base)
    for family in FAMILIES:
        assert len(instances(family=family, noise=False, plugins=False)) >= 4, family
    kinds = {i.kind for i in base}
    assert kinds == {"function", "open", "closed"}
    assert {i.dim for i in base} == {1, 2, 3}


def test_every_instance_s_points_are_pinned():
    """Regenerated from their definitions, the points hash as when the suite was fixed (a
    changed definition changes the suite: give it a new id instead)."""
    pinned = json.loads(HASHES.read_text())
    assert {i.id: points_hash(i) for i in base_instances()} == pinned


def test_noisy_variants_are_deterministic_and_scaled_to_the_range():
    noisy = instances(noise=True, plugins=False)
    base = {i.id: i for i in base_instances()}
    variants = [i for i in noisy if i.noise]
    # every function and planar curve, at two levels or more
    planar_or_function = [i for i in base.values() if i.family != "space_curves"]
    assert len(variants) >= 2 * len(planar_or_function)
    instance = get_instance("dj_doppler+noise0.03s0")
    assert instance.noise == 0.03 and instance.noise_seed == 0
    a, b = instance.point_set(), get_instance("dj_doppler+noise0.03s0").point_set()
    np.testing.assert_array_equal(a.points, b.points)
    clean = base["dj_doppler"].point_set()
    residual = a.points - clean.points
    assert residual.std() == pytest.approx(0.03 * clean.scale, rel=0.1)
    np.testing.assert_array_equal(a.params, clean.params)  # noise on f(x) only
    other = get_instance("dj_doppler+noise0.03s1").point_set()
    assert not np.array_equal(other.points, a.points)
    assert a.name == "dj_doppler+noise0.03s0" and a.noise == pytest.approx(0.03 * clean.scale)
    assert instance.base_id == base["dj_doppler"].base_id == "dj_doppler"


def test_closed_instances_are_closed_by_the_one_rule_and_open_ones_open():
    for instance in base_instances():
        if instance.kind != "function":
            assert closure(instance.point_set().points).closed == instance.closed, instance.id


def test_every_instance_is_a_knot_problem_with_feasible_averaging_knots():
    for instance in base_instances():
        problem = KnotSelection(instance.point_set(), closed=instance.closed)
        mask = np.zeros(problem.encoding.n_var, dtype=np.int64)
        mask[:: max(1, problem.encoding.n_var // 8)] = 1
        assert np.isfinite(problem.evaluate(mask[None, :])[0]), instance.id


def test_definitions_name_their_source():
    for instance in base_instances():
        assert len(instance.definition) > 30, instance.id
    sources = {"galvez_f1": "SHAPES", "aspline_logit": "Goepp", "dj_bumps": "WaveLab",
               "kang_spline": "Kang", "titanium": "Jupp", "humps": "MATLAB",
               "digit_3": "DejaVu Sans Mono"}
    for key, source in sources.items():
        assert source in get_instance(key).definition, key


def test_definitions_against_their_stated_values():
    x, y = get_instance("titanium").generate()
    assert (x[0], x[-1], len(x)) == (595, 1075, 49) and y.max() == 2.169
    x, y = get_instance("galvez_f2").generate()
    at = 153  # x = 0.59765625: the formula's left branch (x < 0.6)
    assert x[at] == 0.59765625 and y[at] == pytest.approx(1 / (0.01 + (x[at] - 0.3) ** 2))
    x, y = get_instance("galvez_f4").generate()
    assert (x[0], x[-1], len(x)) == (-2.0, -2.0 + 4 * 255 / 256, 256)
    t, bumps = get_instance("dj_bumps").generate()
    assert t[0] == 1 / 1024 and t[-1] == 1.0
    assert bumps[np.argmin(np.abs(t - 0.78))] > 4.0  # WaveLab's tenth height: 5.1, not 2.1
    _, doppler = get_instance("dj_doppler").generate()
    assert doppler[-1] == 0.0  # sqrt(t (1 - t)) at t = 1


def test_the_known_answer_instance_is_reproduced_by_its_own_knots():
    """Kang et al.'s spline is fitted exactly by least squares on its true knots (double knot
    included), checked with scipy's make_lsq_spline."""
    from scipy.interpolate import make_lsq_spline

    x, y = get_instance("kang_spline").generate()
    t = np.concatenate(([0.0] * 4, KANG_KNOTS, [1.0] * 4))
    fitted = make_lsq_spline(x, y, t, k=3)
    np.testing.assert_allclose(fitted.c, KANG_COEFFICIENTS, atol=1e-9)
    np.testing.assert_allclose(BSpline(t, np.asarray(KANG_COEFFICIENTS, float), 3)(x), y)


def test_unknown_ids_are_named_with_the_closest():
    with pytest.raises(ValueError, match="Did you mean 'dj_bumps'"):
        get_instance("dj_bump")
    with pytest.raises(ValueError, match="unknown family"):
        instances(family="nope")


PLUGIN = "metaknot_fake_instances_mod"


def test_instances_of_installed_packages(tmp_path, monkeypatch):
    dist = tmp_path / "fakeinst-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: fakeinst\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text(f"[metaknot.instances]\nmine = {PLUGIN}:mine\n")
    (tmp_path / f"{PLUGIN}.py").write_text(textwrap.dedent('''
        import numpy as np
        from metaknot.suite import Instance

        def wave():
            """My lab's wave: sin(5x) on linspace(0, 1, 50)."""
            x = np.linspace(0, 1, 50)
            return x, np.sin(5 * x)

        def mine():
            return [Instance("lab_wave", "my_lab", "function", wave)]
        '''))
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, PLUGIN, raising=False)
    instances_module._plugin_instances.cache_clear()
    try:
        found = instances(family="my_lab")
        assert [i.id for i in found] == ["lab_wave"]
        assert get_instance("lab_wave").point_set().n_points == 50
        assert get_instance("lab_wave+noise0.1s2").noise == 0.1
    finally:
        instances_module._plugin_instances.cache_clear()
        sys.modules.pop(PLUGIN, None)


if __name__ == "__main__":
    write_pinned_hashes()
