"""Multiple scattering through the hair volume (``multiple_scattering:
"volume"``): against converged Mitsuba path tracing (tests/data/dense and
tests/data/held_out, with their max_depth-2 renders for the multiple-
scattering part alone), the white furnace, determinism over thread counts,
reuse of the solve across views, and its errors. docs/volume.md has the
full measurement (scripts/volume_compare.py)."""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import hairshade as hs

DATA = pathlib.Path(__file__).parent / "data"
DENSE = DATA / "dense"
W, H = 320, 180


def _small(material: dict | None = None, lights: list | None = None, strands: int = 1500) -> dict:
    return {
        "hairshade_scene": 1,
        "camera": {"position": [0.25, 0.1, 2.3], "target": [0, -0.12, 0], "up": [0, 1, 0], "fov": 40,
                   "resolution": [160, 90]},
        "meshes": [{"type": "sphere", "center": [0, 0, 0], "radius": 0.48, "albedo": [0.5, 0.4, 0.35]}],
        "lights": lights or [{"type": "directional", "direction": [0.2, 0.4, -1.0], "intensity": [4, 4, 4]},
                             {"type": "environment", "radiance": [0.2, 0.2, 0.25]}],
        "hair": {"generate": {"kind": "head", "strands": strands, "segments": 12, "scalp_radius": 0.5,
                              "length": 0.5, "radius": 0.0013, "seed": 7},
                 "material": material or {"model": "chiang", "eumelanin": 0.1, "pheomelanin": 0.05}},
        "render": {"multiple_scattering": {"volume": {"photons": 65536, "resolution": 24}}},
    }


def _without_settings(name: str, tmp_path) -> hs.Scene:
    d = json.loads((DENSE / f"{name}.json").read_text())
    d["render"] = {}
    return hs.Scene.from_dict(d)


def test_01_same_image_at_every_thread_count(tmp_path):
    """The tallies are integer sums, so neither the solve nor the image
    depends on the order photons finish in: one thread gives the image of
    two, bit for bit."""
    path = tmp_path / "s.json"
    path.write_text(json.dumps(_small()))
    out = tmp_path / "one.npy"
    code = f"import numpy as np, hairshade as hs; np.save({str(out)!r}, hs.render(hs.Scene.load({str(path)!r})))"
    a = hs.render(hs.Scene.load(str(path)))
    subprocess.run([sys.executable, "-c", code], check=True, env=dict(os.environ, RAYON_NUM_THREADS="1"))
    np.testing.assert_array_equal(np.load(out), a)
    assert np.isfinite(a).all() and a.min() >= 0


def test_02_a_new_view_reuses_the_solve_and_a_new_light_does_not():
    sc = hs.Scene.from_dict(_small())
    _, first = hs.render(sc, return_stats=True)
    sc.camera = dict(sc.camera, position=[1.5, 0.3, 1.8])
    _, moved = hs.render(sc, return_stats=True)
    assert moved["volume_reused"] and moved["volume_ms"] == 0.0
    assert moved["volume_voxels"] == first["volume_voxels"] > 0
    d = _small()
    d["lights"][0]["intensity"] = [5, 5, 5]
    _, relit = hs.render(hs.Scene.from_dict(d), return_stats=True)
    assert not relit["volume_reused"]
    # the default preset reads the bins at their centres; read at their mean directions, the
    # bins tally those directions too: a solve of its own
    assert hs.Scene.from_dict(d).options()["volume_directions"] == "centre"
    d["render"]["multiple_scattering"]["volume"]["directions"] = "mean"
    _, mean = hs.render(hs.Scene.from_dict(d), return_stats=True)
    assert not mean["volume_reused"]


def test_03_the_volume_adds_light_and_only_light():
    """The volume holds light that scattered at least once: the render with
    it is the render without it plus a non-negative term, everywhere."""
    sc = hs.Scene.from_dict(_small(lights=[{"type": "directional", "direction": [0.2, 0.4, -1.0],
                                            "intensity": [4, 4, 4]}]))
    none = hs.render(sc, multiple_scattering="none")
    vol = hs.render(sc)
    assert (vol >= none - 1e-6).all()
    # blond under a backlight: much of what is seen is multiple scattering
    # (measured 1.42x on this 1500-strand head; the truth of the 10k-strand
    # blond_back is 2.5x its single scattering)
    assert vol.mean() > 1.3 * none.mean()


def test_04_calibrated_medium_transmits_as_the_strands():
    """Under the medium transport, the medium's cross-section is scaled so
    that its mean transmittance over 16384 rays from the hair equals that
    of the same rays traced through the strands (bisection to 2^-40
    relative). The strands transport flies its photons between the strands
    themselves and never reads the cross-section: it does not calibrate,
    and says so (None)."""
    sc = hs.Scene.from_dict(_small())
    medium_transport = {"volume": {"photons": 65536, "resolution": 24, "transport": "medium"}}
    _, st = hs.render(sc, multiple_scattering=medium_transport, return_stats=True)
    strands, medium, calibrated = st["volume_transmittance"]
    assert 0 < strands < 1 and 0 < medium < 1
    assert abs(calibrated - strands) < 1e-6
    _, st = hs.render(sc, return_stats=True)
    assert st["volume_voxels"] > 0 and st["volume_transmittance"] is None


@pytest.mark.parametrize("settings, field", [
    ({"volume": {"photons": 0}}, "photons"),
    ({"volume": {"resolution": 4}}, "resolution"),
    ({"volume": {"bins": 17}}, "bins"),
    ({"volume": {"smoothing": 1}}, "smoothing"),
])
def test_05_bad_settings_name_the_field(settings, field):
    with pytest.raises(hs.SceneError, match=f"multiple_scattering.volume.{field}"):
        hs.render(hs.Scene.from_dict(_small()), multiple_scattering=settings)


def test_06_deon_hair_takes_no_volume():
    d = _small(material={"model": "deon", "base_color": [0.5, 0.4, 0.3]})
    with pytest.raises(hs.SceneError, match="volume"):
        hs.render(hs.Scene.from_dict(d))


@pytest.mark.slow
def test_07_white_furnace(tmp_path):
    """White fibers (no absorption) under a white environment, no head: a
    hair pixel is 1, short of the 2% target here. Measured on this
    10k-strand head: mean over hair pixels 0.966 with the default strands
    transport and the preset's 2^21 photons on 96 cells a side (0.971 at
    2^20 on 48 cells, 0.966 at 2^18), 0.927 through the fiber medium at 48
    cells (dual scattering 0.75; in docs/volume.md the multiple-scattering
    part against Mitsuba's, which reads 1.000 here); 17% of the pixels
    within 2% (18% on 48 cells, 11% at 2^18), the per-pixel spread partly
    the photons' noise. Bound (a regression check, not the target):
    mean at least 0.91 (the 0.905 of a tally by volume instead of by
    fibers fails it), at most 1.02; no pixel non-finite or negative."""
    d = json.loads((DENSE / "blond_env.json").read_text())
    d.update(meshes=[], lights=[{"type": "environment", "radiance": [1, 1, 1]}], render={})
    d["hair"]["material"].update(eumelanin=0.0, pheomelanin=0.0)
    img = hs.render(hs.Scene.from_dict(d), quality="accurate", multiple_scattering="volume")
    d["hair"]["material"].update(eumelanin=8.0)
    mask = hs.render(hs.Scene.from_dict(d), quality="accurate", multiple_scattering="none").mean(-1) < 0.3
    assert np.isfinite(img).all() and img.min() >= 0
    v = img.mean(-1)[mask]
    assert mask.sum() > 5000
    assert 0.91 <= v.mean() <= 1.02, v.mean()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["auburn_key", "blond_env"])
def test_08_against_path_tracing(name, tmp_path):
    """The accurate preset with volume scattering against the converged
    reference (llvm_ad_rgb; halves relMSE 9.8e-5 and 6.2e-4), and its
    multiple-scattering part (render minus the same without multiple
    scattering) against the truth's (the reference minus Mitsuba at
    max_depth 2). Measured with the preset's 2^21 photons a light on 96
    cells a side and 128 coverage samples, the scenes' polylines
    (docs/volume.md's second table): auburn_key means 1.017/1.010/0.999,
    relMSE 3.30e-4, MS part 1.041/1.041/0.996; blond_env
    0.996/1.000/1.001, 1.55e-3, MS 0.974/0.995/1.019 (dual scattering:
    auburn_key 0.964/0.935/0.955, MS 0.93/0.78/0.55). Bounds: means within
    3% (the largest miss is 1.7%), MS part within 8% (4.1%), relMSE at
    most 1.55x the measured (the photons are the same in every run: the
    margin covers other CPUs' rounding, not noise)."""
    ref = hs.read_exr(str(DENSE / f"{name}.exr"))
    depth2 = hs.read_exr(str(DENSE / f"{name}_depth2.exr"))
    sc = _without_settings(name, tmp_path)
    img = hs.render(sc, quality="accurate", multiple_scattering="volume")
    none = hs.render(sc, quality="accurate", multiple_scattering="none")
    mean = lambda a: a.reshape(-1, 3).mean(0)  # noqa: E731
    np.testing.assert_allclose(mean(img) / mean(ref), 1, atol=0.03)
    np.testing.assert_allclose(mean(img - none) / mean(ref - depth2), 1, atol=0.08)
    assert hs.rel_mse(img, ref) < {"auburn_key": 5.1e-4, "blond_env": 2.4e-3}[name]


def test_09_the_solve_stops_on_ctrl_c():
    """2^26 photons (about a minute of tracing on 2 cores): Ctrl-C raises
    KeyboardInterrupt within 3 s (the solve looks at the cancel flag
    between chunks of 2048 photons, a few ms each; measured 0.1 s)."""
    from test_hostile import _interrupt_after

    d = _small()
    d["render"] = {"multiple_scattering": {"volume": {"photons": 1 << 26}}}
    dt, err = _interrupt_after(f"""
        s = hs.Scene.from_dict({d!r})
        print("go", flush=True)
        hs.render(s, progress=False)
        print("finished")""", delay=1.5)
    assert "KeyboardInterrupt" in err, err[-2000:]
    assert dt < 3.0, f"{dt:.2f} s from Ctrl-C to exit"


def test_10_progress_counts_the_solve():
    """The render's progress holds the solve (100 steps, counted per chunk
    of photons) besides the tiles, ends at its total, and a reused solve
    counts its steps at once."""
    from hairshade import _native
    from hairshade.render import _native_scene

    sc = hs.Scene.from_dict(_small())
    sc.render = {"multiple_scattering": {"volume": {"photons": 65537}}}  # a solve of its own
    calls: list = []
    for _ in range(2):
        calls.clear()
        _native.render(_native_scene(sc, dict(sc.camera)), sc.options(), lambda d, t: calls.append((d, t)))
        done, total = calls[-1]
        assert done == total
        assert total > 100
    none = hs.Scene.from_dict(_small())
    none.render = {"multiple_scattering": "none"}
    calls.clear()
    _native.render(_native_scene(none, dict(none.camera)), none.options(), lambda d, t: calls.append((d, t)))
    assert calls[-1][1] == total - 100


@pytest.mark.parametrize("transport", ["medium", "strands"])
def test_11_cycles_shadow_rule_leaves_the_solve_alone(transport):
    """Traced shadows' ``own_strand: "passes"`` (Cycles' rule) changes the
    single scattering only: the volume's part (the render minus the same
    render without it) is the same under both rules, with the photons in
    the medium and between the strands. Float sums in another order: 1e-6."""
    d = _small()
    d["render"] = {"quality": "accurate", "multiple_scattering": {"volume": {
        "photons": 65536, "resolution": 24, "transport": transport}}}
    sc = hs.Scene.from_dict(d)
    part = {}
    for own in ("passes", "shadows"):
        # two other lightings first, so that this one is solved afresh (the
        # renderer keeps the last two solves)
        for k in (2, 3):
            other = json.loads(json.dumps(d))
            other["lights"][0]["intensity"] = [k, k, k]
            hs.render(hs.Scene.from_dict(other))
        shadows = {"traced": {"own_strand": own}}
        part[own] = hs.render(sc, shadows=shadows) - hs.render(sc, shadows=shadows, multiple_scattering="none")
    assert part["shadows"].mean() > 0
    np.testing.assert_allclose(part["passes"], part["shadows"], atol=1e-6)


def test_12_a_strand_is_not_lit_by_its_own_light():
    """Under the strands transport, light is tallied per group of the strand
    that last scattered it, and a fiber reads only the other groups' light
    (scaled by their share). One straight strand alone, no head: its light
    never meets it again, so its multiple scattering is exactly none, as in
    the truth. Read from a cell's whole tally, the strand gets its own
    light back: measured 1.28x its single scattering under the strands
    transport before groups, and 1.15x under the medium transport (whose
    events belong to no strand), which the last line checks, so that the
    test sees the difference it guards."""
    d = _small(lights=[{"type": "directional", "direction": [0.3, 0.2, -1.0], "intensity": [4, 4, 4]}])
    d["meshes"] = []
    d["hair"] = {"strands": [{"points": [[-0.3, -0.2, 0.0], [0.3, 0.25, 0.05]], "radius": 0.004}],
                 "material": {"model": "chiang", "eumelanin": 0.1, "pheomelanin": 0.05}}
    sc = hs.Scene.from_dict(d)
    none = hs.render(sc, multiple_scattering="none")
    assert none.mean() > 0
    vol = {"photons": 65536, "resolution": 24}
    strands = hs.render(sc, multiple_scattering={"volume": dict(vol, transport="strands")})
    medium = hs.render(sc, multiple_scattering={"volume": dict(vol, transport="medium")})
    np.testing.assert_allclose(strands, none, rtol=1e-5, atol=1e-7)
    assert medium.mean() > 1.01 * none.mean()


def test_13_memory_estimate_bounds_what_the_solve_takes(tmp_path):
    """The render refuses what it estimates will not fit, so the estimate
    must bound what it takes, and not by so much that a fitting solve is
    refused. The tallies are kept for the cells holding hair only (a shell
    around the head), and the estimate counts exactly those. Measured in a
    fresh process on a dense head at 96 cells a side: the process's peak
    resident memory grows by at most the estimate, and by at least a
    third of it (the estimate counts the dense grids and the tallies at
    their peak: measured 0.75 GiB grown against a 1.05 GiB estimate; at
    the accurate preset's 8 x 8 bins, 1.4 GiB peak against 1.78. Before
    the cells holding hair were counted, every cell of the grid was, and
    the estimate at 8 x 8 bins was 15.5 GiB: the solve was refused on a
    16 GiB machine)."""
    # (VmHWM: the process's own high-water mark; getrusage's ru_maxrss starts
    # a child at its parent's, and this test process's is larger)
    code = f"""
import json, hairshade as hs
def high_water():
    return next(int(line.split()[1]) for line in open("/proc/self/status") if line.startswith("VmHWM:")) * 1024
d = json.load(open({str(DENSE / 'blond_back.json')!r})); d["render"] = {{}}
sc = hs.Scene.from_dict(d)
before = high_water()
img, st = hs.render(sc, 64, 36, multiple_scattering={{"volume": {{"resolution": 96, "photons": 4096}}}},
                    return_stats=True, progress=False)
print(json.dumps(dict(estimate=st["memory_estimate"], grown=high_water() - before)))
"""
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout
    m = json.loads(out.strip().splitlines()[-1])
    assert m["grown"] <= m["estimate"], m
    assert m["grown"] >= m["estimate"] / 3, m


def test_14_reference_noise_is_the_spread_of_simulated_references():
    """scripts/volume_compare.py's standard error of a truth's multiple-
    scattering mean (`ms_part_noise`, from the relMSE of each reference's
    two halves), against the spread of that mean over 400 simulated pairs
    of references (a truth and a max_depth-2 render, each the mean of two
    noisy halves with the per-pixel noise relMSE assumes, variance
    proportional to r^2 + 0.01). The spread of 400 draws is known to about
    1/sqrt(800) = 3.5%; the bound is 12%."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "scripts"))
    import volume_compare as vc

    rng = np.random.default_rng(14)
    truth = rng.uniform(0.0, 1.0, (40, 60, 3)) * np.array([1.0, 0.6, 0.3])
    depth2 = truth * np.array([0.8, 0.9, 0.97])  # the parts: 20%, 10%, 3% of the truth
    sigma = {"truth": 0.05, "depth2": 0.03}  # a half's noise, relative to sqrt(r^2 + 0.01)

    def reference(img, s):
        halves = [img + s * np.sqrt(img ** 2 + 0.01) * rng.standard_normal(img.shape) for _ in range(2)]
        return (halves[0] + halves[1]) / 2, float(np.mean((halves[0] - halves[1]) ** 2 / (img ** 2 + 0.01)))

    means, estimates = [], []
    for _ in range(400):
        ref, h_ref = reference(truth, sigma["truth"])
        d2, h_d2 = reference(depth2, sigma["depth2"])
        means.append(ref.reshape(-1, 3).mean(0) - d2.reshape(-1, 3).mean(0))
        estimates.append(vc.ms_part_noise(ref, d2, (h_ref, h_d2)))
    ms = truth.reshape(-1, 3).mean(0) - depth2.reshape(-1, 3).mean(0)
    spread = np.std(means, axis=0) / ms
    estimate = np.mean(estimates, axis=0)
    assert np.all(np.abs(estimate / spread - 1) < 0.12), (estimate, spread)
