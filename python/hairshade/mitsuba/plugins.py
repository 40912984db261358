"""hairshade's own models as Mitsuba BSDFs: :func:`register_plugins`
registers ``hairshade_karis`` (KarisHair) and ``hairshade_deon`` (DEonHair),
so that Mitsuba can render with exactly the shading the rasterizer uses."""

from __future__ import annotations

import json
from typing import Any

import mitsuba as mi
import numpy as np

_REGISTERED = False


def register_plugins() -> None:
    """Registers ``hairshade_karis`` and ``hairshade_deon``: KarisHair and
    DEonHair as Mitsuba BSDFs, so Mitsuba can render the exact shading the
    rasterizer uses. They take a ``params`` string (JSON of the model's
    keyword arguments), read the fiber tangent as local y (as Mitsuba's
    ``hair`` does: use them on ``bsplinecurve``), evaluate
    ``S(L = wo, V = wi, T)`` through hairshade on numpy arrays, and sample
    directions uniformly on the sphere. They need a JIT variant
    (``llvm_ad_rgb``) rendered in wavefront mode;
    :func:`hairshade.mitsuba.render` sets that up. Both models are
    far-field: the value does not depend on where the ray hits the fiber."""
    global _REGISTERED
    if _REGISTERED:
        return

    from ..deon import DEonHair
    from ..karis import KarisHair

    def make(model_cls: type) -> Any:
        class HairshadeBSDF(mi.BSDF):
            def __init__(self, props: Any) -> None:
                mi.BSDF.__init__(self, props)
                kwargs = json.loads(props.get("params", "{}"))
                self.model = model_cls(**kwargs)
                flags = (mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.GlossyTransmission
                         | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide)
                self.m_components = [flags]
                self.m_flags = flags

            def _eval(self, si: Any, wo: Any) -> Any:
                v = np.array(si.wi, dtype=np.float64).T.reshape(-1, 3)
                l = np.array(wo, dtype=np.float64).T.reshape(-1, 3)
                n = max(len(v), len(l))
                f = self.model.eval(np.broadcast_to(l, (n, 3)), np.broadcast_to(v, (n, 3)), np.array([0.0, 1.0, 0.0]))
                return mi.Color3f(f[:, 0], f[:, 1], f[:, 2])

            def sample(self, ctx: Any, si: Any, sample1: Any, sample2: Any, active: Any = True) -> Any:
                bs = mi.BSDFSample3f()
                bs.wo = mi.warp.square_to_uniform_sphere(sample2)
                bs.pdf = mi.warp.square_to_uniform_sphere_pdf(bs.wo)
                bs.eta = 1.0
                bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
                bs.sampled_component = mi.UInt32(0)
                return bs, self._eval(si, bs.wo) / bs.pdf

            def eval(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
                return self._eval(si, wo)

            def pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
                return mi.warp.square_to_uniform_sphere_pdf(wo)

            def eval_pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
                return self._eval(si, wo), mi.warp.square_to_uniform_sphere_pdf(wo)

            def to_string(self) -> str:
                return f"{model_cls.__name__}BSDF[{self.model!r}]"

        return HairshadeBSDF

    for name, cls in (("hairshade_karis", KarisHair), ("hairshade_deon", DEonHair)):
        plugin = make(cls)
        mi.register_bsdf(name, lambda props, plugin=plugin: plugin(props))
    _REGISTERED = True
