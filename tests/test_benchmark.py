"""hairshade bench: rows, CSV, plot, Pareto front (fast mode, small batch;
the numbers themselves are measurements, not test conditions)."""

import csv
import subprocess
import sys

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
    """The PNG decodes to the figure's size (11 x 5.5 in at 130 dpi, saved
    without cropping) and shows one marker per row with an error, each
    (model, variant, precision) in its own colour of matplotlib's 20-colour
    table (row i: colour i), in the axes and in the legend: 100 to 121 pixels of each row's exact colour
    (measured, marker and legend handle), so 50 per row is required. The
    greys (table entries 14, 15) are not checked: the figure has other
    pixels of similar greys."""
    import matplotlib.pyplot as plt

    rows = [dict(model="KarisHair", variant=f"v{i}", precision="f32", threads="all", evals_per_s=10.0 ** (3 + i / 2),
                 rel_l2_error=10.0 ** -i) for i in range(14)]
    rows.append(dict(rows[0], variant="no error", rel_l2_error=float("nan")))  # skipped, not drawn
    benchmark.plot(rows, tmp_path / "b.png")
    img = plt.imread(tmp_path / "b.png")
    assert img.shape[:2] == (round(5.5 * 130), 11 * 130)
    px = np.round(img[..., :3] * 255).astype(int)
    colors = plt.get_cmap("tab20").colors
    for i in range(14):
        colour = np.round(np.array(colors[i]) * 255).astype(int)
        count = int(np.all(px == colour, axis=-1).sum())
        assert count >= 50, f"row {i}: {count} pixels of its colour"


def test_render_bench_steps_checked_and_merged(tmp_path):
    """`--render-steps` names steps of bench_render.STEPS (anything else is
    an error naming the allowed ones, before any work), and `merge` puts a
    partial run's rows in place of the same steps' rows of the committed
    CSV, keeping the others and the order of the steps."""
    from hairshade import bench_render

    with pytest.raises(ValueError, match="steps: expected names among frame"):
        bench_render.render_runtime_vs_error(steps=("dense", "bogus"), progress_bar=False)
    row = lambda section, scene, variant, ms: dict(  # noqa: E731
        section=section, scene=scene, variant=variant, width=320, height=180, threads="all", spp=0, ms=ms, rel_mse=0.1)
    old = [row("frame", "strand_head", "cold", 1.0),
           row("error", "single_strand", "rasterizer (chiang)", 2.0),
           row("error", "auburn_key", "rasterizer (chiang, old label)", 3.0),
           row("mitsuba", "auburn_key", "mitsuba path (chiang)", 4.0),
           row("strands", "strand_head", "1000 strands", 5.0)]
    path = tmp_path / "bench_render.csv"
    bench_render.write_csv(old, str(path))
    new = [dict(row("error", "ginger_two", "rasterizer (chiang, default)", 6.0), step="dense")]
    merged = bench_render.merge(bench_render.read_csv(str(path)), new)
    # the dense heads' old rows (whatever their labels) are gone; the
    # single-strand comparison (step `error`) and the other steps stay
    assert [(r["scene"], r["ms"]) for r in merged] == [
        ("strand_head", 1.0), ("single_strand", 2.0), ("ginger_two", 6.0), ("strand_head", 5.0)]
    r = subprocess.run([sys.executable, "-m", "hairshade.cli", "bench", "--render-only", "--render-steps", "dense,x"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "--render-steps: expected comma-separated names among" in r.stderr
