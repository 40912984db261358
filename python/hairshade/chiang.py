"""Chiang et al. 2016 hair BSDF (near and far field), as Mitsuba 3's `hair`."""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
import numpy.typing as npt

from . import _arrays, _models
from . import _native

_I0_MODES = ("exact", "mitsuba")


def azimuthal_scale(beta_n: float) -> float:
    """Chiang eq. 8: logistic scale s for azimuthal roughness beta_n
    (values below 1e-3 use 1e-3)."""
    return float(_native.chiang_azimuthal_scale(float(beta_n)))


def longitudinal_variance(beta_m: float) -> float:
    """Chiang eq. 7: R-lobe longitudinal variance v for roughness beta_m
    (values below 1e-3 use 1e-3)."""
    return float(_native.chiang_longitudinal_variance(float(beta_m)))


# Mitsuba's default exterior medium for `hair` ("air").
EXT_IOR_AIR = 1.000277


def relative_ior(eta: float | None, int_ior: float | None, ext_ior: float | None) -> float:
    """The relative IOR from ChiangHair's ``eta`` or Mitsuba's ``int_ior`` /
    ``ext_ior`` (numbers; Mitsuba's defaults 1.55 and 1.000277 fill in the
    one not given). None of them given: eta = 1.55."""
    if eta is not None and (int_ior is not None or ext_ior is not None):
        given = ", ".join(n for n, v in (("int_ior", int_ior), ("ext_ior", ext_ior)) if v is not None)
        raise ValueError(f"eta and {given}: give either eta (relative IOR) or Mitsuba's int_ior/ext_ior, not both")
    if int_ior is None and ext_ior is None:
        return 1.55 if eta is None else float(eta)
    iors = []
    for name, v, default in (("int_ior", int_ior, 1.55), ("ext_ior", ext_ior, EXT_IOR_AIR)):
        if isinstance(v, str) or isinstance(v, bool):
            raise ValueError(f"{name}: expected a number (named media are not supported), got {v!r}")
        x = default if v is None else float(v)
        if not math.isfinite(x) or x <= 0:
            raise ValueError(f"{name}: must be finite and > 0, got {x}")
        iors.append(x)
    return iors[0] / iors[1]


class ChiangHair(_models.Picklable):
    """Chiang et al. 2016 near-field hair BSDF with Mitsuba 3's parameters,
    frame and normalization.

    Parameters (defaults as Mitsuba's `hair`):

    ======================== ========= =============================================
    sigma_a                  None      RGB absorption per unit fiber radius, each
                                       >= 0 (a scalar is used for all channels).
                                       Exclusive with the melanin parameters.
    eumelanin                None      >= 0; None means 1.3 when sigma_a is None
    pheomelanin              None      >= 0; None means 0.2 when sigma_a is None
    longitudinal_roughness   0.3       beta_m in [0, 1]; below 1e-3 uses 1e-3
    azimuthal_roughness      0.3       beta_n in [0, 1]; below 1e-3 uses 1e-3
    scale_tilt               2.0       cuticle angle alpha in degrees, [-90, 90];
                                       > 0: the scales' edges point to the tip
                                       (+y) and R leans towards the root
                                       (physical; Mitsuba's and pbrt's hair
                                       tilt the other way: their -alpha)
    eta                      1.55      relative IOR int_ior / ext_ior; > 0, != 1
    int_ior, ext_ior         None      Mitsuba's names: eta = int_ior / ext_ior
                                       (ext_ior defaults to 1.000277, Mitsuba's
                                       "air"); exclusive with eta
    i0                       "exact"   "exact", or "mitsuba" to reproduce
                                       Mitsuba's truncated Bessel series
    coat                     0.0       Blender's Coat, in [0, 1]: R's roughness
                                       is (1 - coat) beta_m (Cycles); Mitsuba's
                                       hair has none
    ======================== ========= =============================================

    Roughness 0 would turn lobes into Dirac deltas; it is raised to 1e-3
    (lobes about 0.04 degrees wide). Mitsuba returns 0 everywhere at exactly 0.

    Frame: local y is the fiber tangent, z the shading normal; the offset h
    is derived from ``wi`` (``h = -x / |xz|``, the length of wi's x-z part). Directions need not be unit
    length. A pair with a zero-length or non-finite direction evaluates to 0
    (pdf 0, sample weight 0), leaving the other pairs untouched.

    ``eval`` includes the cosine exactly as Mitsuba's ``eval`` does: its
    integral over outgoing directions is the albedo.
    """

    def __init__(
        self,
        sigma_a: float | Sequence[float] | npt.ArrayLike | None = None,
        eumelanin: float | None = None,
        pheomelanin: float | None = None,
        longitudinal_roughness: float = 0.3,
        azimuthal_roughness: float = 0.3,
        scale_tilt: float = 2.0,
        eta: float | None = None,
        i0: str = "exact",
        int_ior: float | None = None,
        ext_ior: float | None = None,
        coat: float = 0.0,
    ) -> None:
        eta = relative_ior(eta, int_ior, ext_ior)  # the model keeps eta only
        if i0 not in _I0_MODES:
            raise ValueError(f"i0: must be one of {_I0_MODES}, got {i0!r}")
        sa = None
        if sigma_a is not None:
            raw = np.asarray(sigma_a) if not isinstance(sigma_a, str) else None
            if raw is None or raw.dtype.kind not in "fiu":
                raise TypeError(f"sigma_a: expected a number or 3 numbers, got {sigma_a!r:.80}")
            arr = raw.astype(np.float64)
            if arr.ndim == 0:
                arr = np.repeat(arr, 3)
            if arr.shape != (3,):
                raise ValueError(f"sigma_a: expected a scalar or 3 values (RGB), got shape {arr.shape}")
            sa = [float(v) for v in arr]

        def opt(x: float | None, name: str) -> float | None:
            return None if x is None else _models.scalar(x, name)

        self._params: dict[str, Any] = dict(
            sigma_a=sa,
            eumelanin=opt(eumelanin, "eumelanin"),
            pheomelanin=opt(pheomelanin, "pheomelanin"),
            longitudinal_roughness=_models.scalar(longitudinal_roughness, "longitudinal_roughness"),
            azimuthal_roughness=_models.scalar(azimuthal_roughness, "azimuthal_roughness"),
            scale_tilt=_models.scalar(scale_tilt, "scale_tilt"),
            eta=_models.scalar(eta, "eta"),
            i0=i0,
            coat=_models.scalar(coat, "coat"),
        )
        self._native = _native.ChiangHair(**self._params)

    # -- other renderers' parameters -----------------------------------------
    @classmethod
    def from_blender(cls, **inputs: Any) -> "ChiangHair":
        """The ChiangHair of Blender's Principled Hair BSDF (Chiang model)
        with these inputs, as Cycles evaluates them (formulas and sources:
        :mod:`hairshade.hair_params`). Keywords, Blender's defaults:
        ``parametrization`` ("color": Direct coloring; "melanin";
        "absorption"), ``color`` (0.017513, 0.005763, 0.002059),
        ``melanin`` 0.8, ``melanin_redness`` 1, ``tint`` (1, 1, 1),
        ``absorption_coefficient`` (0.245531, 0.52, 1.365), ``roughness``
        0.3, ``radial_roughness`` 0.3, ``coat`` 0, ``ior`` 1.55, ``offset``
        2 (degrees), ``random_color`` 0, ``random_roughness`` 0, ``random``
        (one strand's random number in [0, 1], needed when either random
        amount is not 0)."""
        from .hair_params import blender

        return cls(**blender(**inputs))

    @classmethod
    def from_pbrt(cls, **params: Any) -> "ChiangHair":
        """The ChiangHair of pbrt-v4's ``hair`` material with these
        parameters (pbrt's names: ``sigma_a``, ``reflectance`` or ``color``,
        ``eumelanin``, ``pheomelanin``, ``eta``, ``beta_m``, ``beta_n``,
        ``alpha``; pbrt's defaults and clamps; its ``alpha`` tilts the other
        way, so ``scale_tilt`` is -alpha). See :mod:`hairshade.hair_params`."""
        from .hair_params import pbrt

        return cls(**pbrt(**params))

    @classmethod
    def from_mitsuba(cls, bsdf: dict[str, Any]) -> "ChiangHair":
        """The ChiangHair of a Mitsuba 3 ``hair`` BSDF dictionary, as
        ``mi.load_dict`` takes it (``{"type": "rgb", "value": ...}`` values,
        named IORs, Mitsuba's defaults; its ``scale_tilt`` is ChiangHair's
        negative). See :func:`hairshade.hair_params.mitsuba`."""
        from .hair_params import mitsuba

        return cls(**mitsuba(bsdf))

    # -- parameters ---------------------------------------------------------
    @property
    def params(self) -> dict[str, Any]:
        """The parameters as given (a copy)."""
        return dict(self._params)

    @property
    def sigma_a(self) -> np.ndarray:
        """The absorption coefficient in use (RGB), from sigma_a or melanin."""
        return np.array(self._native.sigma_a)

    @property
    def variances(self) -> tuple[float, float, float, float]:
        """Longitudinal variances v_p for R, TT, TRT and the residual."""
        return tuple(self._native.variances)  # type: ignore[return-value]

    @property
    def logistic_scale(self) -> float:
        """Scale s of the trimmed logistic azimuthal distribution."""
        return float(self._native.logistic_scale)

    @property
    def far_field_order(self) -> int:
        """Number of quadrature nodes over h used by ``eval_far``."""
        return int(self._native.far_field_order)

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self._params.items() if v is not None)
        return f"ChiangHair({args})"

    # -- evaluation ----------------------------------------------------------
    def _rgb(self, native_op: Any, wi: npt.ArrayLike, wo: npt.ArrayLike) -> np.ndarray:
        a, b, dtype, n, single = _arrays.prepare_pairs(wi, wo)
        out = native_op(a, b).reshape(n, 3)
        return out[0] if single else out

    def eval(self, wi: npt.ArrayLike, wo: npt.ArrayLike) -> np.ndarray:
        """BSDF value (cosine included, as Mitsuba): (N,3),(N,3) -> (N,3).

        float64 runs the scalar kernel. float32 with ``i0="exact"`` runs the
        vector kernel (AVX-512, AVX2 or portable, chosen at run time): within
        f32 rounding of the f64 result (relative L2 6e-7, at most 1.2e-5
        relative over 2^20 random pairs, as the scalar f32 kernel's 1.0e-5).
        A ``wi`` exactly along the tangent has no azimuth; the vector kernel
        takes phi_i = pi/2 there, the scalar one atan2(0, 0) = 0."""
        return self._rgb(self._native.eval, wi, wo)

    def eval_far(self, wi: npt.ArrayLike, wo: npt.ArrayLike, fast: bool = False) -> np.ndarray:
        """Far-field BSDF: ``eval`` averaged over h in [-1, 1] (the normal
        rotated about the tangent). Depends only on theta_i, theta_o and
        phi_o - phi_i. Converged to 1e-6 relative (quadrature order chosen
        from the azimuthal roughness; see ``far_field_order``).

        ``fast=True`` takes the azimuthal terms N_p (averaged over h) from a
        table built once per model on first use (``far_table_size``) and
        keeps the longitudinal terms M_p analytic: computed in float32
        whatever the input type (the output still follows it), about 1e-4
        relative L2 from the quadrature; the renderer shades with it."""
        a, b, dtype, n, single = _arrays.prepare_pairs(wi, wo)
        out = self._native.eval_far(a, b, fast=bool(fast)).reshape(n, 3)
        return out[0] if single else out

    def eval_far_lobes(self, wi: npt.ArrayLike, wo: npt.ArrayLike, fast: bool = False) -> dict[str, np.ndarray]:
        """``eval_far`` split by path: {"R", "TT", "TRT", "TRRT+"} -> (N, 3)
        each (the last is the residual of all longer paths); they sum to
        ``eval_far``. ``fast``: as ``eval_far``."""
        a, b, dtype, n, single = _arrays.prepare_pairs(wi, wo)
        out = self._native.eval_far_lobes(a, b, fast=bool(fast)).reshape(n, 4, 3)
        lobes = {k: out[:, i] for i, k in enumerate(("R", "TT", "TRT", "TRRT+"))}
        return {k: v[0] for k, v in lobes.items()} if single else lobes

    @property
    def far_table_size(self) -> tuple[int, int, int]:
        """The far-field table of ``eval_far(fast=True)`` and the renderer:
        (cos theta_i nodes, phi nodes, bytes); building it on first use."""
        return tuple(self._native.far_table_size)  # type: ignore[return-value]

    def dual_terms(self, back_density: float = 1.0) -> dict[str, np.ndarray]:
        """The dual-scattering terms of this material (Zinke et al. 2008),
        integrated from its far field (the table of ``eval_far(fast=True)``)
        at 65 incidences ``sin_theta`` from -1 to 1: ``a_f``, ``a_b`` (forward
        and backward attenuation), ``alpha_f``, ``beta_f2``, ``alpha_b``,
        ``beta_b2`` (mean and variance of sin(theta_o) + sin(theta_i) on each
        half), ``A_b``, ``delta_b``, ``sigma_b2`` (local back scattering with
        back density ``back_density``), each (65, 3). Built once per
        material and density."""
        return dict(self._native.dual_terms(float(back_density)))

    def pdf(self, wi: npt.ArrayLike, wo: npt.ArrayLike) -> np.ndarray:
        """Solid-angle density of ``sample``: (N,3),(N,3) -> (N,)."""
        a, b, dtype, n, single = _arrays.prepare_pairs(wi, wo)
        out = self._native.pdf(a, b)
        return out[0] if single else out

    def sample(self, wi: npt.ArrayLike, u1: npt.ArrayLike, u2: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Importance sampling: ``wi`` (N,3) or (3,), ``u1`` (N,), ``u2`` (N,2)
        uniform in [0,1] -> (wo (N,3), weight = eval/pdf (N,3), pdf (N,)).
        A failed sample has pdf 0 and weight 0. Random numbers are clamped to
        [0, 1]; non-finite ones give a failed sample."""
        w = _arrays.directions(wi, "wi")
        a1 = _arrays.uniforms(u1, "u1", None, 1)
        n = a1.shape[0]
        a2 = _arrays.uniforms(u2, "u2", n, 2)
        if w.ndim == 2 and w.shape[0] != n:
            raise ValueError(f"wi: expected shape ({n}, 3) or (3,) to match u1 {a1.shape}, got {w.shape}")
        dtype = _arrays.common_dtype([w, a1, a2])
        wo, weight, pdf = self._native.sample(_arrays.flat(w, dtype), _arrays.flat(a1, dtype), _arrays.flat(a2, dtype))
        return wo.reshape(n, 3), weight.reshape(n, 3), pdf
