"""UE4 `HairShadingRef()`: d'Eon 2011 M_p with N_p integrated over h."""

from __future__ import annotations

from typing import Any, Iterable, Sequence

import numpy as np
import numpy.typing as npt

from . import _models
from . import _native


class DEonHair(_models.Picklable):
    """The far-field reference that KarisHair approximates: UE4's
    ``HairShadingRef()`` with the same artist parameters (d'Eon et al. 2011
    longitudinal term, azimuthal term integrated over the fiber offset h with
    a Gaussian detector).

    ================ ================== ======================================
    base_color       (0.3, 0.15, 0.08)  C, RGB in [0, 1]; mu_a = -ln(C)/4
    roughness        0.5                [0, 1], clamped to >= 1/255
    shift            0.035              [-0.25, 0.25]
    eta              1.55               (1, 3]
    h_samples        None               None: adaptive quadrature converged to
                                        1e-8 relative (f64); n in [1, 2^20]:
                                        UE's stratified n-sample estimate
    h_offset         0.5                [0, 1): the stratified samples' offset
    components       R, TT, TRT         any subset
    ================ ================== ======================================

    Same vectors as KarisHair (world-space L, V, T). The result has no MS
    term and no separate cosine."""

    def __init__(
        self,
        base_color: Sequence[float] | float = (0.3, 0.15, 0.08),
        roughness: float = 0.5,
        shift: float = 0.035,
        eta: float = 1.55,
        h_samples: int | None = None,
        components: str | Iterable[str] = ("R", "TT", "TRT"),
        h_offset: float = 0.5,
    ) -> None:
        comps = _models.components(components, ("R", "TT", "TRT"))
        if h_samples is not None:
            if isinstance(h_samples, bool) or not isinstance(h_samples, (int, np.integer)) \
                    or not 1 <= h_samples <= 1 << 20:
                raise ValueError(f"h_samples: must be None or an integer in [1, 1048576], got {h_samples!r:.40}")
        self._params: dict[str, Any] = dict(
            base_color=_models.rgb(base_color, "base_color"),
            roughness=_models.scalar(roughness, "roughness"),
            shift=_models.scalar(shift, "shift"),
            eta=_models.scalar(eta, "eta"),
            h_samples=None if h_samples is None else int(h_samples),
            components=tuple(dict.fromkeys(comps)),
            h_offset=_models.scalar(h_offset, "h_offset"),
        )
        p = self._params
        self._native = _native.DEonHair(
            p["base_color"], p["roughness"], p["shift"], p["eta"], p["h_samples"], p["h_offset"], list(p["components"])
        )

    @property
    def params(self) -> dict[str, Any]:
        return dict(self._params)

    def __repr__(self) -> str:
        return "DEonHair(" + ", ".join(f"{k}={v!r}" for k, v in self._params.items()) + ")"

    def eval(self, L: npt.ArrayLike, V: npt.ArrayLike, T: npt.ArrayLike) -> np.ndarray:
        """Sum of the enabled lobes: (N, 3)."""
        (l, v, t), dtype, n, single = _models.triples(L, V, T)
        out = self._native.eval((l, v, t)).reshape(n, 3)
        return out[0] if single else out

    def eval_lobes(self, L: npt.ArrayLike, V: npt.ArrayLike, T: npt.ArrayLike) -> dict[str, np.ndarray]:
        """{"R", "TT", "TRT"} -> (N, 3) each (disabled lobes are 0)."""
        (l, v, t), dtype, n, single = _models.triples(L, V, T)
        out = self._native.eval((l, v, t), lobes=True).reshape(n, 3, 3)
        lobes = {name: out[:, k] for k, name in enumerate(("R", "TT", "TRT"))}
        return {k: v[0] for k, v in lobes.items()} if single else lobes
