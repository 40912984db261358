"""The command line: render, compare, and clear errors with exit code 2."""

import pathlib
import subprocess
import sys

EXAMPLES = pathlib.Path(__file__).parent.parent / "examples"


def run(*args):
    return subprocess.run([sys.executable, "-m", "hairshade", *args], capture_output=True, text=True, timeout=300)


def test_render_and_compare(tmp_path):
    out = tmp_path / "strand.exr"
    r = run("render", str(EXAMPLES / "single_strand.json"), "-o", str(out), "--png", "--width", "160")
    assert r.returncode == 0, r.stderr
    assert out.exists() and (tmp_path / "strand.png").exists()
    assert "160x90" in r.stdout
    r = run("compare", str(out), str(out), "--png", str(tmp_path / "cmp.png"))
    assert r.returncode == 0, r.stderr
    assert "relMSE 0.0000e+00" in r.stdout and (tmp_path / "cmp.png").exists()


def test_render_lod_and_shading(tmp_path):
    """--lod and --shading reach the renderer: a quarter of the head's
    25 000 strands is drawn (within 4 standard errors); out-of-range or
    unreadable values exit with 2 and name the option."""
    out = tmp_path / "head.exr"
    r = run("render", str(EXAMPLES / "strand_head.json"), "-o", str(out), "--width", "160", "--lod", "0.25",
            "--shading", "vertex")
    assert r.returncode == 0, r.stderr
    drawn = int(r.stdout.split(" strands drawn")[0].rsplit(" ", 1)[1])
    assert abs(drawn - 6250) < 4 * (25000 * 0.25 * 0.75) ** 0.5, r.stdout
    r = run("render", str(EXAMPLES / "strand_head.json"), "-o", str(out), "--width", "16", "--lod", "2")
    assert r.returncode == 2 and "lod" in r.stderr
    r = run("render", str(EXAMPLES / "strand_head.json"), "-o", str(out), "--lod", "half")
    assert r.returncode == 2 and "--lod" in r.stderr


def test_errors_exit_2(tmp_path):
    r = run("render", str(tmp_path / "missing.json"))
    assert r.returncode == 2 and "missing.json: file not found" in r.stderr
    bad = tmp_path / "bad.json"
    bad.write_text('{"hairshade_scene": 1, "camera": {"position": [0,0,1], "target": [0,0,0], "fov": -3}}')
    r = run("render", str(bad))
    assert r.returncode == 2 and "camera.fov: must be in" in r.stderr


# Optional dependencies made unimportable in the child process: None in
# sys.modules makes `import x` fail and importlib.util.find_spec(x) None.
OPTIONAL = ["mitsuba", "drjit", "scipy", "matplotlib", "flip_evaluator", "tqdm"]


def run_without(missing, *args):
    code = ("import sys\n"
            f"for m in {list(missing)!r}: sys.modules[m] = None\n"
            "from hairshade.cli import main\n"
            f"sys.exit(main({list(args)!r}))")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)


def one_line_naming(r, extra):
    """Exit code 2 and a single stderr line that says what to install."""
    lines = r.stderr.strip().splitlines()
    return r.returncode == 2 and len(lines) == 1 and f"pip install 'hairshade[{extra}]'" in lines[0]


def test_missing_extras_one_line_before_any_work(tmp_path):
    img = tmp_path / "a.exr"
    assert run_without(OPTIONAL, "render", str(EXAMPLES / "single_strand.json"), "-o", str(img), "--width", "64").returncode == 0
    cases = [
        (["mitsuba", "drjit"], ["validate"], "mitsuba"),
        (["mitsuba"], ["bench", "--bsdf-only", "--n", "256", "--out", str(tmp_path / "b")], "mitsuba"),
        (["matplotlib"], ["bench", "--n", "256", "--plot", str(tmp_path / "p.png")], "plot"),
        (["scipy"], ["tables", "--out", str(tmp_path / "t")], "mapping"),
        (["flip_evaluator"], ["compare", str(img), str(img)], "flip"),
        (["flip_evaluator"], ["demo", "--out", str(tmp_path / "d")], "mitsuba,flip"),
        (OPTIONAL, ["demo", "--out", str(tmp_path / "d")], "mitsuba,flip"),
    ]
    for missing, args, extra in cases:
        r = run_without(missing, *args)
        assert one_line_naming(r, extra), (args, r.returncode, r.stderr)
        assert "nan" not in r.stdout and r.stdout == "", (args, r.stdout)  # nothing ran
    assert not any((tmp_path / d).exists() for d in ("b", "t", "d", "p.png"))  # nothing written


def test_compare_without_flip_reports_relmse_only(tmp_path):
    img = tmp_path / "a.exr"
    assert run("render", str(EXAMPLES / "single_strand.json"), "-o", str(img), "--width", "64").returncode == 0
    r = run_without(["flip_evaluator"], "compare", str(img), str(img), "--no-flip")
    assert r.returncode == 0 and "relMSE 0.0000e+00" in r.stdout and "nan" not in r.stdout.lower()


def test_mapping_is_an_attribute_and_says_what_it_needs():
    r = subprocess.run([sys.executable, "-c", "import hairshade as hs; print(hs.mapping.to_chiang(hs.KarisHair(), fit=False))"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stdout.startswith("ChiangHair("), r.stderr
    r = subprocess.run([sys.executable, "-c", "import sys; sys.modules['scipy'] = None\nimport hairshade as hs\nhs.mapping"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode != 0 and "hairshade.mapping needs scipy: pip install 'hairshade[mapping]'" in r.stderr


def test_every_option_of_every_command_has_help():
    """`hairshade COMMAND --help` explains every argument and option."""
    import argparse

    from hairshade.cli import build_parser

    missing = []
    for action in build_parser()._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                missing += [f"{name} {a.option_strings or a.dest}" for a in sub._actions
                            if not isinstance(a, argparse._HelpAction) and not a.help]
    assert not missing, missing


def test_render_finds_a_shipped_example_by_name(tmp_path):
    """From a wheel there is no examples/ folder: `hairshade render
    examples/strand_head.json` (or `strand_head`) renders the packaged
    example and says so; a name that is neither a file nor an example is
    still a missing file."""
    out = tmp_path / "a.png"
    r = subprocess.run([sys.executable, "-m", "hairshade", "render", "examples/single_strand.json", "-o", str(out),
                        "--width", "32"], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert r.returncode == 0 and out.stat().st_size > 0, r.stderr
    assert "rendering the shipped example" in r.stderr and "single_strand.json" in r.stderr
    r = subprocess.run([sys.executable, "-m", "hairshade", "render", "single_strand", "-o", str(out), "--width", "32"],
                       capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    r = subprocess.run([sys.executable, "-m", "hairshade", "render", "no_such_scene.json"], capture_output=True,
                       text=True, timeout=120, cwd=tmp_path)
    assert r.returncode == 2 and "no_such_scene.json" in r.stderr and "not found" in r.stderr


def test_compare_reads_png_as_srgb(tmp_path):
    """`compare` takes PNGs, decoded from sRGB to linear: a render's PNG
    against its own EXR differs only by the 8-bit rounding (measured relMSE
    2e-8 on this dark image; read without the sRGB decode it is about 0.2:
    the bound 1e-4 tells them apart); a text file is refused by name."""
    img = tmp_path / "a.exr"
    assert run("render", str(EXAMPLES / "single_strand.json"), "-o", str(img), "--width", "64").returncode == 0
    assert run("render", str(EXAMPLES / "single_strand.json"), "-o", str(tmp_path / "a.png"), "--width", "64").returncode == 0
    r = run_without(["flip_evaluator"], "compare", str(tmp_path / "a.png"), str(img), "--no-flip")
    assert r.returncode == 0, r.stderr
    rel = float(r.stdout.split()[1])
    assert rel < 1e-4, r.stdout
    (tmp_path / "x.txt").write_text("hello")
    r = run_without(["flip_evaluator"], "compare", str(tmp_path / "x.txt"), str(img), "--no-flip")
    assert r.returncode == 2 and "x.txt: expected an .exr or .png image" in r.stderr, r.stderr
