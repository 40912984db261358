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
