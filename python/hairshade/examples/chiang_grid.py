"""Evaluate the Chiang hair BSDF over an angle grid with numpy.

Prints the far-field value (red channel) over theta_o x delta-phi for light
arriving at theta_i = 30 degrees: everything concentrates near the specular
cone theta_o ~ -theta_i, with forward scattering (TT) peaking at
delta-phi = 180 degrees.

    python examples/chiang_grid.py
"""

import numpy as np

import hairshade as hs


def direction(theta, phi):
    """Mitsuba's hair frame: y is the fiber tangent, sin(theta) = y."""
    return np.stack([np.cos(theta) * np.cos(phi), np.sin(theta), np.cos(theta) * np.sin(phi)], axis=-1)


def main():
    hair = hs.ChiangHair(eumelanin=0.8, pheomelanin=0.3, longitudinal_roughness=0.25, azimuthal_roughness=0.3)
    theta_o = np.deg2rad(np.arange(-80, 81, 20))
    dphi = np.deg2rad(np.arange(0, 181, 30))
    T, P = np.meshgrid(theta_o, dphi, indexing="ij")
    wi = direction(np.deg2rad(30.0), 0.0)
    wo = direction(T, P).reshape(-1, 3)
    f = hair.eval_far(wi, wo)[:, 0].reshape(T.shape)
    print("far-field f (red), rows theta_o (deg), columns delta-phi (deg)")
    print("        " + "".join(f"{d:9.0f}" for d in np.rad2deg(dphi)))
    for t, row in zip(np.rad2deg(theta_o), f):
        print(f"{t:7.0f} " + "".join(f"{v:9.4f}" for v in row))


if __name__ == "__main__":
    main()
