"""The KarisHair error tables, regression-gated against the baseline that
`hairshade tables` wrote to docs/error_tables.json (regenerating the tables
moves the gate: review that diff like code), and the ChiangHair mapping."""

from __future__ import annotations

import json
import pathlib

import numpy as np
import pytest

import hairshade as hs
from hairshade import mapping, tables

BASELINE = pathlib.Path(__file__).parent.parent / "docs" / "error_tables.json"


@pytest.fixture(scope="module")
def rows():
    return tables.karis_vs_deon(progress_bar=False)


def test_01_karis_vs_deon_not_worse_than_baseline(rows):
    base = {(r["roughness"], r["color"], r["lobe"]): r for r in json.loads(BASELINE.read_text())["karis_vs_deon"]}
    assert len(rows) == len(base) == 4 * 4 * 4
    for r in rows:
        b = base[(r.roughness, r.color, r.lobe)]
        # 2 % above today's values (plus 1e-4 for rounding in the JSON file).
        for key in ("rel_l2", "rel_l2_core", "max_err"):
            assert getattr(r, key) <= b[key] * 1.02 + 1e-4, (r, key, b[key])


def test_02_tables_measure_real_differences(rows):
    """The comparison is not vacuous: models differ, and the sum is closer in
    the core region than over the whole grid (grazing angles are where the
    Gaussian M_p departs most from d'Eon's)."""
    for r in rows:
        assert r.rel_l2 > 1e-3
    s = [x for x in rows if x.lobe == "sum"]
    assert np.median([x.rel_l2_core for x in s]) < np.median([x.rel_l2 for x in s])


@pytest.mark.parametrize("color,roughness", [((0.85, 0.7, 0.5), 0.4), ((0.3, 0.15, 0.08), 0.6)])
def test_03_chiang_mapping_fit_improves_on_analytic_start(color, roughness):
    k = hs.KarisHair(base_color=color, roughness=roughness)
    L, V = mapping._grid()
    T = np.array([0.0, 1.0, 0.0])
    target = hs.DEonHair(base_color=color, roughness=roughness).eval(L, V, T)

    def err(params):
        lobes = hs.ChiangHair(**params).eval_far_lobes(L, V)
        return np.sqrt((((lobes["R"] + lobes["TT"] + lobes["TRT"]) - target) ** 2).sum() / (target**2).sum())

    p0 = mapping.initial_chiang_params(k)
    p1 = mapping.chiang_params(k)
    assert err(p1) < err(p0)
    assert err(p1) < 0.25
    assert 0 < p1["longitudinal_roughness"] <= 1 and 0.1 <= p1["azimuthal_roughness"] <= 1
    assert isinstance(mapping.to_chiang(k, fit=False), hs.ChiangHair)
