"""Renders a million sub-pixel strands (one segment each, radius 1e-4, spread
over the view) and prints `peak_rss_mb before_mb fragments non_finite bad_pixels estimate_mb` for
tests/test_stress.py test 7 (run in its own process so that its peak memory
is its own: VmHWM, the process's own high-water mark, not getrusage's
ru_maxrss, which a child started by fork and exec inherits from its parent,
so that a large test process hides what the render takes)."""

import sys

import numpy as np

import hairshade as hs

n = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
rng = np.random.default_rng(7)
base = rng.uniform([-1.0, -0.6, -0.5], [1.0, 0.6, 0.5], size=(n, 3))
tip = base + rng.normal(scale=0.01, size=(n, 3))
points = np.stack([base, tip], axis=1).reshape(-1, 3)
d = {
    "hairshade_scene": 1,
    "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 40, "resolution": [320, 180]},
    "lights": [{"type": "directional", "direction": [0.3, 0.8, 0.5], "intensity": [2, 2, 2], "shadows": True},
               {"type": "environment", "radiance": [0.2, 0.2, 0.25]}],
    "hair": {"strands": [{"points": [[0, 0, 0], [0, 0.01, 0]], "radius": 1e-4}], "material": {"model": "karis"}},
}
scene = hs.Scene.from_dict(d)
scene.points = points.astype(np.float32)
scene.radii = np.full(2 * n, 1e-4, np.float32)
scene.offsets = np.arange(0, 2 * n + 1, 2, dtype=np.uint32)


def high_water_mb() -> float:
    """VmHWM of /proc/self/status, in MB."""
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmHWM:")) / 1024


before = high_water_mb()
img, st = hs.render(scene, quality="fast", return_stats=True, progress=False)
peak = high_water_mb()
print(f"{peak:.0f} {before:.0f} {st['fragments']} {st['non_finite_pixels']} {int((~np.isfinite(img)).sum())} "
      f"{st['memory_estimate'] / 2**20:.0f}")
