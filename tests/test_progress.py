"""The one progress bar (hairshade._progress): tqdm's when installed, else
text on stderr; both with count, rate and ETA; hidden when disabled."""

from __future__ import annotations

import pytest

from hairshade import _progress


def test_01_text_line_rate_and_eta():
    line = _progress.text_line("sweep", 5, 20, 2.0, unit="tile")
    # 5 tiles in 2 s: 2.5 tiles/s; 15 left: 6 s
    assert "sweep [#######" in line and "5/20" in line
    assert "2.50 tile/s" in line and "ETA    6.0s" in line
    assert "ETA      ?" in _progress.text_line("sweep", 0, 20, 0.0)


def test_02_text_bar_when_tqdm_is_missing(monkeypatch, capsys):
    monkeypatch.setattr(_progress, "_tqdm", lambda: None)
    assert list(_progress.progress(range(4), desc="four", enabled=True)) == [0, 1, 2, 3]
    err = capsys.readouterr().err  # not a terminal: auto mode draws nothing
    assert err == ""
    with _progress.Bar(3, "forced", enabled=True) as bar:
        for k in range(1, 4):
            bar.update_to(k)
    err = capsys.readouterr().err
    assert err.count("\r") == 3 and "3/3" in err and "it/s" in err and err.endswith("\n")


def test_03_tqdm_bar_when_installed(capsys):
    pytest.importorskip("tqdm")
    with _progress.Bar(10, "tq", unit="pass", enabled=True) as bar:
        bar.update_to(4)
        bar.update_to(10)
        assert bar._tq is not None and bar._tq.n == 10
    assert "10/10" in capsys.readouterr().err


def test_04_disabled_draws_nothing(capsys):
    with _progress.Bar(5, "off", enabled=False) as bar:
        bar.update_to(5)
    assert list(_progress.progress([1, 2], enabled=False)) == [1, 2]
    assert capsys.readouterr().err == ""
