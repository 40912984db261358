"""Other renderers' hair parameters as a :class:`~hairshade.ChiangHair`:
Blender's Principled Hair BSDF (Chiang model, as Cycles evaluates it) and
pbrt-v4's ``hair`` material. :meth:`ChiangHair.from_blender` and
:meth:`ChiangHair.from_pbrt` call these.

Blender (Cycles ``svm/closure.h``, ``closure/bsdf_principled_hair_chiang.h``,
``closure/bsdf_util.h``; node defaults from
``node_shader_bsdf_hair_principled.cc``):

- three parametrizations of σa:

  - ``"absorption"``: σa = Absorption Coefficient;
  - ``"melanin"``: m = Melanin × f_c, f_c = 1 + 2 (random − 0.5) Random Color;
    m' = −ln(max(1 − m, 1e-4)); eumelanin m' (1 − Melanin Redness),
    pheomelanin m' Melanin Redness; σa = eu (0.506, 0.841, 1.653)
    + pheo (0.343, 0.733, 1.924) + σ(Tint);
  - ``"color"`` (Blender's "Direct coloring", its default): σa = σ(Color);

  with σ(c) = (ln max(c, 0) / S(β_n))², S(x) = 5.969 − 0.215 x + 2.532 x²
  − 10.73 x³ + 5.574 x⁴ + 0.245 x⁵ (Chiang et al. 2016, eq. 9), β_n the
  Radial Roughness after the random factor;
- Roughness and Radial Roughness are β_m and β_n, both times
  f_r = 1 + 2 (random − 0.5) Random Roughness, then clamped to
  [0.001, 1]; Coat c gives the R lobe the roughness (1 − c) β_m
  (ChiangHair's ``coat``); IOR is η; Offset is the scale tilt, in
  degrees here (Blender's socket holds radians), with ChiangHair's sign
  (``docs/tilt.md``: both lean R towards the root);
- Random Color and Random Roughness vary per strand with Cycles' per-curve
  random number; the renderer has one material per scene, so they need
  ``random`` (that strand's number in [0, 1]) and give that strand's
  material. Carrying them per strand would take a material index per
  strand in the renderer's strand arrays and a table of materials in its
  shading (today's shading precomputes one model's constants per frame).

pbrt-v4 (``src/pbrt/materials.cpp``, ``HairMaterial::Create``;
``src/pbrt/bxdfs.cpp``, ``HairBxDF``):

- σa from ``sigma_a``, else ``reflectance`` (clamped to [0, 1]) through
  σ(c) with β_n, else ``eumelanin``/``pheomelanin`` with coefficients
  (0.419, 0.697, 1.37) and (0.187, 0.4, 1.05) (Mitsuba's too), else
  eumelanin 1.3 and no pheomelanin;
- ``beta_m``, ``beta_n`` (default 0.3, clamped to [0.01, 1]), ``eta``
  (1.55), ``alpha`` (2 degrees);
- the tilt: pbrt's ``HairBxDF`` tilts as Mitsuba's ``hair`` does, the
  other way from ChiangHair on the same tangent (``bxdfs.cpp``: R uses
  sin θo cos 2α − cos θo sin 2α with x = dp/du), so ``alpha`` a gives
  ``scale_tilt`` −a: the material pbrt renders on the same curve.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

#: Cycles' σa of unit eumelanin and pheomelanin concentration.
CYCLES_EUMELANIN = (0.506, 0.841, 1.653)
CYCLES_PHEOMELANIN = (0.343, 0.733, 1.924)
#: pbrt-v4's (and Mitsuba's).
PBRT_EUMELANIN = (0.419, 0.697, 1.37)
PBRT_PHEOMELANIN = (0.187, 0.4, 1.05)
#: Blender's node defaults.
BLENDER_DEFAULTS: dict[str, Any] = dict(
    parametrization="color", color=(0.017513, 0.005763, 0.002059), melanin=0.8, melanin_redness=1.0,
    tint=(1.0, 1.0, 1.0), absorption_coefficient=(0.245531, 0.52, 1.365), roughness=0.3, radial_roughness=0.3,
    coat=0.0, ior=1.55, offset=2.0, random_color=0.0, random_roughness=0.0, random=None)
#: Smallest colour channel turned into absorption: Cycles takes ln(0) = -inf
#: (infinite absorption, a black fiber); σa must be finite here, and
#: ln(1e-30) gives σa above 100 per radius, black to float precision.
MIN_COLOR = 1e-30


def sigma_from_reflectance(color: Sequence[float], beta_n: float) -> np.ndarray:
    """Chiang et al. 2016, eq. 9: the σa whose multiply scattered colour is
    about ``color``, for azimuthal roughness ``beta_n``."""
    c = np.maximum(np.asarray(color, np.float64), MIN_COLOR)
    b = float(beta_n)
    s = 5.969 - 0.215 * b + 2.532 * b**2 - 10.73 * b**3 + 5.574 * b**4 + 0.245 * b**5
    return (np.log(c) / s) ** 2


def _number(v: Any, name: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not math.isfinite(v) \
            or not lo <= v <= hi:
        raise ValueError(f"{name}: expected a finite number in [{lo:g}, {hi:g}], got {v!r:.80}")
    return float(v)


def _rgb(v: Any, name: str, lo: float = 0.0) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64) if not isinstance(v, str) else np.array([np.nan])
    if a.ndim == 0:
        a = np.repeat(a, 3)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.any(a < lo):
        raise ValueError(f"{name}: expected 3 finite numbers >= {lo:g} (RGB), got {v!r:.80}")
    return a


def blender(**kw: Any) -> dict[str, Any]:
    """ChiangHair keyword arguments of Blender's Principled Hair (Chiang)
    inputs, as :meth:`ChiangHair.from_blender` documents them."""
    unknown = set(kw) - set(BLENDER_DEFAULTS)
    if unknown:
        raise TypeError(f"{sorted(unknown)[0]}: not an input of Blender's Principled Hair BSDF "
                        f"(inputs: {', '.join(BLENDER_DEFAULTS)})")
    p = dict(BLENDER_DEFAULTS, **kw)
    mode = p["parametrization"]
    if not isinstance(mode, str) or mode.lower() not in ("absorption", "melanin", "color"):
        raise ValueError(f"parametrization: expected 'absorption', 'melanin' or 'color' (Blender's ABSORPTION, "
                         f"MELANIN, COLOR), got {mode!r:.80}")
    mode = mode.lower()
    random_color = _number(p["random_color"], "random_color", 0, 1)
    random_roughness = _number(p["random_roughness"], "random_roughness", 0, 1)
    if p["random"] is None:
        if random_color or random_roughness:
            raise ValueError("random_color and random_roughness vary per strand: pass random= (the strand's random "
                             "number in [0, 1]) to get one strand's material")
        rnd = 0.5  # factors of 1
    else:
        rnd = _number(p["random"], "random", 0, 1)
    f_roughness = 1 + 2 * (rnd - 0.5) * random_roughness
    beta_m = _number(p["roughness"], "roughness", 0, 1) * f_roughness
    beta_n = _number(p["radial_roughness"], "radial_roughness", 0, 1) * f_roughness
    if mode == "absorption":
        sigma = _rgb(p["absorption_coefficient"], "absorption_coefficient")
    elif mode == "melanin":
        m = _number(p["melanin"], "melanin", 0, 1) * (1 + 2 * (rnd - 0.5) * random_color)
        m = -math.log(max(1 - m, 1e-4))
        red = _number(p["melanin_redness"], "melanin_redness", 0, 1)
        sigma = m * (1 - red) * np.array(CYCLES_EUMELANIN) + m * red * np.array(CYCLES_PHEOMELANIN)
        sigma = sigma + sigma_from_reflectance(_rgb(p["tint"], "tint"), beta_n)
    else:
        sigma = sigma_from_reflectance(_rgb(p["color"], "color"), beta_n)
    return dict(
        sigma_a=[float(x) for x in sigma],
        longitudinal_roughness=float(np.clip(beta_m, 1e-3, 1)),
        azimuthal_roughness=float(np.clip(beta_n, 1e-3, 1)),
        coat=_number(p["coat"], "coat", 0, 1),
        eta=_number(p["ior"], "ior", 1e-3, 1e3),
        scale_tilt=_number(p["offset"], "offset", -90, 90),
    )


def pbrt(sigma_a: Sequence[float] | None = None, reflectance: Sequence[float] | None = None,
         eumelanin: float | None = None, pheomelanin: float | None = None, eta: float = 1.55,
         beta_m: float = 0.3, beta_n: float = 0.3, alpha: float = 2.0, color: Sequence[float] | None = None
         ) -> dict[str, Any]:
    """ChiangHair keyword arguments of pbrt-v4's ``hair`` material, as
    :meth:`ChiangHair.from_pbrt` documents them."""
    if color is not None:
        if reflectance is not None:
            raise ValueError("reflectance and color are the same pbrt parameter: give one")
        reflectance = color
    bm = float(np.clip(_number(beta_m, "beta_m"), 0.01, 1))
    bn = float(np.clip(_number(beta_n, "beta_n"), 0.01, 1))
    if sigma_a is not None:
        sigma = _rgb(sigma_a, "sigma_a")
    elif reflectance is not None:
        sigma = sigma_from_reflectance(np.clip(_rgb(reflectance, "reflectance", -math.inf), 0, 1), bn)
    elif eumelanin is not None or pheomelanin is not None:
        eu = max(_number(eumelanin or 0.0, "eumelanin"), 0.0)
        ph = max(_number(pheomelanin or 0.0, "pheomelanin"), 0.0)
        sigma = eu * np.array(PBRT_EUMELANIN) + ph * np.array(PBRT_PHEOMELANIN)
    else:
        sigma = 1.3 * np.array(PBRT_EUMELANIN)
    return dict(
        sigma_a=[float(x) for x in sigma],
        longitudinal_roughness=bm,
        azimuthal_roughness=bn,
        eta=_number(eta, "eta"),
        scale_tilt=-_number(alpha, "alpha", -90, 90),
    )


#: Mitsuba's named media that its hair BSDF's IORs default to.
MITSUBA_IORS = {"amber": 1.55, "air": 1.000277, "vacuum": 1.0, "water": 1.3330}


def mitsuba(d: dict[str, Any]) -> dict[str, Any]:
    """ChiangHair keyword arguments of a Mitsuba 3 ``hair`` BSDF dictionary
    (as ``mi.load_dict`` takes it): ``type`` "hair"; ``sigma_a`` a number,
    3 numbers or ``{"type": "rgb", "value": ...}``; ``eumelanin``,
    ``pheomelanin``; ``scale`` (multiplies sigma_a); the roughnesses;
    ``int_ior`` and ``ext_ior`` as numbers or Mitsuba's names amber, air,
    vacuum, water; ``scale_tilt`` in Mitsuba's convention, so ChiangHair's
    is its negative (``docs/tilt.md``)."""
    if not isinstance(d, dict):
        raise TypeError(f"expected a Mitsuba BSDF dictionary, got {d!r:.80}")
    allowed = {"type", "sigma_a", "eumelanin", "pheomelanin", "scale", "longitudinal_roughness",
               "azimuthal_roughness", "scale_tilt", "int_ior", "ext_ior", "id"}
    unknown = set(d) - allowed
    if unknown:
        raise ValueError(f"{sorted(unknown)[0]}: not a parameter of Mitsuba's hair BSDF (parameters: "
                         f"{', '.join(sorted(allowed - {'id'}))})")
    if d.get("type", "hair") != "hair":
        raise ValueError(f"type: expected 'hair' (Mitsuba's hair BSDF), got {d.get('type')!r:.80}")
    out: dict[str, Any] = {}
    if "sigma_a" in d:
        if "eumelanin" in d or "pheomelanin" in d:
            raise ValueError("sigma_a: give either sigma_a or eumelanin/pheomelanin, not both (as Mitsuba)")
        s = d["sigma_a"]
        if isinstance(s, dict):
            if s.get("type") != "rgb" or set(s) - {"type", "value"}:
                raise ValueError(f"sigma_a: expected a number, 3 numbers or {{'type': 'rgb', 'value': ...}}, "
                                 f"got {s!r:.80}")
            s = s.get("value")
        sa = _rgb(s, "sigma_a") * _number(d.get("scale", 1.0), "scale", 0)
        out["sigma_a"] = [float(x) for x in sa]
    else:
        if "scale" in d and d["scale"] != 1:
            raise ValueError("scale: Mitsuba applies it to sigma_a only; give sigma_a")
        for k in ("eumelanin", "pheomelanin"):
            out[k] = _number(d.get(k, 1.3 if k == "eumelanin" else 0.2), k, 0)
    for k in ("longitudinal_roughness", "azimuthal_roughness"):
        out[k] = _number(d.get(k, 0.3), k, 0, 1)
    out["scale_tilt"] = -_number(d.get("scale_tilt", 2.0), "scale_tilt", -90, 90)

    def ior(k: str, default: str) -> float:
        v = d.get(k, default)
        if isinstance(v, str):
            if v not in MITSUBA_IORS:
                raise ValueError(f"{k}: {v!r:.40} is not one of the media known here ({', '.join(MITSUBA_IORS)}); "
                                 "give a number")
            return MITSUBA_IORS[v]
        return _number(v, k, 1e-3, 1e3)

    out["eta"] = ior("int_ior", "amber") / ior("ext_ior", "air")
    return out
