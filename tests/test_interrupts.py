"""Interrupts leave nothing wrong (issue 36): a trace stopped by Ctrl-C or SIGKILL at any moment
leaves nothing under its name (or, finished first, a whole file), Ctrl-C leaves no temporary
and SIGKILL only temporaries the next run removes; Ctrl-C in a command with worker processes
(explore's pool, sweep's local Dask cluster) is one line and status 130.

The commands run as a terminal runs them: in a process group of their own, the signal sent to
the whole group (Ctrl-C reaches every process of the foreground group, workers included).  The
moments are found by watching the output's directory, not by the clock, so that they hold on a
slow machine.
"""
import os
import re
import signal
import subprocess
import sys
import time

import pytest

from mprt import cli, options

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def sweep_spec() -> str:
    """The test sweep's designs (tests/data/explore/sweep.toml) over scenes, a resolution and
    subdivisions that keep two workers busy for seconds."""
    with open(os.path.join(ROOT, "tests", "data", "explore", "sweep.toml")) as f:
        text = f.read()
    for key, value in (("scenes", '["balls:2", "tetra:3"]'), ("res", '"256x256"'),
                       ("subdivisions", "[8, 12, 16, 20, 24, 28]"), ("batch", "1")):
        text, n = re.subn(rf"(?m)^{key} = .*$", f"{key} = {value}", text)
        assert n == 1, key
    return text


NOISE = ("Traceback", "KeyboardInterrupt", "CancelledError", "Error", "Process ")


def _as_at_a_terminal():
    """In the child before it runs mprt: SIGINT delivered and handled by default, as a command
    started at a terminal has it (a test run itself started in the background, or by a harness
    that blocks Ctrl-C, would otherwise pass on an ignored or blocked SIGINT, which mprt keeps)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def start(argv, cwd):
    """mprt with argv in a process group of its own (stdout, stderr piped)."""
    return subprocess.Popen([sys.executable, "-m", "mprt", *argv], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=_as_at_a_terminal)


def temporaries(d, name="t.npz"):
    """The temporaries of ``name`` in d (``atomic``'s names: .NAME.PID[.TAG].tmp.npz)."""
    return sorted(f for f in os.listdir(d) if re.fullmatch(rf"\.{re.escape(name)}\.\d+(\.[a-z]+)?\.tmp\.npz", f))


def wait_for(p, d, moment, timeout=120.0):
    """Poll d until ``moment(p, d)`` holds or p ends; whether it held."""
    t0 = time.monotonic()
    while p.poll() is None and time.monotonic() - t0 < timeout:
        if moment(p, d):
            return True
        time.sleep(0.002)
    return False


def mine(p, d, tag=""):
    return os.path.join(d, f".t.npz.{p.pid}{'.' + tag if tag else ''}.tmp.npz")


def writing(p, d):
    """The trace file is being written (its temporary, or the stream before --compress, exists)."""
    return os.path.exists(mine(p, d)) or os.path.exists(mine(p, d, "stream"))


def half_written(p, d):
    """Uncompressed: over 100 MB of the about 280 written; --compress: deflating into the output's
    temporary."""
    stream = mine(p, d, "stream")
    if os.path.exists(stream):
        return os.path.exists(mine(p, d))
    try:
        return os.path.getsize(mine(p, d)) > 100 << 20
    except OSError:
        return False


def whole(path) -> bool:
    return subprocess.run([sys.executable, "-m", "mprt", "stats", str(path)], capture_output=True).returncode == 0


@pytest.mark.slow
@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("compress", [False, True], ids=["stored", "compress"])
def test_an_interrupted_trace_leaves_nothing_under_its_name(tmp_path, threads, compress):
    argv = ["trace", "balls", "--res", "256x256", "--grid", "100", "--threads", str(threads), "-o", "t.npz"] + \
        (["--compress"] if compress else [])
    out = tmp_path / "t.npz"
    interrupted = 0
    # SIGKILL first at each moment: what it leaves the Ctrl-C run after it removes
    for moment in (writing, half_written):
        for sig in (signal.SIGKILL, signal.SIGINT):
            p = start(argv, tmp_path)
            reached = wait_for(p, str(tmp_path), moment)
            if reached:
                os.killpg(p.pid, sig)
            _, err = p.communicate(timeout=120)
            what = f"{signal.Signals(sig).name} at {moment.__name__} (reached: {reached}): rc {p.returncode}"
            if p.returncode == 0:             # done before the moment came: a whole file
                assert whole(out), what
                out.unlink()
            else:
                interrupted += 1
                assert not out.exists(), what
                if sig == signal.SIGINT:
                    assert p.returncode == 130, what + err
                    assert err.endswith("mprt trace: interrupted\n") and not any(w in err for w in NOISE), err
                    assert temporaries(tmp_path) == [], what      # its own removed, and those SIGKILL left
                else:
                    assert p.returncode == -signal.SIGKILL, what
                    left = temporaries(tmp_path)
                    assert all(f".{p.pid}." in f for f in left), left
            # (the rays' scratch file is unnamed where the file system allows: O_TMPFILE)
            assert set(os.listdir(tmp_path)) <= {".t.npz.%d%s.tmp.npz" % (p.pid, t) for t in ("", ".stream", ".rays")}, \
                os.listdir(tmp_path)
    assert interrupted >= 2          # the moment the writing starts is always met: the trace takes seconds
    # and after all that, a trace runs to its end, whole, with nothing beside it
    p = start(argv, tmp_path)
    p.communicate(timeout=300)
    assert p.returncode == 0 and whole(out)
    assert os.listdir(tmp_path) == ["t.npz"]


def test_the_next_write_removes_what_a_killed_trace_left(tmp_path):
    """What SIGKILL leaves (a dead process's temporaries) goes with the next trace of the name."""
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True).stdout.strip()
    for tag in ("", ".stream", ".rays"):
        (tmp_path / f".t.npz.{dead}{tag}.tmp.npz").write_bytes(b"PK partial")
    (tmp_path / f".u.npz.{dead}.tmp.npz").write_bytes(b"another name's")
    assert cli.main(["trace", "tetra:1", "--res", "16x16", "--grid", "4", "--compress", "-o",
                     str(tmp_path / "t.npz")]) == 0
    assert sorted(os.listdir(tmp_path)) == sorted([f".u.npz.{dead}.tmp.npz", "t.npz"])


def ctrl_c_while(argv, cwd, line: str, timeout=300.0):
    """Run mprt, send SIGINT to its group once a line matching ``line`` (a regular expression)
    appears on its stderr; (rc, stderr)."""
    p = start(argv, cwd)
    err = []
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        got = p.stderr.readline()
        if not got:
            break
        err.append(got)
        if re.search(line, got):
            time.sleep(0.5)                 # into the work (the workers busy)
            os.killpg(p.pid, signal.SIGINT)
            break
    rest, more = p.communicate(timeout=120)
    return p.returncode, "".join(err) + more


def one_line(err: str, command: str) -> None:
    """The interrupt's stderr: what the command said of its progress, then one line."""
    assert not any(w in err for w in NOISE), err
    assert err.endswith(f"mprt {command}: interrupted\n"), err
    assert err.count("interrupted") == 1, err


@pytest.mark.slow
def test_ctrl_c_in_a_sweep_on_a_local_cluster_is_one_line(tmp_path):
    (tmp_path / "s.toml").write_text(sweep_spec())
    rc, err = ctrl_c_while(["sweep", "s.toml", "--out", "out", "--workers", "2"], tmp_path, r"\d+/\d+ tasks done")
    assert rc == 130, err
    one_line(err, "sweep")
    assert not os.path.exists(tmp_path / "out" / "sweep.csv")
    left = [os.path.join(r, f) for r, _, fs in os.walk(tmp_path) for f in fs if ".tmp" in f]
    assert left == []


@pytest.mark.slow
def test_ctrl_c_in_explore_with_worker_processes_is_one_line(tmp_path):
    rc, err = ctrl_c_while(["explore", "balls", "--res", "32x32", "--workers", "2", "--json", "e.json"], tmp_path,
                           r"^phase \d+/\d+: search")     # seconds of work on the workers
    assert rc == 130, err
    one_line(err, "explore")
    assert os.listdir(tmp_path) == []


def parsers():
    p = cli.build_parser()
    return p._subparsers._group_actions[0].choices


@pytest.mark.parametrize("name", cli.COMMANDS)
def test_every_parser_says_130_is_an_interrupt(name):
    assert "130 interrupted (Ctrl-C)" in parsers()[name].epilog


def test_the_exit_status_section_puts_a_commands_own_before_130():
    text = options.exit_status("3 with --baseline: the cycles moved")
    assert text.index("2 a bad option") < text.index("3 with --baseline") < text.index("130 interrupted")
