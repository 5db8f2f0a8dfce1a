"""The cost model: list scheduling, processor configurations, per-visit costs,
packets and the shipped calibration."""
import itertools
import math
import os

import numpy as np
import pytest

import mprt
from mprt.cost import KERNELS, OP_CLASSES, CostModel, CostModelError, Graph, ProcessorConfig, packet_flits
from mprt.cost.schedule import schedule_cycles

GOLDEN = os.path.join(os.path.dirname(__file__), "data", "golden")
LAT = {"int": 1, "fadd": 2, "fmul": 3, "fdiv": 10, "load": 2, "store": 1, "branch": 1}
FP2 = ProcessorConfig(units={"int": 1, "fp": 2})


def cycles(graph, proc, lat=LAT):
    return schedule_cycles(graph, proc, lat)


# ---- list scheduling on hand-made graphs ---------------------------------------

def test_chain_takes_the_sum_of_latencies_on_any_processor():
    # fadd -> fmul -> fdiv -> fadd: each waits for the previous result
    g = Graph.from_list("chain", [("fadd", ()), ("fmul", (0,)), ("fdiv", (1,)), ("fadd", (2,))])
    expect = 2 + 3 + 10 + 2
    for proc in (ProcessorConfig.sequential(), FP2, ProcessorConfig(units={"int": 4, "fp": 8}, pipelined=True)):
        assert cycles(g, proc) == expect


def test_independent_ops_on_k_units():
    # 7 independent fmuls (latency 3) on k FP units: ceil(7/k) rounds of 3 cycles
    # when a unit is busy for the whole latency; pipelined units start one per
    # cycle each, so the last starts at ceil(7/k) - 1 and ends 3 later.
    g = Graph.from_list("indep", [("fmul", ())] * 7)
    for k in (1, 2, 3, 7, 9):
        p = ProcessorConfig(units={"int": 1, "fp": k})
        assert cycles(g, p) == math.ceil(7 / k) * 3
        pp = ProcessorConfig(units={"int": 1, "fp": k}, pipelined=True)
        assert cycles(g, pp) == math.ceil(7 / k) - 1 + 3


def test_issue_width_limits_starts_per_cycle():
    g = Graph.from_list("indep", [("fadd", ())] * 6)
    p = ProcessorConfig(units={"int": 1, "fp": 6}, issue_width=2, pipelined=True)
    assert cycles(g, p) == 3 - 1 + 2          # 2 per cycle: starts at 0, 1, 2


def test_resource_bound_versus_latency_bound():
    # two independent chains of 4 fadds (latency 2): with two FP units the
    # chains overlap (latency bound: 8 cycles); with one non-pipelined unit all
    # 8 adds queue (resource bound: 16); with one pipelined unit the chains
    # interleave, one add starting per cycle while the other waits (9).
    ops = [("fadd", ())] + [("fadd", (i,)) for i in range(3)]
    ops += [("fadd", ())] + [("fadd", (4 + i,)) for i in range(3)]
    g = Graph.from_list("two chains", ops)
    assert cycles(g, ProcessorConfig(units={"int": 1, "fp": 2})) == 8
    assert cycles(g, ProcessorConfig(units={"int": 1, "fp": 1})) == 16
    assert cycles(g, ProcessorConfig(units={"int": 1, "fp": 1}, pipelined=True)) == 9


def test_specialised_units_take_their_classes_only():
    # an int op and an fmul: an int unit cannot run the fmul, so with 2 int
    # units and 1 fp unit the two run side by side; with only 'general' units
    # they also overlap when there are two of them.
    g = Graph.from_list("mix", [("int", ()), ("fmul", ()), ("fmul", ())])
    assert cycles(g, ProcessorConfig(units={"int": 2, "fp": 1})) == 6      # two fmuls queue on one FP unit
    assert cycles(g, ProcessorConfig(units={"general": 3})) == 3
    assert cycles(g, ProcessorConfig(units={"general": 1})) == 1 + 3 + 3


def _config_grid():
    for i, f, gen, w in itertools.product((0, 1, 2, 3), (0, 1, 2, 3), (0, 1), (1, 2, 3, 4, 6)):
        units = {"int": i, "fp": f, "general": gen}
        try:
            yield ProcessorConfig(units=units, issue_width=w)
        except CostModelError:
            continue   # no unit for some class


def test_more_units_or_issue_width_never_cost_cycles():
    configs = list(_config_grid())
    for name in ("os_step", "ic_sphere", "ic_vertex", "sc_light", "ic_hit_polygon"):
        g = KERNELS[name]
        c = {(tuple(p.units.get(k, 0) for k in ("int", "fp", "general")), p.issue_width): cycles(g, p)
             for p in configs}
        for (u, w), cyc in c.items():
            for j in range(3):
                more = tuple(x + (i == j) for i, x in enumerate(u))
                if (more, w) in c:
                    assert c[(more, w)] <= cyc, (name, u, w, more)
            if (u, w + 1) in c:
                assert c[(u, w + 1)] <= cyc, (name, u, w)


def test_sequential_is_the_sum_of_latencies_and_paper_vliw_never_slower():
    seq = ProcessorConfig.sequential()
    for name, g in KERNELS.items():
        total = sum(n * LAT[c] for c, n in g.counts().items())
        assert cycles(g, seq) == total, name
        for stage in ("OS", "IC", "SC"):
            assert cycles(g, ProcessorConfig.paper(stage)) <= total, (name, stage)
    # and the VLIW processors do overlap work in the big kernels
    assert cycles(KERNELS["os_setup"], ProcessorConfig.paper("OS")) < cycles(KERNELS["os_setup"], seq) / 2
    assert cycles(KERNELS["ic_cylinder"], ProcessorConfig.paper("IC")) < cycles(KERNELS["ic_cylinder"], seq) / 2


def test_latency_override_on_the_processor_wins():
    cm = CostModel.nominal()
    g = KERNELS["os_step"]
    slow = ProcessorConfig.sequential(latency={"fadd": 5})
    expect = sum(n * (5 if c == "fadd" else cm.latency[c]) for c, n in g.counts().items())
    assert cm.kernel_cycles("os_step", slow) == expect


# ---- configuration errors ---------------------------------------------------------

@pytest.mark.parametrize("kw, words", [
    ({"units": {"int": 2}}, ["units", "fadd"]),
    ({"units": {"int": 2, "fp": 0}}, ["units", "fadd"]),
    ({"units": {"int": 2, "fpu": 2}}, ["units['fpu']", "unknown unit kind"]),
    ({"units": {"int": -1, "fp": 1}}, ["units['int']", "in 0..64"]),
    ({"units": {"int": 1.5, "fp": 1}}, ["units['int']", "whole number"]),
    ({"units": {}}, ["units", "no functional unit"]),
    ({"units": {"general": 1}, "latency": {"fadd": -2}}, ["latency['fadd']", "in 1..1024"]),
    ({"units": {"general": 1}, "latency": {"fma": 2}}, ["latency['fma']", "unknown operation class"]),
    ({"units": {"general": 1}, "issue_width": 0}, ["issue_width", "in 1..64"]),
    ({"units": {"general": 1}, "pipelined": "yes"}, ["pipelined"]),
])
def test_bad_processor_configs_name_the_field(kw, words):
    with pytest.raises(CostModelError) as e:
        ProcessorConfig(**kw)
    for w in words:
        assert w in str(e.value)


def test_processor_from_dict_names_the_place_and_unknown_fields():
    with pytest.raises(CostModelError, match=r"m\.toml \[IC\]: unknown field 'unit'"):
        ProcessorConfig.from_dict({"unit": {"fp": 3}}, where="m.toml [IC]")
    with pytest.raises(CostModelError, match=r"m\.toml \[IC\]: .*units\['fp'\]"):
        ProcessorConfig.from_dict({"units": {"int": 1, "fp": -3}}, where="m.toml [IC]")
    p = ProcessorConfig.from_dict({"units": {"int": 1, "fp": 3}, "issue_width": 2})
    assert p == ProcessorConfig(units={"int": 1, "fp": 3}, issue_width=2)
    assert hash(p) == hash(ProcessorConfig(units={"int": 1, "fp": 3}, issue_width=2))


def test_bad_cost_model_and_kernel_names():
    with pytest.raises(CostModelError, match="'fdiv' is missing"):
        CostModel({c: 1 for c in OP_CLASSES if c != "fdiv"})
    with pytest.raises(CostModelError, match=r"visit_overhead\['OS'\]"):
        CostModel({c: 1 for c in OP_CLASSES}, {"OS": -1})
    with pytest.raises(CostModelError, match="unknown kernel 'os_stepp'"):
        CostModel.nominal().kernel_cycles("os_stepp", ProcessorConfig.sequential())
    tr = mprt.load_trace(os.path.join(GOLDEN, "balls-g4.npz"))
    with pytest.raises(CostModelError, match="no processor for stage 'SC'"):
        CostModel.nominal().visit_costs(tr, {"OS": ProcessorConfig.sequential(), "IC": ProcessorConfig.sequential()})


def test_packet_flits():
    # header + tail around the data words listed in packets.py
    assert packet_flits("SC", "OS", "primary") == 1 + 11 + 1
    assert packet_flits("SC", "OS", "shadow") == 1 + 13 + 1       # light term instead of contribution
    assert packet_flits("OS", "IC", "reflect") == packet_flits("IC", "OS", "reflect")
    assert packet_flits("OS", "SC", "shadow") < packet_flits("IC", "SC", "primary")
    assert packet_flits(0, 1, 3) == packet_flits("OS", "IC", "shadow")
    with pytest.raises(CostModelError, match="no IC->SC flow for a shadow ray"):
        packet_flits("IC", "SC", "shadow")
    with pytest.raises(CostModelError, match="ray_kind"):
        packet_flits("OS", "IC", "gamma")


# ---- per-visit costs against a plain per-visit loop ---------------------------------

def _loop_costs(tr, cm, procs, n):
    """Costs of the first n visits recomputed one visit at a time from the
    trace's fields and the kernel cycles (an independent reading of the rules)."""
    kc = {s: (lambda name, s=s: cm.kernel_cycles(name, procs[s])) for s in procs}
    rays, v = tr.rays, tr.visits
    tests = ["ic_sphere", "ic_polygon", "ic_cylinder", "ic_cone"]
    hits = ["ic_hit_sphere", "ic_hit_polygon", "ic_hit_cylinder", "ic_hit_cone"]
    kinds = ["primary", "reflect", "refract", "shadow"]
    stages = ["OS", "IC", "SC"]
    out = []
    for i in range(n):
        r = int(v["ray"][i])
        kind = kinds[rays["kind"][r]]
        s = stages[v["stage"][i]]
        o = int(v["outcome"][i])
        k = kc[s]
        first = i == 0 or int(v["ray"][i - 1]) != r
        proc = cm.visit_overhead[s]
        if s == "OS":
            proc += k("os_visit") + int(v["steps"][i]) * k("os_step") + (k("os_setup") if first else 0)
            if o == 8:
                proc += k(hits[tr.prim_kind[v["prim"][i]]])
        elif s == "IC":
            proc += k("ic_visit") + int(v["vertices"][i]) * k("ic_vertex")
            proc += sum(int(v["tests"][i][j]) * k(tests[j]) for j in range(4))
            if o == 3:
                proc += k(hits[tr.prim_kind[v["prim"][i]]])
        elif o == 7:
            proc += k("sc_lit")
        else:
            kids = [int(rays["kind"][c]) for c in np.flatnonzero(rays["parent"] == r)]
            proc += k("sc_shade") + tr.meta["lights"] * k("sc_light")
            proc += (int(v["made"][i]) + int(v["suppressed"][i])) * k("sc_keep")
            proc += sum(k(["", "sc_reflect", "sc_refract", "sc_shadow"][c]) for c in kids)
        # incoming packet
        if first:
            src = "SC"
        elif s == "SC":
            src = "OS" if o == 7 or int(v["outcome"][i - 1]) == 8 else "IC"
        else:
            src = "IC" if s == "OS" else "OS"
        recv = k("receive_packet") + packet_flits(src, s, kind) * k("receive_flit")
        # outgoing packets
        pk = []
        if s == "OS" and o == 0:
            pk = [packet_flits("OS", "IC", kind)]
        elif s == "OS" and o in (2, 8):
            pk = [packet_flits("OS", "SC", kind)]
        elif s == "IC" and o == 3:
            pk = [packet_flits("IC", "SC", kind)]
        elif s == "IC" and o == 5:
            pk = [packet_flits("IC", "OS", kind)]
        elif s == "SC" and o == 6:
            pk = [packet_flits("SC", "OS", kinds[rays["kind"][c]]) for c in np.flatnonzero(rays["parent"] == r)]
        send = sum(k("send_packet") + f * k("send_flit") for f in pk)
        out.append((proc, recv, send, sum(pk)))
    return np.array(out, dtype=np.int64)


@pytest.mark.parametrize("scene", ["balls-g9", "mount-g4", "rings-g9", "tree-g4", "gears-g9"])
def test_visit_costs_match_a_per_visit_loop(scene):
    tr = mprt.load_trace(os.path.join(GOLDEN, scene + ".npz"))
    cm = CostModel({"int": 1, "fadd": 2, "fmul": 3, "fdiv": 11, "load": 2, "store": 1, "branch": 2},
                   {"OS": 3, "IC": 5, "SC": 7})
    procs = {"OS": ProcessorConfig.paper("OS"), "IC": ProcessorConfig.paper("IC"), "SC": ProcessorConfig.sequential()}
    n = 400
    vc = cm.visit_costs(tr, procs, chunk=97)   # chunk edges inside rays
    ref = _loop_costs(tr, cm, procs, n)
    got = np.stack([vc.process[:n], vc.receive[:n], vc.send[:n], vc.flits[:n]], axis=1)
    assert np.array_equal(got, ref)
    for a in (vc.process, vc.receive, vc.send):
        assert a.dtype == np.int64 and len(a) == len(tr.visits)
    assert vc.flits.dtype == np.int32
    again = cm.visit_costs(tr, procs)
    for f in ("process", "receive", "send", "flits"):
        assert np.array_equal(getattr(vc, f), getattr(again, f))
    # every visit does some work and reads its packet; a packet leaves unless the ray retires
    assert (vc.process > 0).all() and (vc.receive > 0).all()
    retire = np.isin(tr.visits["outcome"], (1, 4, 7)) | ((tr.visits["outcome"] == 6) & (tr.visits["made"] == 0))
    assert np.array_equal(vc.send == 0, retire)
    assert vc.inject_flits == packet_flits("SC", "OS", "primary")


def test_kernel_counts_agree_with_trace_stats_and_visit_costs():
    tr = mprt.load_trace(os.path.join(GOLDEN, "rings-g9.npz"))
    st = tr.stats()
    cm = CostModel.nominal()
    c = cm.kernel_counts(tr)
    assert c["units"] == {"voxels": st["voxels_traversed"], "tests": st["tests"], "sc_input": st["sc_input"]}
    assert c["stages"]["OS"]["os_setup"] == st["rays"]
    assert c["stages"]["SC"]["sc_shadow"] == st["sc_made_shadow"]
    assert c["stages"]["IC"]["ic_cylinder"] == st["tests_by_kind"]["cylinder"]
    # the counts times the sequential kernel cycles are the visits' processing, stage by stage
    seq = ProcessorConfig.sequential()
    vc = cm.visit_costs(tr, {s: seq for s in ("OS", "IC", "SC")})
    for s, code in (("OS", 0), ("IC", 1), ("SC", 2)):
        counts = dict(c["stages"][s])
        visits = counts.pop("visits")
        counts.pop("sc_primary", None)
        expect = visits * cm.visit_overhead[s] + sum(n * cm.kernel_cycles(k, seq) for k, n in counts.items())
        assert int(vc.process[tr.visits["stage"] == code].sum()) == expect


# ---- calibration and the shipped model ------------------------------------------------

from mprt.cost import calibrate as cal  # noqa: E402


def test_shipped_model_reproduces_its_stored_residuals_on_the_shipped_counts():
    model = CostModel.default()
    stored = {(s, g, st): (p, o) for s, g, st, p, o in model.info["residuals"]}
    rows = cal.read_counts()
    assert {(r["scene"], r["grid"]) for r in rows} == {(s, n) for s in cal.SCENES for n in cal.SUBDIVISIONS}
    got = cal.residuals_of(model, rows)
    assert len(got) == len(stored) == 45
    for r in got:
        p, o = stored[(r.scene, r.grid, r.stage)]
        assert r.paper == p == cal.PAPER[r.scene][r.stage][cal.SUBDIVISIONS.index(r.grid)]
        assert r.ours == pytest.approx(o, abs=1e-3)


def test_a_cell_recomputed_by_hand_from_its_counts():
    # OS per voxel of balls n=50: (set-ups x set-up + steps x step + visits x
    # dispatch + late hits x finalisation + visits x overhead) / voxels, on the
    # sequential processor of model M.
    model = CostModel.default()
    row = next(r for r in cal.read_counts() if r["scene"] == "balls" and r["grid"] == 50)
    seq = ProcessorConfig.sequential()
    k = lambda name: model.kernel_cycles(name, seq)  # noqa: E731
    os_total = (row["OS:os_setup"] * k("os_setup") + row["OS:os_step"] * k("os_step")
                + row["OS:os_visit"] * k("os_visit") + row["OS:visits"] * model.visit_overhead["OS"]
                + sum(row[f"OS:ic_hit_{p}"] * k(f"ic_hit_{p}") for p in ("sphere", "polygon", "cylinder", "cone")))
    mine = next(r for r in cal.residuals_of(model, [row]) if r.stage == "OS")
    assert mine.ours == pytest.approx(os_total / row["voxels"])
    # the counts agree with the units the averages are per
    assert row["OS:os_step"] == row["voxels"]
    assert row["IC:ic_sphere"] + row["IC:ic_polygon"] + row["IC:ic_cylinder"] + row["IC:ic_cone"] == row["tests"]
    assert row["SC:visits"] == row["sc_input"]


def test_refitting_the_shipped_counts_gives_the_shipped_model():
    shipped = CostModel.default()
    model, residuals = CostModel.calibrate()
    assert (model.latency, model.visit_overhead, model.scale) == (shipped.latency, shipped.visit_overhead,
                                                                 shipped.scale)
    assert len(residuals) == 45


def test_calibrating_on_balls_fits_balls_better_and_predicts_the_rest():
    rows = cal.read_counts()
    balls, _ = cal.fit(rows, scenes=["balls"])
    allfit = CostModel.default()
    rms = lambda m, scene: np.sqrt(np.mean([r.rel ** 2 for r in cal.residuals_of(m, rows)  # noqa: E731
                                            if r.scene == scene]))
    assert rms(balls, "balls") < rms(allfit, "balls")
    # balls only has spheres: its fit cannot see what makes cylinders and cones
    # dear, so it predicts rings and tree worse than the fit that saw them
    assert rms(balls, "rings") > rms(allfit, "rings") and rms(balls, "tree") > rms(allfit, "tree")
    with pytest.raises(CostModelError, match="unknown scene 'gears'"):
        cal.fit(rows, scenes=["gears"])


def test_free_stage_scales_fit_better_than_latencies_alone():
    rows = cal.read_counts()
    fixed, res_fixed = cal.fit(rows, free_scale=False)
    assert fixed.scale == {"OS": 100, "IC": 100, "SC": 100}
    free = cal.residuals_of(CostModel.default(), rows)
    assert sum(r.rel ** 2 for r in free) < sum(r.rel ** 2 for r in res_fixed)


def test_calibration_inputs_are_checked(tmp_path):
    tr = mprt.load_trace(os.path.join(GOLDEN, "balls-g4.npz"))
    with pytest.raises(CostModelError, match="balls:1.*default sizes"):
        cal.counts_row(tr)
    bad = tmp_path / "counts.csv"
    bad.write_text("scene,grid\nballs,20\n")
    with pytest.raises(CostModelError, match=r"counts\.csv: columns missing: width"):
        cal.read_counts(bad)
    rows = cal.read_counts()
    cal.write_counts(rows, tmp_path / "c.csv")
    text = (tmp_path / "c.csv").read_text().splitlines()
    text[3] = text[3].replace(",", ",x", 1)
    (tmp_path / "c.csv").write_text("\n".join(text) + "\n")
    with pytest.raises(CostModelError, match=r"c\.csv, line 4: a count is not a whole number"):
        cal.read_counts(tmp_path / "c.csv")


def test_model_files_load_and_are_checked(tmp_path):
    m = CostModel({c: 2 for c in OP_CLASSES}, {"OS": 1, "IC": 2, "SC": 3}, {"OS": 50, "IC": 100, "SC": 150})
    m.save(tmp_path / "m.json")
    back = CostModel.load(tmp_path / "m.json")
    assert (back.latency, back.visit_overhead, back.scale) == (m.latency, m.visit_overhead, m.scale)
    (tmp_path / "m.toml").write_text('[latency]\nint = 1\nfadd = 1\nfmul = 1\nfdiv = 9\nload = 1\nstore = 1\n'
                                     'branch = 1\n[scale]\nIC = 40\n')
    t = CostModel.load(tmp_path / "m.toml")
    assert t.latency["fdiv"] == 9 and t.scale == {"OS": 100, "IC": 40, "SC": 100}
    # the scale applies to the stage's kernels, rounded half up, not to packets
    seq = ProcessorConfig.sequential()
    base = CostModel(t.latency)
    assert t.kernel_cycles("ic_sphere", seq) == (base.kernel_cycles("ic_sphere", seq) * 40 + 50) // 100
    assert t.kernel_cycles("send_flit", seq) == base.kernel_cycles("send_flit", seq)
    (tmp_path / "b.toml").write_text('[latency]\nint = 1\n[scales]\nIC = 40\n')
    with pytest.raises(CostModelError, match=r"b\.toml: unknown field 'scales'"):
        CostModel.load(tmp_path / "b.toml")
    (tmp_path / "c.toml").write_text('[latency]\nint = 1\n')
    with pytest.raises(CostModelError, match=r"c\.toml\.latency: operation class 'fadd' is missing"):
        CostModel.load(tmp_path / "c.toml")
