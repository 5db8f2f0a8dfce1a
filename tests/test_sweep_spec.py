"""The sweep spec speaks the workload file's grammar (issue 35 items 1 and 4, issue 36 item 4):
[[scene]] tables with the workload's keys (or the old list of names), each scene traced with its
own res, rules, skip_unknown, max_rays and max_depth; designs as a built-in machine's name (the
machine model's 3MPPE, M, S: the cycles of simulate --model), a partial design over its base
(tables merged key by key, base another design or "default") or a machine file; --skip-unknown
the default of the scenes that do not say; errors name the spec and the field."""
import argparse
import csv
import json
import pickle

import pytest

from mprt import tracing
from mprt.cli import main
from mprt.explore import sweep
from mprt.explore.cli import add_parsers
from mprt.explore.evaluate import TraceEvaluator, grid_dims
from mprt.explore.space import Design, SpaceError
from mprt.machine.config import builtin, config_toml, load_config
from mprt.scene import Scene

# A small NFF scene: a ball over a floor, with extension lines mprt does not know after it.
BALL = """v
from 0 -5 1
at 0 0 0.5
up 0 0 1
angle 40
hither 0.01
resolution 16 16
b 0.1 0.1 0.2
l 3 -4 5
f 0.8 0.3 0.2 0.7 0.3 20 0 1
p 4
-3 -3 0
3 -3 0
3 3 0
-3 3 0
f 0.9 0.9 0.9 0.6 0.4 20 0 1
s 0 0 0.8 0.8
"""
EXTENSIONS = "Q 0\nfp 2\n1 2 3\n4 5 6\nZ 481\n"


def run(*argv):
    p = argparse.ArgumentParser(prog="mprt")
    add_parsers(p.add_subparsers(dest="cmd", required=True))
    a = p.parse_args([str(x) for x in argv])
    return a.func(a)


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def spec_file(tmp_path, text, name="s.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.fixture
def traces(monkeypatch):
    """(width, height, rules, max_depth, max_rays) of every trace made in this process."""
    made = []
    real = tracing.trace

    def spy(grid, width=0, height=0, rules="paper", threshold=None, **kw):
        made.append((width, height, rules, kw.get("max_depth"), kw.get("max_rays")))
        return real(grid, width, height, rules, threshold, **kw)

    monkeypatch.setattr(tracing, "trace", spy)
    return made


DESIGNS = '[designs]\nS = "S"\nwide = { pes = 2 }\n'


def test_the_list_and_the_tables_give_the_same_rows(tmp_path):
    old = spec_file(tmp_path, 'scenes = ["tetra:1", "balls:1"]\nres = "12x12"\nsubdivisions = [2, 3]\n' + DESIGNS,
                    "old.toml")
    new = spec_file(tmp_path, 'res = "12x12"\nsubdivisions = [2, 3]\n[[scene]]\nname = "tetra:1"\n'
                    '[[scene]]\nname = "balls:1"\n' + DESIGNS, "new.toml")
    assert run("sweep", old, "--out", tmp_path / "a", "--workers", "0") == 0
    assert run("sweep", new, "--out", tmp_path / "b", "--workers", "0") == 0
    a, b = rows(tmp_path / "a" / "sweep.csv"), rows(tmp_path / "b" / "sweep.csv")
    assert len(a) == 2 * 2 * 2 and a == b
    assert [r["scene"] for r in a[::4]] == ["tetra:1", "balls:1"]        # named as given, in order
    assert sweep.load_spec(old)["entries"] == sweep.load_spec(new)["entries"]


def test_a_scenes_own_settings_reach_its_trace(tmp_path, traces):
    p = spec_file(tmp_path, 'res = "16x16"\nrules = "paper"\nsubdivisions = [3]\n'
                  '[[scene]]\nname = "balls:1"\nres = "8x10"\nrules = "spd"\nmax_depth = 2\nmax_rays = 500\n'
                  '[[scene]]\nname = "tetra:1"\n[designs]\nS = "S"\n')
    assert run("sweep", p, "--out", tmp_path / "o", "--workers", "0") == 0
    assert sorted(traces, key=str) == sorted([(8, 10, "spd", 2, 500), (16, 16, "paper", None, None)], key=str)
    got = {r["scene"]: float(r["cycles"]) for r in rows(tmp_path / "o" / "sweep.csv")}
    scene = Scene.load("balls:1")
    _, tr = scene.grid(grid_dims(scene, (3,))).trace(8, 10, rules="spd", max_depth=2, max_rays=500)
    assert got["balls:1"] == TraceEvaluator(tr).run_config(builtin("S"), 1).cycles
    _, deep = scene.grid(grid_dims(scene, (3,))).trace(8, 10, rules="spd")
    assert len(deep.rays) > len(tr.rays)               # (the depth limit changed the trace)


def test_a_partial_design_is_its_base_with_the_fields_it_gives(tmp_path):
    p = spec_file(tmp_path, 'scenes = ["tetra:1"]\nsubdivisions = [2]\n[designs]\n'
                  'os3 = { units = { OS = { int = 3 } } }\n'
                  'twice = { base = "os3", replication = { IC = 2 }, pes = 2 }\n'
                  'thrice = { base = "twice", units = { IC = { fp = 0, general = 1 } } }\n'
                  'plain = { base = "default", cache = { SC = 8 } }\n')
    d = sweep.load_spec(p)["designs"]
    base = Design().to_dict()
    os3 = json.loads(json.dumps(base))
    os3["units"]["OS"] = {"int": 3, "fp": 2}
    assert d["os3"] == Design(**os3)
    twice = json.loads(json.dumps(os3))
    twice["replication"] = {"OS": 1, "IC": 2, "SC": 1}
    twice["pes"] = 2
    assert d["twice"] == Design(**twice)
    thrice = json.loads(json.dumps(twice))
    thrice["units"]["IC"] = {"int": 1, "fp": 0, "general": 1}
    assert d["thrice"] == Design(**thrice)
    assert d["plain"].cache == {"IC": 16, "SC": 8} and d["plain"].units == Design().units
    # Design.from_dict without a base reads a whole design back as it was (no merging)
    m = Design(units={"OS": {"general": 1}, "IC": {"general": 1}, "SC": {"general": 1}})
    assert Design.from_dict(m.to_dict()) == m
    assert Design.from_dict({"units": {"OS": {"int": 3}}}, base=Design()).units["OS"] == {"int": 3, "fp": 2}


@pytest.mark.parametrize("level", [1, 3])
def test_3mppe_rows_are_simulate_model_3mppe(tmp_path, capsys, level):
    p = spec_file(tmp_path, f'scenes = ["balls:1"]\nres = "16x16"\nsubdivisions = [[4, 4, 3]]\nlevel = {level}\n'
                  '[designs]\npaper = "3mppe"\nM = "M"\n')
    assert run("sweep", p, "--out", tmp_path / "o", "--workers", "0") == 0
    got = {r["design"]: r for r in rows(tmp_path / "o" / "sweep.csv")}
    for model, name in (("3mppe", "paper"), ("M", "M")):
        out = tmp_path / f"{model}.json"
        assert main(["simulate", "balls:1", "--model", model, "--grid", "4,4,3", "--res", "16x16",
                     "--level", str(level), "--json", str(out)]) == 0
        sim = json.loads(out.read_text())
        assert float(got[name]["cycles"]) == sim["cycles"] > 0, model
    assert float(got["paper"]["cost"]) > float(got["M"]["cost"]) > 0


def test_a_machine_file_design_and_an_nff_beside_the_spec(tmp_path, monkeypatch):
    folder = tmp_path / "specs"
    folder.mkdir()
    (folder / "ball.nff").write_text(BALL + EXTENSIONS)
    cfg = builtin("3mppe").replace(pes=1)
    (folder / "one.toml").write_text(config_toml(cfg))
    p = spec_file(folder, 'res = "12x12"\nsubdivisions = [3]\n[[scene]]\nname = "ball.nff"\nskip_unknown = true\n'
                  '[designs]\nmine = { machine = "one.toml" }\npaper = "3mppe"\n')
    monkeypatch.chdir(tmp_path)                         # the spec's folder is not the current one
    spec = sweep.load_spec(p)
    assert spec["designs"]["mine"] == load_config(folder / "one.toml")
    assert spec["scenes"] == ["ball.nff"]
    assert run("sweep", p, "--out", tmp_path / "o", "--workers", "0") == 0
    got = {r["design"]: float(r["cycles"]) for r in rows(tmp_path / "o" / "sweep.csv")}
    scene = Scene.from_nff(str(folder / "ball.nff"), skip_unknown=True)
    _, tr = scene.grid(grid_dims(scene, (3,))).trace(12, 12)
    ev = TraceEvaluator(tr)
    assert got["mine"] == ev.run_config(cfg, 1).cycles
    assert got["paper"] == ev.run_config(builtin("3mppe"), 1).cycles != got["mine"]


def test_a_task_pickles_and_a_fresh_worker_loads_the_scene_itself(tmp_path):
    (tmp_path / "ball.nff").write_text(BALL + EXTENSIONS)
    p = spec_file(tmp_path, 'res = "8x8"\nsubdivisions = [2]\n[[scene]]\nname = "ball.nff"\nskip_unknown = true\n'
                  'max_depth = 3\n[designs]\npaper = "3mppe"\nd = { pes = 2 }\n')
    spec = sweep.load_spec(p)
    (entry,) = spec["entries"]
    scene = entry.load()
    args = (entry, [2, 2, 2], 1, [sweep._portable(spec["designs"][n]) for n in ("paper", "d")], scene.content_hash())
    here = sweep._batch_task(*args)
    sweep._TRACES.clear()
    sweep._SCENES.clear()
    there = sweep._batch_task(*pickle.loads(pickle.dumps(args)))
    assert there == here and here[0]["cycles"] > 0
    with pytest.raises(Exception, match="differs from the one swept"):
        sweep._TRACES.clear()
        sweep._SCENES.clear()
        sweep._batch_task(*args[:4], "0" * 64)


def test_skip_unknown_per_scene_and_from_the_command_line(tmp_path, capsys):
    (tmp_path / "ball.nff").write_text(BALL + EXTENSIONS)
    (tmp_path / "plain.nff").write_text(BALL + EXTENSIONS)
    body = 'res = "8x8"\nsubdivisions = [2]\n[designs]\nS = "S"\n'
    refused = spec_file(tmp_path, 'scenes = ["ball.nff"]\n' + body, "refused.toml")
    assert main(["sweep", str(refused), "--out", str(tmp_path / "r"), "--workers", "0"]) != 0
    err = capsys.readouterr().err
    assert "unknown entity" in err and "skip_unknown = true" in err and "--skip-unknown" in err
    assert main(["sweep", str(refused), "--out", str(tmp_path / "r"), "--workers", "0", "--skip-unknown"]) == 0
    assert "warning" in capsys.readouterr().err                 # each entity skipped is told
    # a scene that says is not changed by the flag; the others take it
    mixed = spec_file(tmp_path, body.replace("[designs]", '[[scene]]\nname = "ball.nff"\nskip_unknown = false\n'
                                             '[[scene]]\nname = "plain.nff"\n[designs]'), "mixed.toml")
    spec = sweep.load_spec(mixed, skip_unknown=True)
    assert [e.skip_unknown for e in spec["entries"]] == [False, True]


@pytest.mark.parametrize("text, field", [
    ('scenes = ["tetra:1"]\nsubdivisions = [2]\n[designs]\nx = { speed = 3 }\n', "designs.x.speed: unknown field"),
    ('scenes = ["tetra:1"]\nsubdivisions = [2]\n[designs]\nx = { units = { XX = { int = 1 } } }\n',
     "designs.x: units.XX: unknown field"),
    ('scenes = ["tetra:1"]\nsubdivisions = [2]\n[designs]\nx = { units = { OS = { int = 0, fp = 1 } } }\n',
     "designs.x: units.OS: no unit runs integer"),
    ('scenes = ["tetra:1"]\nsubdivisions = [2]\n[designs]\nx = { base = "nowhere" }\n',
     r"designs.x.base: 'nowhere' is neither a design of this spec \(x\) nor \"default\""),
    ('scenes = ["tetra:1"]\nsubdivisions = [2]\n[designs]\nx = { base = "y" }\ny = { base = "x", pes = 2 }\n',
     r"designs.y.base: the bases go round \(x -> y -> x\)"),
    ('scenes = ["tetra:1"]\nsubdivisions = [2]\n[designs]\np = "3mppe"\nx = { base = "p", pes = 2 }\n',
     "designs.x.base: 'p' is a whole machine"),
    ('scenes = ["tetra:1"]\nsubdivisions = [2]\n[designs]\nx = "3MPPE"\n', "designs.x: '3MPPE' is not a built-in"),
    ('scenes = ["tetra:1"]\nsubdivisions = [2]\n[designs]\nx = { machine = "gone.toml" }\n',
     "designs.x.machine: no machine file 'gone.toml'"),
    ('scenes = ["tetra:1"]\nsubdivisions = [2]\n[designs]\nx = { machine = "m.toml", pes = 2 }\n',
     "designs.x.pes: a design with machine = ..."),
    ('scenes = ["tetra:1"]\nsubdivisions = [2]\n[designs]\ndefault = { pes = 2 }\n', "designs.default:"),
    ('subdivisions = [2]\n[[scene]]\nname = "tetra:1"\nspeed = 2\n[designs]\nS = "S"\n',
     r"scene\[0\].speed: unknown field"),
    ('subdivisions = [2]\n[[scene]]\nname = "gone.nff"\n[designs]\nS = "S"\n', r"scene\[0\].name: 'gone.nff'"),
    ('subdivisions = [2]\n[[scene]]\nname = "tetra:1"\nmax_depth = 0\n[designs]\nS = "S"\n',
     r"scene\[0\].max_depth: 0 is not an integer"),
    ('subdivisions = [2]\n[[scene]]\nname = "tetra:1"\n[[scene]]\nname = "tetra:1"\nres = "8x8"\n'
     '[designs]\nS = "S"\n', r"scene\[1\]: 'tetra:1' again"),
    ('scenes = ["tetra:1"]\nsubdivisions = [2]\n[[scene]]\nname = "balls:1"\n[designs]\nS = "S"\n', "not both"),
    ('subdivisions = [2]\n[designs]\nS = "S"\n', "scene: missing"),
    ('scenes = ["tetra:1"]\nsubdivisions = [2]\nspeed = 1\n[designs]\nS = "S"\n', "speed: unknown field"),
])
def test_errors_name_the_spec_and_the_field(tmp_path, text, field):
    (tmp_path / "m.toml").write_text(config_toml(builtin("S")))
    p = spec_file(tmp_path, text)
    with pytest.raises(SpaceError, match=field) as e:
        sweep.load_spec(p)
    assert str(e.value).startswith(f"{p}: ")


def test_a_bad_machine_file_is_named(tmp_path):
    (tmp_path / "m.toml").write_text('name = "x"\npes = 0\n[[stage]]\nsubtasks = ["OS", "IC", "SC"]\n')
    p = spec_file(tmp_path, 'scenes = ["tetra:1"]\nsubdivisions = [2]\n[designs]\nx = { machine = "m.toml" }\n')
    with pytest.raises(SpaceError, match=f"{p}: designs.x.machine: .*m.toml") as e:
        sweep.load_spec(p)
    assert "pes" in str(e.value)


def test_the_help_shows_the_grammar(capsys):
    with pytest.raises(SystemExit):
        run("sweep", "--help")
    text = capsys.readouterr().out
    for part in ("[[scene]]", "skip_unknown", "max_depth", 'paper = "3mppe"', 'base = "os3"', "\"default\"",
                 'machine = "mine.toml"', "--skip-unknown", 'scenes = ["balls", "tetra:2"]'):
        assert part in text, part


def test_a_dask_worker_traces_each_scene_with_its_own_options(tmp_path, monkeypatch):
    """On a local cluster (a worker process loads each scene itself: an NFF beside the spec read
    with skip_unknown, a machine file's machine) the rows are those of a run in this process."""
    folder = tmp_path / "specs"
    folder.mkdir()
    (folder / "ball.nff").write_text(BALL + EXTENSIONS)
    (folder / "one.toml").write_text(config_toml(builtin("3mppe").replace(pes=1)))
    p = spec_file(folder, 'res = "10x10"\nsubdivisions = [2, 3]\nbatch = 2\n'
                  '[[scene]]\nname = "ball.nff"\nskip_unknown = true\nmax_depth = 2\n'
                  '[[scene]]\nname = "balls:1"\nres = "8x8"\nrules = "spd"\n'
                  '[designs]\nmine = { machine = "one.toml" }\npaper = "3mppe"\n'
                  'os3 = { units = { OS = { int = 3 } } }\n')
    monkeypatch.chdir(tmp_path)
    assert run("sweep", p, "--out", tmp_path / "dask", "--workers", "1") == 0
    assert run("sweep", p, "--out", tmp_path / "here", "--workers", "0") == 0
    a, b = rows(tmp_path / "dask" / "sweep.csv"), rows(tmp_path / "here" / "sweep.csv")
    assert len(a) == 2 * 2 * 3 and a == b
    assert all(r["cycles"] and float(r["cycles"]) > 0 for r in a)
