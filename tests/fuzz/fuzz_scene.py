"""Fuzz target for the scene loader (atheris / libFuzzer).

Input bytes are parsed as JSON and loaded with Scene.from_dict; valid scenes
are rendered at a tiny resolution. Allowed outcomes: a SceneError (the
loader's documented error) or a finite, non-negative image. Anything else
(another exception, a NaN pixel, a crash) is a finding.

    python tests/fuzz/fuzz_scene.py tests/fuzz/corpus -max_total_time=60
"""

import json
import sys

import atheris

with atheris.instrument_imports():
    import numpy as np

    import hairshade as hs


def one_input(data: bytes) -> None:
    try:
        d = json.loads(data.decode("utf-8", errors="replace"))
    except (ValueError, RecursionError):
        return
    try:
        scene = hs.Scene.from_dict(d, base_dir="/nonexistent", source="fuzz.json")
    except hs.SceneError:
        return
    # Keep renders tiny and bounded.
    if scene.points.shape[0] > 20000 or (scene.cards is not None and len(scene.cards["tangents"]) > 5000):
        return
    img = hs.render(scene, width=16, height=9, progress=False)
    if not (np.all(np.isfinite(img)) and np.all(img >= 0)):
        raise RuntimeError("non-finite or negative pixel")


def main() -> None:
    atheris.Setup(sys.argv, one_input)
    atheris.Fuzz()


if __name__ == "__main__":
    main()
