"""A space file may mark a variable software (issue 35 item 1): chosen per scene, like the
subdivision, while the rest of the machine is one for the workload.  The feed of a processor's
copies (how they take their packets) is the one variable that may be: it is a policy, not
silicon, so it does not change what the chip costs."""
import argparse
import json
from pathlib import Path

import pytest

from mprt.explore.cli import add_parsers
from mprt.explore.space import SpaceError, parse_space

HERE = Path(__file__).parent
BASE = (HERE / "data" / "explore" / "workload_space.toml").read_text()
SOFT = BASE.replace('feed = "shared"', 'feed = { choices = ["shared", "round-robin", "shortest-queue"] }') \
           .replace('IC = { min = 1, max = 2 }\nSC = 1', 'IC = 2\nSC = 1', 1)
SOFT = 'software = ["replication.feed"]\n' + SOFT


def run(*argv):
    p = argparse.ArgumentParser(prog="mprt")
    add_parsers(p.add_subparsers(dest="cmd", required=True))
    a = p.parse_args([str(x) for x in argv])
    return a.func(a)


def test_software_variables_are_checked_by_name():
    sp = parse_space(SOFT, "soft.toml")
    assert sp.software == ("replication.feed",)
    hw = sp.hardware()
    assert dict(zip(hw.names, (v.values for v in hw.variables)))["replication.feed"] == ("shared",)
    assert [c["replication.feed"] for c in sp.software_values()] == ["shared", "round-robin", "shortest-queue"]
    with pytest.raises(SpaceError, match=r"soft.toml: software: 'pes' cannot be software"):
        parse_space('software = ["pes"]\n' + BASE, "soft.toml")
    with pytest.raises(SpaceError, match="software: a list of variable names"):
        parse_space('software = "replication.feed"\n' + BASE, "soft.toml")


def test_each_scene_takes_its_own_software_and_its_machine_file_runs_to_the_cycle(tmp_path, capsys):
    """Each scene's row names the feed it runs with, which is its best of the three for the shared
    machine (no other feed is faster there); each scene's machine file (--machine-out's
    FILE.K.toml) gives that row's cycles in simulate."""
    from mprt.cli import main
    from mprt.explore.evaluate import TraceEvaluator
    from mprt.machine.config import load_config
    from mprt.scene import Scene
    space, out, mout = tmp_path / "soft.toml", tmp_path / "e.json", tmp_path / "m.toml"
    space.write_text(SOFT)
    assert run("explore", "balls:1", "tetra:1", "--res", "16x16", "--space", space, "--level", "3",
               "--workers", "0", "--json", out, "--machine-out", mout) == 0
    rep = json.loads(out.read_text())
    for k, row in enumerate(rep["per_scene"]):
        assert set(row["software"]) == {"replication.feed"}
        cfg = load_config(str(tmp_path / f"m.{k + 1}.toml"))
        tr = Scene.load(row["scene"]).grid(tuple(row["subdivision"])).trace(16, 16)[1]
        ev = TraceEvaluator(tr)
        assert ev.run_config(cfg, 3).cycles == row["cycles"]
        feeds = {s.feed for s in cfg.stages if s.replicas > 1}
        assert feeds <= {row["software"]["replication.feed"], "shared"}
        # no other feed is faster for this scene on the same hardware
        for other in ("shared", "round-robin", "shortest-queue"):
            alt = cfg.replace(stages=tuple(s.__class__(**{**s.__dict__, "feed": other if s.replicas > 1 else "shared"})
                                           for s in cfg.stages))
            assert ev.run_config(alt, 3).cycles >= row["cycles"]
    capsys.readouterr()
    text = mout.read_text()
    assert "software" in text and "simulate" in text
