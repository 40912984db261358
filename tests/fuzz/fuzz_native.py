"""Fuzz target for the private `_native` entry points (atheris / libFuzzer).

The bytes pick a function of `hairshade._native` (the renderer with a
scene dict as `hairshade.render` builds it, the model constructors and
their batch methods, the image readers and writers, the special
functions) and hostile values for its arguments: NaN, infinities, huge
integers, wrong types and shapes, inconsistent strand offsets. The Python
API checks its arguments before they get here; these entry points must
check them again. Allowed outcomes: a result or a ValueError, TypeError,
OverflowError, MemoryError or OSError. A PanicException (a Rust panic
crossing into Python), any other exception, a crash or a hang is a
finding.

    python tests/fuzz/fuzz_native.py tests/fuzz/corpus_native -max_total_time=60
"""

import os
import sys
import tempfile

import atheris

with atheris.instrument_imports():
    import numpy as np

    import hairshade as hs
    from hairshade import _native
    from hairshade.render import _native_scene

ALLOWED = (ValueError, TypeError, OverflowError, MemoryError, OSError)
OUT = os.path.join(tempfile.mkdtemp(), "fuzz_native.exr")
_SCENE = hs.Scene.from_arrays(np.array([[0, 0, 0], [0, 1, 0], [0.1, 0, 0], [0.1, 1, 0.0]]), 0.01, [0, 2, 4])
BASE = _native_scene(_SCENE, dict(_SCENE.camera, width=16, height=9))
OPTIONS = _SCENE.options()
# the native models behind the public classes (DEonHair stratified: converged pairs take a millisecond each)
MODELS = [hs.ChiangHair()._native, hs.KarisHair()._native, hs.DEonHair(h_samples=16)._native]


FLOATS = [float("nan"), float("inf"), -float("inf"), 1e39, -1.0, 0.0, -0.0, 1e-45, 3e38, 1e18, 0.5, 2.0]
INTS = [-1, 0, 1, 2, 3, 2**31, 2**32 - 1, 2**40, 2**64, 16384, 16385]


def value(fdp: "atheris.FuzzedDataProvider", like: object = None) -> object:
    """A hostile value, mostly of the kind of ``like`` (floats for a float,
    arrays of its dtype with hostile entries and lengths for an array,
    element by element for a tuple), sometimes of another kind."""
    if like is None or fdp.ConsumeIntInRange(0, 7) == 0:
        pool = [None, True, "abc", "r", [], [1, 2], {"a": 1}, (2**40, 2, 1.0), OUT, "/dev/null",
                "/nonexistent/x.png", *FLOATS[:4], *INTS[4:]]
        return fdp.PickValueInList(pool)
    if isinstance(like, bool):
        return fdp.ConsumeBool()
    if isinstance(like, int):
        return fdp.PickValueInList(INTS)
    if isinstance(like, float):
        return fdp.PickValueInList(FLOATS)
    if isinstance(like, np.ndarray):
        n = fdp.PickValueInList([0, 1, 2, 3, len(like), len(like) + 1, max(len(like) - 1, 0), 3 * len(like)])
        if like.dtype.kind == "f":
            return np.array([fdp.PickValueInList(FLOATS) for _ in range(n)], dtype=like.dtype)
        return np.array([fdp.PickValueInList([0, 1, 2, 3, 4, 5, 2**31, 2**32 - 1]) for _ in range(n)],
                        dtype=like.dtype)
    if isinstance(like, (list, tuple)):
        out = list(like)
        if out:
            i = fdp.ConsumeIntInRange(0, len(out) - 1)
            out[i] = value(fdp, out[i])
        return type(like)(out) if isinstance(like, tuple) else out
    if isinstance(like, dict):
        out = dict(like)
        if out:
            k = fdp.PickValueInList(sorted(out))
            out[k] = value(fdp, out[k])
        return out
    return value(fdp)


def render(fdp: "atheris.FuzzedDataProvider") -> None:
    scene = dict(BASE)
    for _ in range(fdp.ConsumeIntInRange(1, 3)):
        key = fdp.PickValueInList(sorted(k for k in scene if k != "hair"))
        scene[key] = value(fdp, scene[key])
    options = value(fdp, OPTIONS) if fdp.ConsumeIntInRange(0, 3) == 0 else OPTIONS
    _native.render(scene, options, None)


def pairs(fdp: "atheris.FuzzedDataProvider", n: int) -> np.ndarray:
    """n directions (flat float32) with hostile entries now and then."""
    a = np.tile(np.array([0.3, 0.2, 0.9], np.float32), n)
    for _ in range(fdp.ConsumeIntInRange(0, 3)):
        if len(a):
            a[fdp.ConsumeIntInRange(0, len(a) - 1)] = fdp.PickValueInList(FLOATS)
    return a


def model_call(fdp: "atheris.FuzzedDataProvider") -> None:
    m = fdp.PickValueInList(MODELS)
    meths = sorted(x for x in dir(m) if not x.startswith("_") and callable(getattr(m, x)))
    n = fdp.PickValueInList([0, 1, 2, 17])
    args = [pairs(fdp, n) if fdp.ConsumeBool() else value(fdp, 0.5) for _ in range(fdp.ConsumeIntInRange(0, 4))]
    getattr(m, fdp.PickValueInList(meths))(*args)


def function(fdp: "atheris.FuzzedDataProvider") -> None:
    name, like = fdp.PickValueInList([
        ("chiang_azimuthal_scale", (0.3,)), ("chiang_longitudinal_variance", (0.3,)), ("i0e", (1.0,)),
        ("log_i0", (1.0,)), ("lobe", ("r", [0.5] * 6)), ("read_exr", (OUT, 16)), ("read_png", (OUT, 16)),
        ("render_options", (OPTIONS,)), ("srgb8", (np.ones(12, np.float32), 0.0, True)),
        ("write_exr", (OUT, np.ones((2, 2, 3), np.float32))), ("write_png", (OUT + ".png", np.ones((2, 2, 3), np.float32), 0.0)),
    ])
    getattr(_native, name)(*value(fdp, like))


def one_input(data: bytes) -> None:
    fdp = atheris.FuzzedDataProvider(data)
    target = fdp.PickValueInList([render, model_call, function])
    try:
        target(fdp)
    except ALLOWED:
        pass


def main() -> None:
    atheris.Setup(sys.argv, one_input)
    atheris.Fuzz()


if __name__ == "__main__":
    main()
