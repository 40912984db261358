"""hairshade bench: rows, CSV, plot, Pareto front (fast mode, small batch;
the numbers themselves are measurements, not test conditions)."""

import csv

import numpy as np
import pytest

from hairshade import benchmark


@pytest.mark.mitsuba  # times Mitsuba's `hair` beside ours when Mitsuba is installed
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
    # The CSV holds the rows' values: floats are written with 6 significant
    # digits, so they read back within half a unit of the 6th (5e-6 relative).
    for r, line in zip(rows, csv.DictReader(lines)):
        assert [line[k] for k in ("model", "variant", "precision", "threads")] == [
            r["model"], r["variant"], r["precision"], r["threads"]]
        for k in ("evals_per_s", "rel_l2_error"):
            np.testing.assert_allclose(float(line[k]), r[k], rtol=5e-6, atol=0, equal_nan=True, err_msg=k)


def test_bench_plot_draws_every_row(tmp_path):
    """The PNG decodes to the figure's size (8 x 5 in at 130 dpi, saved
    without cropping) and shows one marker per row with an error: points
    take the colours of matplotlib's 10-colour cycle in turn, so with 12
    rows C0 and C1 mark two points and C2..C9 one. A marker (25 pt^2, ~9 px
    across) is 69 pixels of its exact colour here (measured; these points
    are far apart), so 50 per marker is required. C7 (grey 127) is not
    checked: other parts of the figure have 85 pixels of that grey with no
    C7 marker drawn (measured)."""
    import matplotlib.colors
    import matplotlib.pyplot as plt

    rows = [dict(model="M", variant=f"v{i}", precision="f32", threads="all", evals_per_s=10.0 ** (3 + i / 2),
                 rel_l2_error=10.0 ** -i) for i in range(12)]
    rows.append(dict(rows[0], variant="no error", rel_l2_error=float("nan")))  # skipped, not drawn
    benchmark.plot(rows, tmp_path / "b.png")
    img = plt.imread(tmp_path / "b.png")
    assert img.shape[:2] == (5 * 130, 8 * 130)
    px = np.round(img[..., :3] * 255).astype(int)
    for i in (0, 1, 2, 3, 4, 5, 6, 8, 9):
        colour = np.round(np.array(matplotlib.colors.to_rgb(f"C{i}")) * 255).astype(int)
        markers = 2 if i < 2 else 1
        count = int(np.all(px == colour, axis=-1).sum())
        assert count >= 50 * markers, f"C{i}: {count} pixels for {markers} marker(s)"


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
