"""A probe, not a renderer: does light diffusing through the hair volume
explain where the truth's multiple scattering lies better than dual
scattering's straight-line fiber counts?

For one dense scene it builds, in numpy, a grid of fiber cross-section per
unit length (orientation-averaged: each segment adds 2 r ℓ π/4 / V), the
light each light scatters at its first fiber crossing (σ e^{-n} · E ·
(a_f + a_b), n marched to the light, zero where the head blocks the path),
and solves the diffusion equation

    −∇·(D ∇φ) + σ_a φ = q,   σ_a = σ (1 − a_f − a_b),
    D = 1 / (3 (σ_a + σ (a_f + a_b)(1 − g))),   g = (a_f − a_b) / (a_f + a_b)

per channel (a_f, a_b from ChiangHair.dual_terms at normal incidence), with
φ = 0 outside the hair (σ below --vacuum) and inside the head. The image of
it is read through the camera's fiber-count transmittance: Σ σ e^{-n_cam}
(a_f + a_b) φ / 4π ds.

The truth's multiple scattering is the converged reference minus Mitsuba at
max_depth 2 (2 × 512 spp); the rasterizer's is the most accurate
configuration of docs/dense_hair.md minus the same without multiple
scattering. Printed: relMSE of the rasterizer's single scattering plus (a)
dual, (b) the diffusion image as solved, (c) dual scaled per channel by
least squares, (d) a least-squares mix a·dual + b·diffusion per channel.
(c) and (d) are fitted to the truth: they say how much of the truth's
spatial pattern each term can carry, not what a model would render.

    python scripts/diffusion_probe.py [--scene blond_back] [--grid 80] [--vacuum 2]
"""

from __future__ import annotations

import argparse
import json
import pathlib
import sys
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl
from scipy.ndimage import map_coordinates

import hairshade as hs

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from dense_compare import DENSE, direct_halves, render_best  # noqa: E402

LIGHT_DIRECTIONS = 32  # the environment as the renderer's Fibonacci lattice


class Grid:
    def __init__(self, scene: hs.Scene, res: int) -> None:
        p, r, off = scene.points.astype(np.float64), scene.radii.astype(np.float64), scene.offsets
        self.lo, hi = p.min(0) - 0.05, p.max(0) + 0.05
        self.vox = float((hi - self.lo).max() / res)
        self.dims = tuple(int(x) for x in np.ceil((hi - self.lo) / self.vox))
        self.extent = float(np.linalg.norm(hi - self.lo))
        self.centre = 0.5 * (self.lo + hi)
        first = np.concatenate([np.arange(off[s], off[s + 1] - 1) for s in range(len(off) - 1)])
        a, b = p[first], p[first + 1]
        rr = 0.5 * (r[first] + r[first + 1])
        length = np.linalg.norm(b - a, axis=1)
        k = int(max(1, np.ceil(length.max() / (0.5 * self.vox))))
        self.sigma = np.zeros(self.dims)
        for j in range(k):  # each segment as k points, nearest voxel
            idx = np.floor((a + (j + 0.5) / k * (b - a) - self.lo) / self.vox).astype(int)
            np.add.at(self.sigma, tuple(idx.T), 2 * rr * length / k * (np.pi / 4))
        self.sigma /= self.vox**3
        axes = [self.lo[i] + self.vox * (np.arange(self.dims[i]) + 0.5) for i in range(3)]
        self.centres = np.stack(np.meshgrid(*axes, indexing="ij"), -1)

    def sample(self, field: np.ndarray, x: np.ndarray) -> np.ndarray:
        g = (x - self.lo) / self.vox - 0.5
        return map_coordinates(field, [g[..., 0], g[..., 1], g[..., 2]], order=1, mode="constant", cval=0.0)


def lights_of(d: dict) -> list[tuple[np.ndarray, np.ndarray]]:
    """(unit direction towards the light, irradiance) per directional light;
    an environment as LIGHT_DIRECTIONS directions of 4π L / K each."""
    out = []
    for light in d["lights"]:
        if light.get("type") == "environment":
            k = LIGHT_DIRECTIONS
            i = np.arange(k) + 0.5
            z = 1 - 2 * i / k
            ph = np.pi * (1 + 5**0.5) * i
            dirs = np.stack([np.sqrt(1 - z**2) * np.cos(ph), z, np.sqrt(1 - z**2) * np.sin(ph)], -1)
            out += [(dl, np.array(light["radiance"], float) * 4 * np.pi / k) for dl in dirs]
        else:
            dl = np.array(light["direction"], float)
            out.append((dl / np.linalg.norm(dl), np.array(light["intensity"], float)))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="blond_back")
    ap.add_argument("--grid", type=int, default=80, help="voxels along the hair's longest side")
    ap.add_argument("--vacuum", type=float, default=2.0, help="σ (1/m) below which a voxel is outside the hair")
    args = ap.parse_args()
    d = json.loads((DENSE / f"{args.scene}.json").read_text())
    ref = hs.read_exr(str(DENSE / f"{args.scene}.exr"))[..., :3].astype(np.float64)
    scene = hs.Scene.from_dict(d)
    halves = direct_halves(d)
    truth_ms = ref - 0.5 * (halves[0] + halves[1])
    images = {ms: render_best(d, multiple_scattering=ms).astype(np.float64) for ms in ("none", "dual")}
    ss, dual_ms = images["none"], images["dual"] - images["none"]

    t0 = time.perf_counter()
    g = Grid(scene, args.grid)
    spheres = [(np.array(m["center"], float), m["radius"]) for m in d.get("meshes", []) if m.get("type") == "sphere"]

    def in_head(x: np.ndarray) -> np.ndarray:
        return np.any([np.linalg.norm(x - c, axis=-1) < rad for c, rad in spheres], axis=0) if spheres else \
            np.zeros(x.shape[:-1], bool)

    def clear(x: np.ndarray, dl: np.ndarray) -> np.ndarray:
        out = np.ones(x.shape[:-1])
        for c, rad in spheres:
            oc = x - c
            b = (oc * dl).sum(-1)
            disc = b * b - (oc**2).sum(-1) + rad**2
            out[(disc > 0) & (-b + np.sqrt(np.maximum(disc, 0)) > 0)] = 0
        return out

    mat = dict(d["hair"]["material"])
    mat.pop("model")
    terms = hs.ChiangHair(**mat).dual_terms()
    mid = terms["a_f"].shape[0] // 2  # sin θ = 0
    a_f, a_b = terms["a_f"][mid], terms["a_b"][mid]
    albedo = a_f + a_b
    gg = (a_f - a_b) / albedo

    # first-scattered light per unit volume
    step = 0.5 * g.vox
    q = np.zeros(g.dims + (3,))
    for dl, e in lights_of(d):
        n = np.zeros(g.dims)
        for s in range(int(np.ceil(g.extent / step))):
            n += g.sample(g.sigma, g.centres + dl * (s + 0.5) * step) * step
        q += (g.sigma * np.exp(-n) * clear(g.centres, dl))[..., None] * e * albedo

    # diffusion, 7-point stencil, φ = 0 at vacuum and head voxels' centres
    active = (g.sigma > args.vacuum) & ~in_head(g.centres)
    index = -np.ones(g.dims, int)
    index[active] = np.arange(active.sum())
    at = np.argwhere(active)
    phi = np.zeros(g.dims + (3,))
    for c in range(3):
        sigma_a = g.sigma * (1 - albedo[c])
        diff = 1 / (3 * np.maximum(sigma_a + g.sigma * albedo[c] * (1 - gg[c]), 1e-6))
        rows, cols, vals = [], [], []
        diag = sigma_a[active] * g.vox**2
        for ax in range(3):
            for sgn in (-1, 1):
                nb = at.copy()
                nb[:, ax] += sgn
                inside = (nb[:, ax] >= 0) & (nb[:, ax] < g.dims[ax])
                nb = np.clip(nb, 0, np.array(g.dims) - 1)
                d_nb = np.where(inside, diff[tuple(nb.T)], 0.0)
                nid = np.where(inside, index[tuple(nb.T)], -1)
                own = diff[active]
                face = np.where(nid >= 0, 2 * own * d_nb / (own + d_nb + 1e-30), own)
                diag = diag + face
                m = nid >= 0
                rows.append(index[active][m])
                cols.append(nid[m])
                vals.append(-face[m])
        me = index[active]
        mat_ = sp.csr_matrix((np.concatenate(vals + [diag]), (np.concatenate(rows + [me]),
                              np.concatenate(cols + [me]))), shape=(len(me), len(me)))
        x, info = spl.cg(mat_, q[..., c][active] * g.vox**2, rtol=1e-6, maxiter=3000)
        if info != 0:
            raise RuntimeError(f"diffusion solve did not converge (channel {c}, info {info})")
        phi[..., c][active] = x

    # the camera's view through the volume
    cam = d["camera"]
    w, h = cam["resolution"]
    pos, tgt, up = (np.array(cam[k], float) for k in ("position", "target", "up"))
    fw = (tgt - pos) / np.linalg.norm(tgt - pos)
    rt = np.cross(fw, up)
    rt /= np.linalg.norm(rt)
    u2 = np.cross(rt, fw)
    focal = 0.5 * h / np.tan(0.5 * np.radians(cam["fov"]))
    px, py = np.meshgrid(np.arange(w) + 0.5 - w / 2, -(np.arange(h) + 0.5 - h / 2))
    rays = fw + (px[..., None] * rt + py[..., None] * u2) / focal
    rays /= np.linalg.norm(rays, axis=-1, keepdims=True)
    t_near = max(np.linalg.norm(pos - g.centre) - 0.5 * g.extent, 0.0)
    n_cam, alive = np.zeros((h, w)), np.ones((h, w))
    diffusion = np.zeros((h, w, 3))
    ds = 0.25 * g.vox
    for s in range(int(g.extent / ds) + 1):
        x = pos + rays * (t_near + (s + 0.5) * ds)
        sg = g.sample(g.sigma, x)
        alive *= ~in_head(x)
        wgt = sg * np.exp(-n_cam) * ds * alive
        diffusion += wgt[..., None] * np.stack([g.sample(phi[..., c], x) for c in range(3)], -1) * albedo / (4 * np.pi)
        n_cam += sg * ds
    took = time.perf_counter() - t0

    weight = 1 / (ref**2 + 1e-2)  # hs.rel_mse's

    def fit(terms_: list[np.ndarray]) -> tuple[np.ndarray, list[np.ndarray]]:
        out, coefs = np.zeros_like(ref), []
        for c in range(3):
            x = np.stack([t[..., c].ravel() for t in terms_], 1)
            sw = np.sqrt(weight[..., c].ravel())
            coef = np.linalg.lstsq(x * sw[:, None], truth_ms[..., c].ravel() * sw, rcond=None)[0]
            out[..., c] = (x @ coef).reshape(ref.shape[:2])
            coefs.append(coef)
        return out, coefs

    hair = ref.mean(-1) > 1e-3
    ratio = diffusion[hair].mean(0) / truth_ms[hair].mean(0)
    scaled, c1 = fit([dual_ms])
    mixed, c2 = fit([dual_ms, diffusion])
    print(f"## {args.scene}: grid {g.dims}, voxel {g.vox * 1000:.1f} mm, probe {took:.0f} s")
    print(f"a_f {np.round(a_f, 3)}, a_b {np.round(a_b, 3)} (sin θ = 0)")
    print("| multiple scattering | relMSE |\n| --- | --- |")
    print(f"| dual | {hs.rel_mse(ss + dual_ms, ref):.2e} |")
    print(f"| diffusion as solved (mean {np.round(ratio, 3)} of the truth's) | {hs.rel_mse(ss + diffusion, ref):.2e} |")
    print(f"| dual × per-channel fit {np.round([c[0] for c in c1], 2)} | {hs.rel_mse(ss + scaled, ref):.2e} |")
    print(f"| fit a·dual + b·diffusion, a {np.round([c[0] for c in c2], 2)}, b {np.round([c[1] for c in c2], 2)} "
          f"| {hs.rel_mse(ss + mixed, ref):.2e} |")
    print(f"| the truth's | {hs.rel_mse(ss + truth_ms, ref):.2e} |")


if __name__ == "__main__":
    main()
