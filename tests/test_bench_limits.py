"""studies/03_bench/limits.py: the fit that splits intersect's time per ray into walk, IC and set-up."""
import importlib.util
import os

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.fixture(scope="module")
def limits():
    spec = importlib.util.spec_from_file_location("bench_limits", os.path.join(ROOT, "studies", "03_bench", "limits.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def synthetic(limits, coef, setup, n=40, seed=3):
    rng = np.random.default_rng(seed)
    points = []
    for _ in range(n):
        p = {"voxels": rng.uniform(5, 90), "ic_visits": rng.uniform(0.5, 6), "polygon_tests": rng.uniform(0, 20),
             "sphere_tests": 0.0, "cone_tests": rng.uniform(0, 40)}
        p["ns_per_ray"] = setup + sum(coef[k] * p[k] for k in coef)
        points.append(p)
    return points


def test_fit_recovers_the_costs_it_was_made_with(limits):
    coef = {"voxels": 2.5, "ic_visits": 4.0, "polygon_tests": 9.0, "cone_tests": 3.0}
    got, r2 = limits.fit(synthetic(limits, coef, 40.0), 40.0)
    for k, v in coef.items():
        assert got[k] == pytest.approx(v, rel=1e-6)
    assert got["sphere_tests"] == 0.0  # never made: left out, not fitted
    assert got["ray"] == pytest.approx(40.0) and r2 == pytest.approx(1.0)


def test_split_adds_up_to_the_fitted_time(limits):
    coef = {"voxels": 2.0, "ic_visits": 1.0, "polygon_tests": 7.0, "sphere_tests": 0.0, "cone_tests": 3.0,
            "ray": 30.0}
    p = {"voxels": 10.0, "ic_visits": 2.0, "polygon_tests": 3.0, "sphere_tests": 0.0, "cone_tests": 1.0}
    s = limits.split(p, coef)
    assert s["walk"] == 20.0 and s["ic"] == 2.0 + 21.0 + 3.0 and s["setup"] == 30.0
    assert s["fitted"] == s["walk"] + s["ic"] + s["setup"]


def test_fit_costs_are_never_negative(limits):
    # a point set whose unconstrained fit would give IC visits a negative cost
    coef = {"voxels": 3.0, "ic_visits": 0.0, "polygon_tests": 8.0, "cone_tests": 0.0}
    pts = synthetic(limits, coef, 20.0, seed=5)
    for p in pts:
        p["ns_per_ray"] -= 0.5 * p["ic_visits"]
    got, _ = limits.fit(pts, 20.0)
    assert min(got.values()) >= 0.0


def test_a_rare_kind_of_test_is_fitted_with_the_main_kind(limits):
    # cones make nearly every test; a polygon in one row in ten, at the cones' cost
    coef = {"voxels": 2.0, "ic_visits": 5.0, "cone_tests": 4.0}
    pts = synthetic(limits, coef, 15.0, seed=7)
    for i, p in enumerate(pts):
        p["polygon_tests"] = 1.0 if i % 10 == 0 else 0.0
        p["ns_per_ray"] += 4.0 * p["polygon_tests"]
    got, r2 = limits.fit(pts, 15.0)
    assert got["polygon_tests"] == got["cone_tests"] == pytest.approx(4.0)
    assert r2 == pytest.approx(1.0)
