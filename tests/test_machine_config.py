"""Machine configurations: built-ins, TOML files, and errors naming field and file."""
import os

import pytest

from mprt.cost import ProcessorConfig
from mprt.machine import ConfigError, builtin, load_config
from mprt.machine.config import resolve, stage_capacity

HERE = os.path.dirname(os.path.abspath(__file__))

GOOD = """
name = "two-ic"
pes = 3
dis = "interleaved"
window = 12

[[stage]]
subtasks = ["OS"]
processor = "paper"
send_fifo = 4
receive_fifo = 8

[[stage]]
subtasks = ["IC"]
processor = { units = { int = 1, fp = 4 }, issue_width = 3 }
replicas = 2
receive_fifo = 16

[[stage]]
subtasks = ["SC"]

[ring]
flit_time = 2
buffer_classes = 3

[ic_memory]
resident = 4096
cache = { size = 8192, line = 64, ways = 4 }

[icgm]
latency = 30
bandwidth = 8
contention = false
"""


def write(tmp_path, text, name="m.toml"):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def test_builtins():
    s, m, p = builtin("S"), builtin("M"), builtin("3mppe")
    assert [x.subtasks for x in s.stages] == [("OS", "IC", "SC")]
    assert [x.subtasks for x in m.stages] == [("OS",), ("IC",), ("SC",)]
    assert all(x.processor == ProcessorConfig.sequential() for x in s.stages + m.stages)
    assert (m.ring, m.ic_memory, m.finite_fifos, m.level, m.pes) == (None, None, False, 2, 1)
    assert [x.processor for x in p.stages] == [ProcessorConfig.paper(t) for t in ("OS", "IC", "SC")]
    assert p.ring.buffer_classes == 3 and p.finite_fifos and p.level == 3 and p.pes == 2
    assert p.processors() == {t: ProcessorConfig.paper(t) for t in ("OS", "IC", "SC")}


def test_toml_file(tmp_path):
    c = load_config(write(tmp_path, GOOD))
    assert c.name == "two-ic" and c.pes == 3 and c.dis == "interleaved" and c.window == 12
    assert c.stages[1].replicas == 2 and c.stages[1].send_fifo is None and c.stages[1].receive_fifo == 16
    assert dict(c.stages[1].processor.units) == {"int": 1, "fp": 4} and c.stages[1].processor.issue_width == 3
    assert c.ring.flit_time == 2 and c.ic_memory.cache.line == 64 and c.icgm.contention is False
    assert c.sc_memory is None and c.level == 3
    assert c.source.endswith("m.toml")
    assert c.to_dict()["stages"][1]["processor"] == {"units": {"int": 1, "fp": 4}, "issue_width": 3}


def test_base_and_overrides(tmp_path):
    c = load_config(write(tmp_path, 'base = "3mppe"\npes = 4\nring = "none"\nic_memory = "none"\n'))
    assert c.name == "3mppe" and c.pes == 4 and c.ring is None and c.ic_memory is None
    assert c.sc_memory == builtin("3mppe").sc_memory
    assert load_config(os.path.join(HERE, "data", "machine", "full.toml")).ic_memory.resident == 1024


def test_resolve():
    assert resolve().name == "M" and resolve("S").name == "S" and resolve("3mppe", pes=3).pes == 3
    with pytest.raises(ConfigError, match="--pes: must be at least 1"):
        resolve("M", pes=0)


@pytest.mark.parametrize("text,message", [
    ('base = "M"\ncolour = 3\n', r"m\.toml: colour: unknown field"),
    ('base = "M"\n[ring]\nflit_time = 1\nspeed = 2\n', r"m\.toml: ring\.speed: unknown field"),
    ('base = "M"\npes = "two"\n', r"m\.toml: pes: must be an integer, not 'two'"),
    ('base = "M"\npes = 2.5\n', r"m\.toml: pes: must be an integer, not 2\.5"),
    ('base = "M"\nwindow = 0\n', r"m\.toml: window: must be at least 1, not 0"),
    ('base = "Q"\n', r"m\.toml: base: unknown model 'Q' \(known: S, M, 3mppe\)"),
    ('base = "M"\ndis = "random"\n', r"m\.toml: dis: unknown policy 'random'"),
    ('[[stage]]\nsubtasks = ["OS", "IC", "SC"]\nprocessor = { units = { int = 0, fp = 0 } }\n',
     r"m\.toml: stage\[0\]\.processor.*no functional unit"),
    ('[[stage]]\nsubtasks = ["OS", "IC", "SC"]\nprocessor = { units = { int = -1, fp = 2 } }\n',
     r"m\.toml: stage\[0\]\.processor.*units\['int'\] = -1"),
    ('[[stage]]\nsubtasks = ["OS", "IC", "SC"]\nprocessor = "fast"\n', r"m\.toml: stage\[0\]\.processor: must be"),
    ('[[stage]]\nsubtasks = ["OS", "IC"]\nprocessor = "paper"\n[[stage]]\nsubtasks = ["SC"]\n',
     r"m\.toml: stage\[0\]\.processor: 'paper' is ambiguous"),
    ('[[stage]]\nsubtasks = ["OS", "IC"]\n', r"m\.toml: stage: no stage runs SC"),
    ('[[stage]]\nsubtasks = ["OS", "IC", "SC"]\n[[stage]]\nsubtasks = ["IC"]\n',
     r"m\.toml: stage\[1\]\.subtasks: IC is already run by another stage"),
    ('[[stage]]\nsubtasks = ["OS", "XX", "SC"]\n', r"m\.toml: stage\[0\]\.subtasks: unknown subtask 'XX'"),
    ('[[stage]]\nsubtasks = ["OS", "IC", "SC"]\nreplicas = 0\n', r"m\.toml: stage\[0\]\.replicas: must be at least 1"),
    ('[[stage]]\nsubtasks = ["OS", "IC", "SC"]\nreceive_fifo = 0\n',
     r"m\.toml: stage\[0\]\.receive_fifo: a FIFO holds at least 1 packet, not 0"),
    ('[[stage]]\nsubtasks = ["OS", "IC", "SC"]\nsend_fifo = 1.5\n',
     r"m\.toml: stage\[0\]\.send_fifo: must be a positive integer or \"unbounded\""),
    ('[[stage]]\nsubtasks = ["OS", "IC", "SC"]\nlatency = 1\n', r"m\.toml: stage\[0\]\.latency: unknown field"),
    ('[[stage]]\nsubtasks = ["OS", "IC", "SC"]\nfeed = "random"\n',
     r"m\.toml: stage\[0\]\.feed: must be one of \"shared\", \"round-robin\", \"shortest-queue\", not 'random'"),
    ('[[stage]]\nsubtasks = ["OS", "IC", "SC"]\nfeed = 1\n', r"m\.toml: stage\[0\]\.feed: must be one of"),
    ('base = "M"\n[ic_memory]\nresident = -5\n[icgm]\nlatency = 1\nbandwidth = 1\n',
     r"m\.toml: ic_memory\.resident: must be at least 0, not -5"),
    ('base = "M"\n[ic_memory]\ncache = { size = 1024.0, line = 32, ways = 1 }\n[icgm]\nlatency = 1\nbandwidth = 1\n',
     r"m\.toml: ic_memory\.cache\.size: must be an integer, not 1024\.0"),
    ('base = "M"\n[ic_memory]\ncache = { size = 32, line = 64, ways = 1 }\n[icgm]\nlatency = 1\nbandwidth = 1\n',
     r"m\.toml: ic_memory\.cache\.line: the line \(64 bytes\) is larger than the cache \(32 bytes\)"),
    ('base = "M"\n[ic_memory]\ncache = { size = 1000, line = 32, ways = 1 }\n[icgm]\nlatency = 1\nbandwidth = 1\n',
     r"m\.toml: ic_memory\.cache\.size: 1000 bytes is not a whole number of sets"),
    ('base = "M"\n[ic_memory]\ncache = { size = 1024, ways = 1 }\n[icgm]\nlatency = 1\nbandwidth = 1\n',
     r"m\.toml: ic_memory\.cache\.line: missing"),
    ('base = "M"\n[ic_memory]\nresident = 64\n', r"m\.toml: icgm: ic_memory is modelled, so its misses need"),
    ('base = "M"\n[scgm]\nlatency = 1\nbandwidth = 0\n', r"m\.toml: scgm\.bandwidth: must be at least 1, not 0"),
    ('base = "M"\n[scgm]\nlatency = 1\nbandwidth = 2\ncontention = "yes"\n',
     r"m\.toml: scgm\.contention: must be true or false"),
    ('base = "M"\n[ring]\nbuffer_classes = 4\n', r"m\.toml: ring\.buffer_classes: at most 3"),
    ('base = "S"\n[ring]\nflit_time = 1\n', r"m\.toml: ring: a ring needs at least 2 stages"),
    ('base = "M"\nstage = 3\n', r"m\.toml: stage: must be an array of tables"),
    ("pes = 2\n", r"m\.toml: stage: missing"),
    ('base = "M"\npes = [1\n', r"m\.toml: not valid TOML"),
    # upper bounds: one value must not make a replay's work or memory run away (issue 19)
    ('base = "3mppe"\n[ic_memory]\ncache = { size = 1152921504606846976, line = 32, ways = 4 }\n',
     r"m\.toml: ic_memory\.cache\.size: at most 2\^40 bytes \(1 TiB\), not 1152921504606846976"),
    ('base = "M"\npes = 1000000\n', r"m\.toml: pes: must be at most 1024, not 1000000"),
    ('[[stage]]\nsubtasks = ["OS", "IC", "SC"]\nreplicas = 1000000\n',
     r"m\.toml: stage\[0\]\.replicas: must be at most 256"),
    ('base = "3mppe"\n[ring]\nflit_time = 1000000000000000000\n', r"m\.toml: ring\.flit_time: must be at most 65536"),
    ('base = "3mppe"\n[icgm]\nlatency = 1000000000\nbandwidth = 8\n', r"m\.toml: icgm\.latency: must be at most"),
    ('base = "M"\nwindow = 9223372036854775807\n', r"m\.toml: window: must be at most 1048576"),
    ('[[stage]]\nsubtasks = ["OS", "IC", "SC"]\nprocessor = { units = { int = 1, fp = 1 }, latency = { fadd = 1000000 } }\n',
     r"m\.toml: stage\[0\]\.processor.*latency\['fadd'\] = 1000000: must be a whole number in 1\.\.1024"),
    ('[[stage]]\nsubtasks = ["OS", "IC", "SC"]\nprocessor = { units = { int = 100000, fp = 1 } }\n',
     r"m\.toml: stage\[0\]\.processor.*units\['int'\] = 100000: must be a whole number in 0\.\.64"),
])
def test_errors_name_field_and_file(tmp_path, text, message):
    with pytest.raises(ConfigError, match=message):
        load_config(write(tmp_path, text))


def test_nested_too_deeply(tmp_path):
    with pytest.raises(ConfigError, match=r"m\.toml: not a TOML file mprt reads \(nested too deeply\)"):
        load_config(write(tmp_path, "pes = " + "[" * 100000 + "]" * 100000 + "\n"))


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match=r"nope\.toml: cannot read the configuration"):
        load_config(tmp_path / "nope.toml")


def test_dataclass_checks_without_a_file():
    m = builtin("M")
    with pytest.raises(ConfigError, match="^pes: must be at least 1, not 0"):
        m.replace(pes=0)
    with pytest.raises(ConfigError, match="^stage: no stage runs SC"):
        m.replace(stages=m.stages[:2])


def test_feed_field_and_deadlock_capacity(tmp_path):
    text = ('base = "M"\n[[stage]]\nsubtasks = ["OS"]\nsend_fifo = 2\nreceive_fifo = 3\n'
            '[[stage]]\nsubtasks = ["IC"]\nreplicas = 3\nsend_fifo = 2\nreceive_fifo = 3\nfeed = "FEED"\n'
            '[[stage]]\nsubtasks = ["SC"]\nsend_fifo = 2\nreceive_fifo = 3\n')
    caps = {}
    for feed in ("shared", "round-robin", "shortest-queue"):
        c = load_config(write(tmp_path, text.replace("FEED", feed)))
        assert c.stages[1].feed == feed and c.stages[0].feed == "shared"
        assert c.to_dict()["stages"][1].get("feed", "shared") == feed
        caps[feed] = (stage_capacity(c.stages[1]), c.cycle_capacity)
    # the README's deadlock argument: OS and SC hold 2 + 3 + 1 = 6 each when full, IC
    # (3 copies) 2 + 3 + 3 shared, 2 + 3 + 1 round-robin (only the next copy full),
    # 2 + 3 x (3 + 1) shortest-queue (every copy full); the smallest two stages count
    assert caps == {"shared": (8, 12), "round-robin": (6, 12), "shortest-queue": (14, 12)}
    assert load_config(write(tmp_path, text.replace("FEED", "round-robin").replace("replicas = 3", "replicas = 1")
                             .replace('receive_fifo = 3\nfeed', 'receive_fifo = 1\nfeed'))).cycle_capacity == 10
    with pytest.raises(ConfigError, match="^stage\\[0\\]\\.feed: must be one of shared, round-robin"):
        builtin("S").replace(stages=(builtin("S").stages[0].__class__(("OS", "IC", "SC"), None, feed="fifo"),))
