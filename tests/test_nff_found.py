"""NFF files as they are found (issue 20, item 3), from Python and the command line: the classic
glass (Ks + T over 1) is read with one warning per file and renders to an end, the same bits
for any thread count; an unknown entity is an error naming it, and ``--skip-unknown`` reads the
file without it, warning with each entity and its count.  (The reader's own checks:
tests/c/test_nff_found.c.)"""
import pytest

import mprt
from cli_run import cli_main

# A classic glass scene: two glass balls (Ks + T = 1.8) and a third (1.4) over a tiled floor,
# with the extension lines other tools write (Q, fp with its data, Z).
GLASS = """v
from 0 -6 1.5
at 0 0 0.5
up 0 0 1
angle 35
hither 0.01
resolution 24 24
b 0.1 0.2 0.5
l 4 -4 8
l -5 -2 6
f 0.8 0.3 0.2 0.7 0.3 20 0 1
p 4
-4 -4 0
4 -4 0
4 4 0
-4 4 0
f .9 .9 .9 .1 .9 50 .9 1.33
s 0 0 1 1
s 0.6 1.8 0.8 0.8
f 1 1 1 0 0.5 10 0.9 1.5
s -1.5 0.5 0.5 0.5
"""
EXTENSIONS = "Q 0\nfp 2\n1 2 3\n4 5 6\nZ 481\nQ 1\n"


mprt_main = cli_main


def test_glass_over_one_is_read_with_one_note():
    """Both over-1 materials are kept as written; one note names the first line and the count."""
    scene = mprt.Scene.from_text(GLASS, "glass.nff")
    m = scene.materials()
    assert list(m["ks"] + m["t"]) == pytest.approx([0.3, 1.8, 1.4])
    assert scene.notes == [scene.notes[0]] and scene.notes[0].startswith(
        "glass.nff:17: material: Ks 0.9 + T 0.9 = 1.8 is over 1 (2 such materials in the file)")


def test_the_classic_glass_renders_the_same_bits_for_any_thread_count():
    """SPD rules: the render ends with secondary rays, the same image and counts for 1, 2 and 3
    threads; paper rules (depth 5 for this scene since issue 36: Scene.default_max_depth): all
    thread counts finish alike; to depth 64, each stops at the same sample."""
    grid = mprt.Scene.from_text(GLASS, "glass.nff").grid((5, 5, 3))
    img, c = grid.render(24, 24, rules="spd", threads=1)
    assert c["reflect_rays"] > 100 and c["refract_rays"] > 100
    for threads in (2, 3):
        img2, c2 = grid.render(24, 24, rules="spd", threads=threads)
        assert img2.tobytes() == img.tobytes() and c2 == c
    for depth in (0, 64):
        outcomes = set()
        for threads in (1, 2):
            try:
                img, c = grid.render(24, 24, rules="paper", threads=threads, max_depth=depth)
                outcomes.add((img.tobytes(), repr(sorted(c.items()))))
            except mprt.WorkLimitError as e:
                outcomes.add(str(e))
        assert len(outcomes) == 1
        assert isinstance(outcomes.pop(), str) == (depth == 64)


def test_unknown_entity_is_an_error_naming_it(tmp_path, capsys):
    """Without --skip-unknown the first unknown line is an error naming the entity and the way
    to read the file without it."""
    f = tmp_path / "ext.nff"
    f.write_text(GLASS + EXTENSIONS)
    with pytest.raises(mprt.SceneParseError, match=r"ext.nff:22: unknown entity 'Q'"):
        mprt.Scene.from_nff(f)
    code, _, err = mprt_main(capsys, "render", f, "--res", "8x8", "-o", tmp_path / "x.png", "--rules", "spd")
    assert code == 1
    assert "ext.nff:22: unknown entity 'Q' (--skip-unknown reads the file without" in err
    assert not (tmp_path / "x.png").exists()


def test_skip_unknown_reads_without_them_and_warns_with_counts(tmp_path, capsys):
    """--skip-unknown: the same scene as the file without those lines, and one warning for each
    entity with its count and lines (issue 36: the 'fp' material line's says which material its
    surfaces take), and one for the glass (saying its trees stop at depth 5)."""
    f = tmp_path / "ext.nff"
    f.write_text(GLASS + EXTENSIONS)
    scene = mprt.Scene.from_nff(f, skip_unknown=True)
    assert scene.to_nff() == mprt.Scene.from_text(GLASS).to_nff()
    code, out, err = mprt_main(capsys, "render", f, "--skip-unknown", "--res", "8x8", "--rules", "spd",
                               "-o", tmp_path / "x.png")
    assert code == 0, err
    warnings = [ln for ln in err.splitlines() if ln.startswith("mprt: warning: ")]
    assert len(warnings) == 4
    assert warnings[0].endswith("(2 such materials in the file): read as written; a hit's reflection and "
                                "refraction rays may then carry more light in all than their parent, and "
                                "the ray budget of a sample (--max-rays) bounds the work; as the contribution "
                                "cutoff cannot end the ray trees of such a surface, they stop at depth 5 (SPD's; "
                                "classic NFF renderers limit depth) unless --max-depth is given")
    assert warnings[1].endswith("ext.nff: 2 'Q' lines skipped (lines 22, 27), with the number lines after each")
    assert warnings[2].endswith("ext.nff: 1 'fp' material line skipped (line 23), with the number lines after it: "
                                "the surfaces after it take the last 'f' material before it: the 'f' of line 20")
    assert warnings[3].endswith("ext.nff: 1 'Z' line skipped (line 26), with the number lines after it")
    assert "4 primitives" in out


@pytest.mark.parametrize("command", ["render", "trace", "simulate", "explore", "prepass"])
def test_every_scene_command_takes_skip_unknown(command, capsys):
    """Every subcommand that reads a scene lists --skip-unknown in its help."""
    code, out, _ = mprt_main(capsys, command, "--help")
    assert code == 0 and "--skip-unknown" in out
