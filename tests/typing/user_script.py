"""A user's script over hairshade's public API, checked by `mypy --strict`
in tests/test_typing.py (and run there, so that it is also correct)."""

from __future__ import annotations

import pickle
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

import hairshade as hs


def lobes() -> float:
    c = hs.ChiangHair(eumelanin=1.3, pheomelanin=0.2, longitudinal_roughness=0.3, azimuthal_roughness=0.3,
                      scale_tilt=2.0, eta=1.55)
    m = hs.ChiangHair(int_ior=1.55, ext_ior=1.0, i0="mitsuba")
    wi = np.array([[0.0, 0.3, 1.0]], dtype=np.float32)
    wo = [[0.2, -0.3, 0.9]]  # any array-like
    f: npt.NDArray[np.floating[Any]] = c.eval(wi, wo)  # numpy 1.x needs the argument
    pdf = c.pdf(wi, wo)
    wo_s, weight, p = c.sample(wi, np.random.rand(1), np.random.rand(1, 2))
    far = c.eval_far(wi, wo, fast=True)
    parts = c.eval_far_lobes(wi, wo)
    k = hs.KarisHair(base_color=(0.3, 0.15, 0.08), roughness=0.5, scatter=0.2)
    L, V, T = [0.0, 0.0, 1.0], np.array([0.3, 0.1, 0.9]), (0.0, 1.0, 0.0)
    s = k.eval(L, V, T, shadow=0.5)
    per_lobe = k.eval_lobes(L, V, T)
    env = k.eval_env(V, T, np.ones(3))
    d = hs.DEonHair(base_color=0.4, roughness=0.5, h_samples=16)
    ref = d.eval(L, V, T) + d.eval_lobes(L, V, T)["TT"]
    fitted: hs.ChiangHair = hs.mapping.to_chiang(k, fit=False)
    copy = pickle.loads(pickle.dumps(k))
    assert isinstance(copy, hs.KarisHair)
    total = f.sum() + pdf.sum() + wo_s.sum() + weight.sum() + p.sum() + far.sum() + parts["R"].sum()
    total += s.sum() + per_lobe["MS"].sum() + env.sum() + ref.sum() + m.eval(wi, wo).sum()
    total += hs.lobes.deon_mp(0.1, np.linspace(-1, 1, 5), 0.09).sum() + hs.lobes.color_to_absorption([0.3, 0.2, 0.1]).sum()
    return float(total) + float(fitted.params["eta"])


def render() -> tuple[float, int]:
    scene = hs.Scene.load(hs.examples()[0])
    img = hs.render(scene, width=64, progress=False)
    brighter = img * 2  # an array, not a union with the stats tuple
    img2, stats = hs.render(scene, width=64, return_stats=True)
    # settings by keyword, typed: a misspelt key or an option under the wrong
    # method is a mypy error (tests/test_typing.py checks that too)
    fast = hs.render(scene, width=32, quality="fast", transparency={"mlab": {"layers": 8}},
                     shadows={"opacity": {"map_size": 512}}, progress=False)
    exact = hs.render(scene, width=32, quality="accurate", transparency={"coverage": {"samples": 4}},
                      shadows="traced", multiple_scattering={"dual": {"backscatter": "two_stream"}}, progress=False)
    brighter = brighter + float(fast.mean() + exact.mean())
    pts = np.array([[0, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0]], dtype=np.float64)
    arrays = hs.Scene.from_arrays(pts, 0.01, [0, 2, 4], material={"model": "karis"})
    with tempfile.TemporaryDirectory() as tmp:
        hs.write_exr(Path(tmp) / "a.exr", brighter)
        back = hs.read_exr(Path(tmp) / "a.exr")
        hs.write_png(Path(tmp) / "a.png", back, exposure=1.0)
    err = hs.rel_mse(img, img2) + float(hs.side_by_side(img, img2).mean())
    return err + float(hs.render(arrays, width=32).max()), int(stats["fragments"]) + arrays.strand_count


if __name__ == "__main__":
    print(lobes(), render(), hs.__version__, hs.num_threads())
