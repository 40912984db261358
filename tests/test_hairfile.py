"""Cem Yuksel's `.hair` files (a scene's `hair.file`, by extension) and
`Scene.from_arrays`. The files are written here with `struct` from the
format's specification (cemyuksel.com/research/hairmodels), independently
of the reader."""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest

import hairshade as hs

SEGMENTS, POINTS, THICKNESS, TRANSPARENCY, COLOR = 1, 2, 4, 8, 16


def write_hair(path, strands, thickness=None, default_segments=0, default_thickness=0.01,
               transparency=False, color=False, segments_array=True, header_points=None):
    """A .hair file: 128-byte header, then the arrays its flags announce."""
    n_points = sum(len(s) for s in strands)
    flags = POINTS | (SEGMENTS if segments_array else 0) | (THICKNESS if thickness is not None else 0)
    flags |= (TRANSPARENCY if transparency else 0) | (COLOR if color else 0)
    info = b"written by tests/test_hairfile.py".ljust(88, b"\0")
    head = struct.pack("<4sIIIIff3f88s", b"HAIR", len(strands), header_points or n_points, flags,
                       default_segments, default_thickness, 0.0, 0.2, 0.1, 0.05, info)
    assert len(head) == 128
    body = b""
    if segments_array:
        body += struct.pack(f"<{len(strands)}H", *(len(s) - 1 for s in strands))
    body += b"".join(struct.pack("<3f", *p) for s in strands for p in s)
    if thickness is not None:
        body += struct.pack(f"<{n_points}f", *thickness)
    if transparency:
        body += struct.pack(f"<{n_points}f", *([0.5] * n_points))
    if color:
        body += struct.pack(f"<{3 * n_points}f", *([0.3] * 3 * n_points))
    with open(path, "wb") as f:
        f.write(head + body)


def strands(rng, n=40, lengths=(2, 9)):
    """n strands hanging down from a small patch, 2 to 8 points each."""
    out = []
    for _ in range(n):
        k = int(rng.integers(*lengths))
        root = rng.uniform(-0.3, 0.3, 3) * [1, 0, 1] + [0, 0.3, 0]
        steps = np.cumsum(np.c_[rng.normal(0, 0.02, k), -np.full(k, 0.08), rng.normal(0, 0.02, k)], axis=0)
        out.append((root + steps - steps[0]).astype(np.float32))
    return out


def scene_with(path, tmp_path, material=None):
    d = {"hairshade_scene": 1,
         "camera": {"position": [0, 0, 2.2], "target": [0, 0, 0], "fov": 40, "resolution": [96, 64]},
         "lights": [{"type": "directional", "direction": [0.3, 0.5, 1.0], "intensity": [3, 3, 3]}],
         "hair": {"file": path.name, "material": material or {"model": "karis"}}}
    scene_path = tmp_path / "scene.json"
    scene_path.write_text(json.dumps(d))
    return hs.Scene.load(scene_path)


def test_01_round_trip_points_radii_offsets_and_render(tmp_path):
    rng = np.random.default_rng(1)
    ss = strands(rng)
    thick = rng.uniform(0.002, 0.01, sum(len(s) for s in ss)).astype(np.float32)
    write_hair(tmp_path / "a.hair", ss, thickness=thick, transparency=True, color=True)
    s = scene_with(tmp_path / "a.hair", tmp_path)
    assert s.strand_count == len(ss)
    assert np.array_equal(np.diff(s.offsets), [len(x) for x in ss])
    assert np.array_equal(s.points, np.concatenate(ss))  # float32 in, float32 out: exact
    assert np.array_equal(s.radii, thick / 2)  # thickness is the diameter
    img = hs.render(s)
    assert np.all(np.isfinite(img)) and img.max() > 0
    assert np.count_nonzero(img.sum(axis=2)) > 50  # the strands cover pixels


def test_02_default_segments_and_thickness(tmp_path):
    """Without the segments and thickness arrays every strand has the
    header's default segment count and thickness."""
    rng = np.random.default_rng(2)
    ss = strands(rng, n=12, lengths=(5, 6))  # 5 points = 4 segments each
    write_hair(tmp_path / "b.hair", ss, segments_array=False, default_segments=4, default_thickness=0.006)
    s = scene_with(tmp_path / "b.hair", tmp_path)
    assert s.strand_count == 12 and np.all(np.diff(s.offsets) == 5)
    assert np.array_equal(s.points, np.concatenate(ss))
    assert np.all(s.radii == np.float32(0.003))


@pytest.mark.parametrize("damage, match", [
    ("magic", "not a .hair file"),
    ("truncated", "points array is truncated"),
    ("count", "the header says"),
    ("claims", "the header claims 10000 points"),
    ("nan", "is not finite"),
])
def test_03_bad_files_name_the_field_and_problem(tmp_path, damage, match):
    rng = np.random.default_rng(3)
    ss = strands(rng, n=5)
    if damage == "nan":
        ss[2][1, 0] = np.nan
    header_points = {"count": sum(len(x) for x in ss) - 1, "claims": 10_000}.get(damage)
    write_hair(tmp_path / "c.hair", ss, header_points=header_points)
    raw = (tmp_path / "c.hair").read_bytes()
    if damage == "magic":
        raw = b"HAIX" + raw[4:]
    if damage == "truncated":
        raw = raw[:-7]
    (tmp_path / "c.hair").write_bytes(raw)
    with pytest.raises(hs.SceneError, match=rf"hair\.file: .*c\.hair: .*{match}"):
        scene_with(tmp_path / "c.hair", tmp_path)


def test_04_from_arrays_equals_the_same_strands_inline():
    rng = np.random.default_rng(4)
    ss = strands(rng, n=6)
    pts = np.concatenate(ss)
    offsets = np.r_[0, np.cumsum([len(x) for x in ss])]
    radii = rng.uniform(0.001, 0.004, len(pts))
    cam = {"position": [0, 0, 2.2], "target": [0, 0, 0], "resolution": [80, 48]}
    mat = {"model": "chiang", "eumelanin": 0.5}
    a = hs.Scene.from_arrays(pts, radii, offsets, material=mat, camera=cam)
    inline = [{"points": x.tolist(), "radii": radii[o:o + len(x)].tolist()} for x, o in zip(ss, offsets)]
    b = hs.Scene.from_dict({"hairshade_scene": 1, "camera": cam, "lights": [
        {"type": "directional", "direction": [0.5, 0.7, 0.6], "intensity": [3, 3, 3], "shadows": True}],
        "hair": {"strands": inline, "material": mat}})
    assert np.array_equal(a.points, b.points) and np.array_equal(a.radii, b.radii)
    assert np.array_equal(a.offsets, b.offsets)
    assert np.array_equal(hs.render(a), hs.render(b))


def test_05_from_arrays_default_camera_frames_the_strands():
    rng = np.random.default_rng(5)
    ss = [x + [10.0, -4.0, 2.0] for x in strands(rng, n=20)]  # far from the origin
    pts = np.concatenate(ss)
    s = hs.Scene.from_arrays(pts, 0.003, np.r_[0, np.cumsum([len(x) for x in ss])])
    img = hs.render(s, width=96)
    assert np.count_nonzero(img.sum(axis=2)) > 50


@pytest.mark.parametrize("args, match", [
    ((np.zeros((4, 2)), 0.01, [0, 2, 4]), r"points: expected shape \(M, 3\)"),
    ((np.zeros((4, 3)), np.ones(3), [0, 2, 4]), r"radii: expected a scalar or shape \(4,\)"),
    ((np.zeros((4, 3)), 0.01, [0, 1, 4]), "offsets: strand 0 has 1 points"),
    ((np.zeros((4, 3)), 0.01, [0, 2, 5]), "offsets: must start at 0 and end at len"),
    ((np.zeros((4, 3)), 0.01, [0.0, 2.0, 4.0]), "offsets: expected a 1-d integer array"),
    ((np.full((4, 3), np.nan), 0.01, [0, 2, 4]), r"points\[0\]: must be finite"),
    ((np.zeros((4, 3)), -1.0, [0, 2, 4]), r"radii\[0\]: must be finite and >= 0"),
])
def test_06_from_arrays_errors_name_the_argument(args, match):
    with pytest.raises(hs.SceneError, match=match):
        hs.Scene.from_arrays(*args)
