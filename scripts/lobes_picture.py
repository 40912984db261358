"""docs/lobes.png: the README's picture of the models' lobes. KarisHair
(UE's real-time model) against its reference DEonHair, per lobe, on the
specular cone (θo = −θi = −30°) over the azimuth, for a brown material
(base colour 0.3/0.15/0.08, roughness 0.4), red channel, and their sum.

    python scripts/lobes_picture.py [--out docs/lobes.png]
"""

from __future__ import annotations

import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import hairshade as hs  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent


def direction(theta_deg: float, phi: np.ndarray) -> np.ndarray:
    t = np.deg2rad(theta_deg)
    phi = np.atleast_1d(phi)
    return np.stack([np.cos(t) * np.cos(phi), np.full_like(phi, np.sin(t)), np.cos(t) * np.sin(phi)], -1)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "docs" / "lobes.png"))
    a = ap.parse_args()
    brown = (0.3, 0.15, 0.08)
    karis = hs.KarisHair(base_color=brown, roughness=0.4, components=("R", "TT", "TRT"))
    deon = hs.DEonHair(base_color=brown, roughness=0.4)
    phi = np.linspace(-np.pi, np.pi, 361)
    T = np.array([0.0, 1.0, 0.0])
    L, V = direction(30.0, np.zeros(1)).repeat(len(phi), 0), direction(-30.0, phi)
    k, d = karis.eval_lobes(L, V, T), deon.eval_lobes(L, V, T)
    fig, axes = plt.subplots(1, 4, subplot_kw={"projection": "polar"}, figsize=(13, 4.0), dpi=100)
    for ax, lobe in zip(axes, ("R", "TT", "TRT")):
        ax.plot(phi, d[lobe][:, 0], label="DEonHair (reference)")
        ax.plot(phi, k[lobe][:, 0], "--", label="KarisHair (UE)")
        ax.set_title(lobe, pad=12)
        ax.set_yticklabels([])
    total_d = sum(d[lobe][:, 0] for lobe in ("R", "TT", "TRT"))
    total_k = sum(k[lobe][:, 0] for lobe in ("R", "TT", "TRT"))
    axes[3].plot(phi, total_d, label="DEonHair (reference)")
    axes[3].plot(phi, total_k, "--", label="KarisHair (UE)")
    axes[3].set_title("R + TT + TRT", pad=12)
    axes[3].set_yticklabels([])
    handles, labels = axes[3].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=9, frameon=False)
    fig.suptitle("Lobes over the azimuth on the specular cone (θi = 30°), brown hair, red channel", fontsize=10)
    fig.tight_layout(rect=(0, 0.08, 1, 0.9))
    fig.savefig(a.out)
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
