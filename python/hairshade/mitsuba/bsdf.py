"""Mitsuba's own ``hair`` BSDF on numpy arrays: :func:`hair_dict` (the
scene-dictionary entry for a :class:`~hairshade.ChiangHair`'s parameters)
and :class:`MitsubaHair` (``eval``, ``eval_pdf`` and ``sample`` in
Mitsuba's local frame, which is hairshade's), with the vectorized JIT
variants or the scalar one."""

from __future__ import annotations

from typing import Any

import drjit as dr
import mitsuba as mi
import numpy as np

from ..chiang import ChiangHair
from . import default_variant


def hair_dict(model: ChiangHair) -> dict[str, Any]:
    """Mitsuba scene-dictionary entry of Mitsuba's ``hair`` BSDF with the
    parameters of ``model`` (``ext_ior`` 1 so that eta is int_ior; the tilt
    negated: Mitsuba's ``scale_tilt`` α shifts R as ChiangHair's −α does,
    see ``docs/tilt.md``)."""
    p = model.params
    if p.get("coat", 0.0):
        raise ValueError(f"coat: Mitsuba's hair has no coat (R's own roughness); got coat={p['coat']!r}")
    d: dict[str, Any] = {
        "type": "hair",
        "int_ior": p["eta"],
        "ext_ior": 1.0,
        "longitudinal_roughness": p["longitudinal_roughness"],
        "azimuthal_roughness": p["azimuthal_roughness"],
        "scale_tilt": -p["scale_tilt"],
    }
    if p["sigma_a"] is not None:
        d["sigma_a"] = {"type": "rgb", "value": list(p["sigma_a"])}
    else:
        if p["eumelanin"] is not None:
            d["eumelanin"] = p["eumelanin"]
        if p["pheomelanin"] is not None:
            d["pheomelanin"] = p["pheomelanin"]
    return d


def _unit_rows(a: object, name: str) -> np.ndarray:
    x = np.atleast_2d(np.asarray(a, dtype=np.float64))
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"{name}: expected shape (N, 3) or (3,), got {np.shape(a)}")
    return x / np.linalg.norm(x, axis=1, keepdims=True)


class MitsubaHair:
    """Mitsuba's ``hair`` BSDF for the parameters of a :class:`ChiangHair`,
    evaluated on numpy arrays in Mitsuba's local frame (the same frame as
    hairshade). Results are float64 arrays of Mitsuba's float32 values."""

    def __init__(self, model: ChiangHair, variant: str | None = None) -> None:
        self.variant = variant or default_variant()
        if self.variant not in mi.variants():
            raise ValueError(f"variant: {self.variant!r} is not one of {mi.variants()}")
        self.params = hair_dict(model)
        mi.set_variant(self.variant)
        self._bsdf = mi.load_dict(self.params)

    def _activate(self) -> None:
        mi.set_variant(self.variant)

    @property
    def _vectorized(self) -> bool:
        return not self.variant.startswith("scalar")

    def _pairs(self, wi: object, wo: object) -> tuple[np.ndarray, np.ndarray, int]:
        """Activates the variant; unit (N,3) arrays of both directions, N."""
        self._activate()
        a, b = np.broadcast_arrays(_unit_rows(wi, "wi"), _unit_rows(wo, "wo"))
        return a, b, a.shape[0]

    @staticmethod
    def _wide_si(a: np.ndarray) -> Any:
        si = dr.zeros(mi.SurfaceInteraction3f, a.shape[0])
        si.wi = mi.Vector3f(a[:, 0], a[:, 1], a[:, 2])
        return si

    def eval_pdf(self, wi: object, wo: object) -> tuple[np.ndarray, np.ndarray]:
        """(value (N,3), pdf (N,)) from Mitsuba's ``eval_pdf``."""
        a, b, n = self._pairs(wi, wo)
        ctx = mi.BSDFContext()
        if self._vectorized:
            v, p = self._bsdf.eval_pdf(ctx, self._wide_si(a), mi.Vector3f(b[:, 0], b[:, 1], b[:, 2]))
            return np.array(v, dtype=np.float64).T.reshape(n, 3), np.array(p, dtype=np.float64).reshape(n)
        si = mi.SurfaceInteraction3f()
        val = np.empty((n, 3))
        pdf = np.empty(n)
        for i in range(n):
            si.wi = mi.Vector3f(a[i])
            v, p = self._bsdf.eval_pdf(ctx, si, mi.Vector3f(b[i]))
            val[i] = np.array(v)
            pdf[i] = float(p)
        return val, pdf

    def eval(self, wi: object, wo: object) -> np.ndarray:
        """Mitsuba's ``eval`` (N,3)."""
        a, b, n = self._pairs(wi, wo)
        if self._vectorized:
            v = self._bsdf.eval(mi.BSDFContext(), self._wide_si(a), mi.Vector3f(b[:, 0], b[:, 1], b[:, 2]))
            return np.array(v, dtype=np.float64).T.reshape(n, 3)
        return self.eval_pdf(a, b)[0]

    def sample(self, wi: object, u1: object, u2: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mitsuba's ``sample``: (wo (N,3), weight (N,3), pdf (N,))."""
        self._activate()
        u1 = np.asarray(u1, dtype=np.float64).reshape(-1)
        u2 = np.asarray(u2, dtype=np.float64).reshape(-1, 2)
        n = u1.shape[0]
        a = np.broadcast_to(_unit_rows(wi, "wi"), (n, 3))
        ctx = mi.BSDFContext()
        if self._vectorized:
            bs, w = self._bsdf.sample(ctx, self._wide_si(a), mi.Float(u1), mi.Point2f(u2[:, 0], u2[:, 1]))
            wo = np.array(bs.wo, dtype=np.float64).T.reshape(n, 3)
            return wo, np.array(w, dtype=np.float64).T.reshape(n, 3), np.array(bs.pdf, dtype=np.float64).reshape(n)
        si = mi.SurfaceInteraction3f()
        wo = np.empty((n, 3))
        weight = np.empty((n, 3))
        pdf = np.empty(n)
        for i in range(n):
            si.wi = mi.Vector3f(a[i])
            bs, w = self._bsdf.sample(ctx, si, float(u1[i]), mi.Point2f(u2[i]))
            wo[i] = np.array(bs.wo)
            weight[i] = np.array(w)
            pdf[i] = float(bs.pdf)
        return wo, weight, pdf
