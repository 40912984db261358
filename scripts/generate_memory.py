"""Peak bytes per vertex of procedural hair (hairshade.generate), through
the float32 copy a scene makes: the measurement behind
``generate.BYTES_PER_VERTEX``.

    python scripts/generate_memory.py
"""

import tracemalloc

import numpy as np

from hairshade.generate import generate

for kind in ("head", "bundle"):
    for n, k in ((20000, 16), (5000, 64)):
        tracemalloc.start()
        gp, gr = generate({"kind": kind, "strands": n, "segments": k})
        points = np.concatenate(gp).astype(np.float32)
        radii = np.concatenate(gr).astype(np.float32)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        del gp, gr, points, radii
        print(f"{kind:6s} {n:6d} strands x {k:3d} segments: {peak / (n * (k + 1)):6.1f} bytes per vertex (peak)")
