"""Karis 2016 / UE4 `HairShading()`: the real-time hair model, term by term."""

from __future__ import annotations

from typing import Any, Iterable, Sequence

import numpy as np
import numpy.typing as npt

from . import _models
from . import _native
from .lighting import sh_coefficients


class KarisHair(_models.Picklable):
    """UE4's ``HairShading()`` (Karis, SIGGRAPH 2016), term by term.

    ==================== ================== ==========================================
    base_color           (0.3, 0.15, 0.08)  C, RGB, each in [0, 1]
    specular             0.5                [0, 1]; scales R by 2*specular
    roughness            0.5                [0, 1]; clamped to >= 1/255 as UE does
    scatter              0.0                [0, 1]; Kajiya-Kay multiple-scattering weight
    shift                0.035              [-0.25, 0.25]; alpha = (-2, 1, 4) * shift
    backlit              1.0                [0, 1]; TT weight and R's back-lit lerp
    area                 0.0                [0, 1]; added to every beta (area lights)
    components           R, TT, TRT, MS     any subset; disabled lobes are not computed
    separable_r          True               UE's bUseSeparableR (R width ~ cos(phi/2))
    legacy_absorption    True               TT absorption pow(C, ...) (UE default)
    corrected_absorption False              non-legacy only: use 2 sqrt(1-(ha)^2)/cos(theta_d)
                                            instead of UE's 2 abs(1-(ha)^2/cos(theta_d))
    fast_asin            False              UE's asinFast for theta_d (abs. error 9e-3 rad)
    ==================== ================== ==========================================

    Vectors are world-space: L towards the light, V towards the viewer, T
    the fiber tangent, each (N, 3) or (3,) (normalized internally). A pair
    with a zero-length or non-finite vector, or a non-finite per-pair input,
    evaluates to 0. The result is UE's S (the value multiplied by the light
    color), clamped at 0 as UE does; it has no separate cosine.

    float32 inputs are evaluated by the vector kernel (AVX-512, AVX2+FMA or
    the portable fallback, chosen at run time; ``HAIRSHADE_SIMD=avx2`` or
    ``portable`` lowers it), unless ``fast_asin`` is set; float64 by the
    scalar kernel. The two agree to ~2e-5 relative where the lobes are not
    steeper than float32 inputs can resolve.
    """

    def __init__(
        self,
        base_color: Sequence[float] | float = (0.3, 0.15, 0.08),
        specular: float = 0.5,
        roughness: float = 0.5,
        scatter: float = 0.0,
        shift: float = 0.035,
        backlit: float = 1.0,
        area: float = 0.0,
        components: str | Iterable[str] = ("R", "TT", "TRT", "MS"),
        separable_r: bool = True,
        legacy_absorption: bool = True,
        corrected_absorption: bool = False,
        fast_asin: bool = False,
    ) -> None:
        comps = _models.components(components, _models.COMPONENTS)
        absorption = "legacy" if legacy_absorption else ("chiang_corrected" if corrected_absorption else "chiang")
        self._params: dict[str, Any] = dict(
            base_color=_models.rgb(base_color, "base_color"),
            specular=_models.scalar(specular, "specular"),
            roughness=_models.scalar(roughness, "roughness"),
            scatter=_models.scalar(scatter, "scatter"),
            shift=_models.scalar(shift, "shift"),
            backlit=_models.scalar(backlit, "backlit"),
            area=_models.scalar(area, "area"),
            components=tuple(dict.fromkeys(comps)),
            separable_r=_models.flag(separable_r, "separable_r"),
            legacy_absorption=_models.flag(legacy_absorption, "legacy_absorption"),
            corrected_absorption=_models.flag(corrected_absorption, "corrected_absorption"),
            fast_asin=_models.flag(fast_asin, "fast_asin"),
        )
        p = self._params
        self._native = _native.KarisHair(
            p["base_color"], p["specular"], p["roughness"], p["scatter"], p["shift"], p["backlit"], p["area"],
            list(p["components"]), p["separable_r"], absorption, p["fast_asin"],
        )

    @property
    def params(self) -> dict[str, Any]:
        return dict(self._params)

    def __repr__(self) -> str:
        return "KarisHair(" + ", ".join(f"{k}={v!r}" for k, v in self._params.items()) + ")"

    def _run(self, lobes: bool, L: npt.ArrayLike, V: npt.ArrayLike, T: npt.ArrayLike, shadow: npt.ArrayLike,
             global_scattering: npt.ArrayLike, local_scattering: npt.ArrayLike,
             opaque_visibility: npt.ArrayLike) -> tuple[np.ndarray, int, bool]:
        (l, v, t), dtype, n, single = _models.triples(L, V, T)
        extras = [
            _models.per_pair(shadow, "shadow", n, dtype, False, (0.0, 1.0)),
            _models.per_pair(global_scattering, "global_scattering", n, dtype, True),
            _models.per_pair(local_scattering, "local_scattering", n, dtype, True),
            _models.per_pair(opaque_visibility, "opaque_visibility", n, dtype, False),
        ]
        single = single and all(s for _, s in extras)
        out = self._native.eval((l, v, t), *(a for a, _ in extras), lobes=lobes)
        return out, n, single

    def eval(self, L: npt.ArrayLike, V: npt.ArrayLike, T: npt.ArrayLike, shadow: npt.ArrayLike = 1.0,
             global_scattering: npt.ArrayLike = 1.0, local_scattering: npt.ArrayLike = 0.0,
             opaque_visibility: npt.ArrayLike = 1.0) -> np.ndarray:
        """UE's ``HairShading`` S for light L, view V, tangent T -> (N, 3).

        ``shadow`` (scalar or (N,)) enters only the Kajiya-Kay tint;
        ``global_scattering`` and ``local_scattering`` (scalar, RGB or (N, 3))
        and ``opaque_visibility`` (scalar or (N,)) are UE's
        FHairTransmittanceData of the MS block."""
        out, n, single = self._run(False, L, V, T, shadow, global_scattering, local_scattering, opaque_visibility)
        out = out.reshape(n, 3)
        return out[0] if single else out

    def eval_lobes(self, L: npt.ArrayLike, V: npt.ArrayLike, T: npt.ArrayLike, shadow: npt.ArrayLike = 1.0,
                   global_scattering: npt.ArrayLike = 1.0, local_scattering: npt.ArrayLike = 0.0,
                   opaque_visibility: npt.ArrayLike = 1.0) -> dict[str, np.ndarray]:
        """{"R", "TT", "TRT", "MS"} -> (N, 3) each; disabled lobes are 0.
        MS is everything the multiple-scattering block adds, so the four
        sum to ``eval`` wherever that sum is >= 0 (UE clamps it at 0)."""
        out, n, single = self._run(True, L, V, T, shadow, global_scattering, local_scattering, opaque_visibility)
        out = out.reshape(n, 4, 3)
        lobes = {name: out[:, k] for k, name in enumerate(_models.COMPONENTS)}
        return {k: v[0] for k, v in lobes.items()} if single else lobes

    def eval_env(self, V: npt.ArrayLike, T: npt.ArrayLike, sh: npt.ArrayLike) -> np.ndarray:
        """Environment lighting as in Karis 2016: the SH radiance sampled in
        the fake-normal direction n = normalize(V - T (T.V)) and used as a
        directional light from n, times pi, with R multiplied by
        saturate(1 + V.L), TT removed and 0.2 added to every beta.

        ``sh``: (3,) constant radiance, or (4, 3) / (9, 3) real SH
        coefficients (bands 0-1 / 0-2, order Y00, Y1-1, Y10, Y11, Y2-2, ...).
        Negative SH radiance (ringing) is clamped to 0. In float32 (V and T
        float32) the coefficients must be at most 1e30 in magnitude, so
        that the radiance stays finite (ValueError naming ``sh``; with 3e38
        it was inf).
        -> (N, 3); 0 where V is along T."""
        c = sh_coefficients(sh)
        (v, t), dtype, n, single = _env_pairs(V, T)
        if dtype == np.float32 and np.abs(c).max() > F32_SH_BOUND:
            raise ValueError(f"sh: in float32 the coefficients must be at most {F32_SH_BOUND:g} in magnitude, got "
                             f"{float(np.abs(c).max())!r} (pass float64 V and T to evaluate in float64)")
        out = self._native.eval_env(v, t, np.ascontiguousarray(c, dtype=dtype).reshape(-1)).reshape(n, 3)
        return out[0] if single else out

    def dual_terms(self, back_density: float = 1.0) -> dict[str, np.ndarray]:
        """The dual-scattering terms (Zinke et al. 2008) that
        ``multiple_scattering="dual"`` renders with, integrated from R + TT
        + TRT (the model's own multiple-scattering term is what dual
        scattering replaces) at 65 incidences ``sin_theta`` from -1 to 1:
        the same keys as ``ChiangHair.dual_terms``, each (65, 3). Baked
        once per material and density (float32 evaluation)."""
        return dict(self._native.dual_terms(float(back_density)))


#: The largest SH coefficient `eval_env` takes in float32: its radiance
#: over the largest coefficient measured at most 0.54 (200k random pairs,
#: roughness 0 to 1, constant and single-band SH), so results stay far
#: inside float32 (3.4e38).
F32_SH_BOUND = 1e30


def _env_pairs(V: npt.ArrayLike, T: npt.ArrayLike) -> tuple[tuple[np.ndarray, np.ndarray], type, int, bool]:
    from . import _arrays

    a, b = _arrays.directions(V, "V"), _arrays.directions(T, "T")
    n = _arrays.pair_count(a, b)
    dtype = _arrays.common_dtype([a, b])
    return (_arrays.flat(a, dtype), _arrays.flat(b, dtype)), dtype, n, a.ndim == 1 and b.ndim == 1
