"""Multilayer and single-channel EXRs: Blender's own render, saved by
Blender both as a multilayer file and as a plain RGB file
(tests/data/blender, scripts/blender_fixtures.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import hairshade as hs
from hairshade.cli import main

BLENDER = Path(__file__).parent / "data" / "blender"
MULTI = BLENDER / "render_multilayer.exr"
PLAIN = BLENDER / "render_rgb.exr"


def test_01_blender_multilayer_lists_its_layers():
    assert hs.exr_layers(MULTI) == {
        "ViewLayer.Combined": ("A", "B", "G", "R"),
        "ViewLayer.Depth": ("Z",),
        "ViewLayer.Normal": ("X", "Y", "Z"),
        "ViewLayer.Noisy Image": ("A", "B", "G", "R"),
    }
    assert hs.exr_layers(PLAIN) == {"": ("B", "G", "R")}


def test_02_combined_is_the_plain_files_image_bit_for_bit():
    """The same render result, saved two ways by Blender: the multilayer
    file's Combined layer (chosen by name, and by default as the only RGB
    layer named Combined) equals the plain RGB file."""
    plain = hs.read_exr(PLAIN)
    assert plain.shape == (18, 32, 3) and plain.max() > 0
    np.testing.assert_array_equal(hs.read_exr(MULTI, layer="ViewLayer.Combined"), plain)
    np.testing.assert_array_equal(hs.read_exr(MULTI), plain)


def test_03_a_single_channel_layer_is_grey():
    z = hs.read_exr(MULTI, layer="ViewLayer.Depth")
    assert z.shape == (18, 32, 3)
    np.testing.assert_array_equal(z[..., 0], z[..., 1])
    np.testing.assert_array_equal(z[..., 0], z[..., 2])
    assert np.all(z > 0)  # distances (Blender writes 1e10 where no surface was hit)


def test_04_errors_list_what_the_file_has():
    listing = ("'ViewLayer.Combined' (A, B, G, R; 32x18), 'ViewLayer.Depth' (Z; 32x18), "
               "'ViewLayer.Normal' (X, Y, Z; 32x18), 'ViewLayer.Noisy Image' (A, B, G, R; 32x18)")
    with pytest.raises(ValueError) as e:
        hs.read_exr(MULTI, layer="Combined")
    assert str(e.value) == f"{MULTI}: has no layer 'Combined'; its layers: {listing}"
    with pytest.raises(ValueError, match="layer 'ViewLayer.Normal' .X, Y, Z; 32x18. has no R, G and B channels"):
        hs.read_exr(MULTI, layer="ViewLayer.Normal")
    with pytest.raises(TypeError, match="layer: expected a layer name"):
        hs.read_exr(MULTI, layer=3)


def test_05_compare_takes_a_layer(capsys):
    assert main(["compare", str(MULTI), str(PLAIN), "--no-flip", "--layer", "ViewLayer.Combined"]) == 0
    assert capsys.readouterr().out.startswith("relMSE 0.0000e+00")
    assert main(["compare", str(MULTI), str(PLAIN), "--no-flip", "--layer", "nope"]) == 2
    assert "has no layer 'nope'" in capsys.readouterr().err
