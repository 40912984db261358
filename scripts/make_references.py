"""Regenerates the Mitsuba references of tests/data (direct lighting, the
scene variants of hairshade.references; ChiangHair through Mitsuba's
`hair`, and KarisHair through the hairshade_karis plugin). Takes about a minute with
Mitsuba's llvm_ad_rgb variant.

    .venv/bin/python scripts/make_references.py
"""

import os
import sys
import time

import hairshade as hs
from hairshade import mitsuba as hm
from hairshade.references import CASES, KARIS_CASES, comparison_scene, karis_reference_path, karis_scene, reference_path

DATA = os.path.join(os.path.dirname(__file__), "..", "tests", "data")


def main() -> int:
    os.makedirs(DATA, exist_ok=True)
    for name, c in CASES.items():
        scene = comparison_scene(name)
        t = time.perf_counter()
        img = hm.render(scene, spp=c["spp"], integrator="direct", width=c["width"], height=c["height"], progress=True)
        hs.write_exr(reference_path(name, DATA), img)
        print(f"{name}: {c['width']}x{c['height']}, {c['spp']} spp, {time.perf_counter() - t:.1f} s")
    for name, c in KARIS_CASES.items():
        scene = karis_scene(name)
        t = time.perf_counter()
        img = hm.render(scene, spp=c["spp"], integrator="direct", width=c["width"], height=c["height"], progress=True,
                        hair_bsdf="karis")
        hs.write_exr(karis_reference_path(name, DATA), img)
        print(f"{name} (KarisHair plugin): {c['width']}x{c['height']}, {c['spp']} spp, {time.perf_counter() - t:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
