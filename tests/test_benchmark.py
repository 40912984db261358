"""hairshade bench: rows, CSV, Pareto front (fast mode, small batch; the
numbers themselves are measurements, not test conditions)."""

import numpy as np

from hairshade import benchmark


def test_bench_rows_csv_and_pareto(tmp_path):
    rows = benchmark.bsdf_runtime_vs_error(n=4096, repeats=1, fast=True, progress_bar=False)
    models = {r["model"] for r in rows}
    assert {"KarisHair", "ChiangHair"} <= models
    assert all(r["evals_per_s"] > 0 for r in rows)
    # f64 references have zero error by definition; Karis's error is its
    # approximation error against DEonHair (far from zero).
    karis = [r for r in rows if r["model"] == "KarisHair" and r["variant"] == "R+TT+TRT"]
    assert all(0.1 < r["rel_l2_error"] < 2 for r in karis)
    front = benchmark.pareto(rows)
    assert front and all(np.isfinite(r["rel_l2_error"]) for r in front)
    benchmark.write_csv(rows, tmp_path / "b.csv")
    lines = (tmp_path / "b.csv").read_text().splitlines()
    assert lines[0] == "model,variant,precision,threads,evals_per_s,rel_l2_error" and len(lines) == len(rows) + 1
    benchmark.plot(rows, tmp_path / "b.png")
    assert (tmp_path / "b.png").stat().st_size > 1000


def test_equal_error_ratio_interpolates_and_bounds():
    from hairshade.bench_render import equal_error_ratio

    # Mitsuba (ms, relMSE) at increasing spp; error 1/spp, time = spp ms.
    pts = [(1.0, 1.0), (4.0, 0.25), (16.0, 0.0625)]
    r, kind = equal_error_ratio(2.0, 0.5, pts)  # error 0.5 is reached at 2 spp = 2 ms
    assert kind == "interpolated" and abs(r - 1.0) < 1e-12
    assert equal_error_ratio(2.0, 2.0, pts) == (0.5, "<=")  # 1 spp already better
    assert equal_error_ratio(2.0, 0.01, pts) == (8.0, ">=")  # 16 spp not enough


def test_render_bench_csv_round_trip(tmp_path):
    from hairshade import bench_render

    rows = [bench_render._row("frame", "s", "cold", 64, 36, ms=1.5),
            bench_render._row("mitsuba", "s", "mitsuba (chiang)", 64, 36, "mitsuba", 4, 2.0, 0.1)]
    bench_render.write_csv(rows, tmp_path / "r.csv")
    back = bench_render.read_csv(tmp_path / "r.csv")
    assert [(r["section"], r["spp"], r["ms"]) for r in back] == [("frame", 0, 1.5), ("mitsuba", 4, 2.0)]
    assert "Rasterizer ms/frame" in bench_render.summary(back)
