# mprt: C library, C tests, Python package, demo and benchmark.
CC ?= gcc
PYTHON ?= python3
# The project's virtual environment: created once with $(PYTHON) and reused,
# so the same commands work with Debian's own python3 (PEP 668), pyenv and CI.
VENV ?= .venv
PY := $(VENV)/bin/python
B ?= build
# Warnings are errors: the library and its tests build clean under all of these.
WARN = -std=c99 -pedantic -Wall -Wextra -Wshadow -Wstrict-prototypes -Wmissing-prototypes -Wconversion -Werror
# -ffp-contract=off: no fused multiply-add, so the watertight edge tests stay
# exactly antisymmetric and results do not depend on the compiler's choices.
OPT ?= -O2 -g
CFLAGS = $(OPT) $(WARN) $(EXTRA) -ffp-contract=off -D_POSIX_C_SOURCE=200809L -Ic/include -Ic/src
LDLIBS = -lm -lpthread $(EXTRA_LD)

SRC := $(wildcard c/src/*.c)
HDR := c/include/mprt.h $(wildcard c/src/*.h)
TESTS := $(patsubst tests/c/%.c,$(B)/%,$(wildcard tests/c/test_*.c))

.PHONY: all test ctest pytest demo bench asan asan-py tsan single clean install fuzz fuzz-replay fuzz-lib fuzz-nff fuzz-machine fuzz-python \
	baselines baselines-update

all: $(B)/libmprt.a $(TESTS)

$(B)/obj/%.o: c/src/%.c $(HDR)
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -c $< -o $@

$(B)/libmprt.a: $(patsubst c/src/%.c,$(B)/obj/%.o,$(SRC))
	ar rcs $@ $^

$(B)/test_%: tests/c/test_%.c $(B)/libmprt.a $(wildcard tests/c/*.h)
	$(CC) $(CFLAGS) $< $(B)/libmprt.a -o $@ $(LDLIBS)

# The grid's build against the plain one kept in the tests (tests/c/grid_reference.c).
$(B)/test_grid_build: tests/c/test_grid_build.c tests/c/grid_reference.c $(B)/libmprt.a $(wildcard tests/c/*.h)
	$(CC) $(CFLAGS) $< tests/c/grid_reference.c $(B)/libmprt.a -o $@ $(LDLIBS)

# The usage example of mprt.h: the indented lines of its "Usage" comment,
# compiled as they stand by test_header_example.c.
$(B)/header_example.inc: c/include/mprt.h
	@mkdir -p $(dir $@)
	sed -n '/^ \* Usage/,/^ \* Limitations:/s/^ \*     //p' $< > $@

$(B)/test_header_example: tests/c/test_header_example.c $(B)/header_example.inc $(B)/libmprt.a tests/c/check.h
	$(CC) $(CFLAGS) -I$(B) $< $(B)/libmprt.a -o $@ $(LDLIBS)

# C tests run from tests/c (they read ../data/spd-reference).
ctest: $(TESTS)
	@set -e; for t in $(TESTS); do (cd tests/c && ../../$$t); done

$(PY):
	@$(PYTHON) -m venv $(VENV) || { echo "could not create $(VENV): on Debian, apt-get install python3-venv" >&2; exit 1; }
	$(PY) -m pip install -q --upgrade pip

# The Python package (editable) in the venv, rebuilt when a C or build file changes; ./mprt runs
# the venv's mprt from anywhere (no activation needed).
install: $(VENV)/.installed mprt
$(VENV)/.installed: $(PY) $(SRC) $(HDR) python/mprt/_build.py pyproject.toml setup.py
	$(PY) -m pip install -q -e '.[test]'
	@touch $@

mprt: $(VENV)/.installed
	@printf '#!/bin/sh\n# made by make install: the mprt command of this checkout'"'"'s virtual environment\nexec $(if $(filter /%,$(VENV)),"$(VENV)","$$(dirname "$$0")/$(VENV)")/bin/mprt "$$@"\n' > $@
	@chmod +x $@
	@echo "./mprt runs mprt from $(VENV) (or: . $(VENV)/bin/activate, then mprt)"

pytest: $(VENV)/.installed mprt
	$(PY) -m pytest -q tests

test: ctest pytest fuzz-replay baselines

# The replays pinned as a hardware team would pin its designs (README, "Pinning a design in CI"):
# two golden traces, each against its baseline; exit 3 names the stage that moved.  After a change
# meant to move them: make baselines-update.
BASELINES = tetra-g4:M balls-g9:3mppe
baselines: $(VENV)/.installed
	@set -e; for b in $(BASELINES); do t=$${b%%:*}; m=$${b##*:}; \
	    $(PY) -m mprt simulate tests/data/golden/$$t.npz --model $$m \
	        --baseline tests/data/golden/baselines/$$t.$$m.json --tolerance 0 > /dev/null; \
	    echo "baseline $$t on $$m: unchanged"; done

baselines-update: $(VENV)/.installed
	@set -e; for b in $(BASELINES); do t=$${b%%:*}; m=$${b##*:}; \
	    $(PY) -m mprt simulate tests/data/golden/$$t.npz --model $$m \
	        --json tests/data/golden/baselines/$$t.$$m.json > /dev/null; done

demo: $(VENV)/.installed mprt
	$(PY) -m mprt explore balls gears mount rings tetra tree --res 32x32 --budget 800 --plot explore.png \
		--json explore.json --machine-out explore-machine.toml

# make bench: this checkout against BEFORE (a git revision, default main), built
# from a clean export into $(B)/before; BEFORE= (empty) benchmarks this checkout alone.
# Where setup.py cannot build the export (a setuptools that rejects its pyproject.toml),
# the extensions are compiled with cffi directly, as asan-py does.
BEFORE ?= main
bench: $(VENV)/.installed
	@$(PY) -m pip install -q embreex || echo "make bench: embreex could not be installed; the bench runs without the Embree columns" >&2
	@if [ -n "$(BEFORE)" ]; then \
	    rm -rf $(B)/before && mkdir -p $(B)/before && git archive $(BEFORE) | tar -x -C $(B)/before && \
	    (cd $(B)/before && { $(abspath $(PY)) setup.py -q build_ext --inplace > build_ext.log 2>&1 || \
	        { ln -sfn ../c python/c && $(abspath $(PY)) -c "import sys; sys.path.insert(0, 'python/mprt'); import _build; \
	        [getattr(_build, f).compile(tmpdir='python') for f in ('ffi', 'ffi32') if hasattr(_build, f)]" >> build_ext.log 2>&1; }; }) || \
	    { echo "could not build $(BEFORE) in $(B)/before (see $(B)/before/build_ext.log)" >&2; exit 1; }; fi
	$(PY) studies/03_bench/run.py $(if $(BEFORE),--before $(B)/before/python) $(BENCH_ARGS)
	$(PY) studies/03_bench/embree.py $(if $(BEFORE),--before $(B)/before/python)

# The C tests under AddressSanitizer and UndefinedBehaviorSanitizer.
asan:
	$(MAKE) B=build/asan OPT="-O1 -g" EXTRA="$(SAN)" \
	    EXTRA_LD="-fsanitize=address,undefined" ctest

# The compiled replay's differential tests (against SimPy, levels 1 to 3, the ring and the
# memories alone and together) with the C library
# under ASan and UBSan: the extension built into build/asan-py beside a copy of the package
# (--capture=sys: a sanitizer's report, written to the descriptor, is seen when it stops the run);
# test_lifetimes.py, the C objects' destruction in the orders Python may collect them; and the
# trace writer's tests (records copied and renumbered at any byte offset, on threads).
asan-py: $(VENV)/.installed
	rm -rf build/asan-py && mkdir -p build/asan-py && cp -r python/mprt build/asan-py/ && rm -f build/asan-py/mprt/*.so
	ln -s ../../c build/asan-py/c      # (cffi compiles in its tmpdir, with paths relative to the root)
	CFLAGS="$(SAN) -O1 -g" LDFLAGS="-fsanitize=address,undefined" $(PY) -c \
	    "import sys; sys.path.insert(0, 'python/mprt'); import _build; \
	    [f.compile(tmpdir='build/asan-py', verbose=True) for f in (_build.ffi, _build.ffi32)]" \
	    > build/asan-py/build.log 2>&1
	cd tests && ASAN_OPTIONS=detect_leaks=0 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
	    LD_PRELOAD="$$($(CC) -print-file-name=libasan.so) $$($(CC) -print-file-name=libubsan.so)" \
	    PYTHONPATH=../build/asan-py ../$(PY) -m pytest -q --capture=sys -p no:cacheprovider test_fidelity_full.py \
	    test_fidelity_memory.py test_fidelity_ring.py test_fidelity.py test_compiled_priced.py test_recordcheck.py \
	    test_lifetimes.py test_compiled_threads.py test_simulate_fused.py test_tracecheck_split.py \
	    test_work_bound.py test_trace_write.py test_trace_buffers.py

# The fuzz target over NFF parse, write, grids, renders and intersection
# (tests/fuzz/fuzz_nff.c), replayed on its seed corpus and on every input
# that ever failed, with gcc and the sanitizers of make asan (part of make
# test; no clang needed).
SAN = -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all
# The second target, tests/fuzz/fuzz_machine.c, builds machine configurations and
# ray-tree traces (well formed, then damaged) from its input and replays them on
# the compiled replay, at levels 1 to 3 (the ring, the memories, both); its corpus and failures are tests/fuzz/corpus_machine and
# tests/fuzz/crashes_machine.
FUZZ_SRC = tests/fuzz/fuzz_nff.c
fuzz-replay:
	@$(MAKE) -s B=build/asan OPT="-O1 -g" EXTRA="$(SAN)" EXTRA_LD="-fsanitize=address,undefined" \
	    build/asan/fuzz_replay build/asan/fuzz_machine_replay
	build/asan/fuzz_replay tests/fuzz/corpus tests/fuzz/crashes
	build/asan/fuzz_machine_replay tests/fuzz/corpus_machine tests/fuzz/crashes_machine

$(B)/fuzz_replay: $(FUZZ_SRC) tests/fuzz/replay.c $(B)/libmprt.a
	$(CC) $(CFLAGS) $(FUZZ_SRC) tests/fuzz/replay.c $(B)/libmprt.a -o $@ $(LDLIBS)

$(B)/fuzz_machine_replay: tests/fuzz/fuzz_machine.c tests/fuzz/replay.c $(B)/libmprt.a
	$(CC) $(CFLAGS) tests/fuzz/fuzz_machine.c tests/fuzz/replay.c $(B)/libmprt.a -o $@ $(LDLIBS)

# make fuzz: every fuzz target in turn, FUZZ_TIME seconds each (default 60): the C targets
# under libFuzzer with Debian's clang (apt-get install clang) and the sanitizers, then the
# Python one under Atheris.  Each starts from its seed corpus in tests/fuzz; new inputs go to
# build/fuzz/corpus*, failing ones to build/fuzz/found* (fix, then copy them into the
# matching tests/fuzz/crashes* directory: make test replays them).  One target alone:
# make fuzz-nff, fuzz-machine or fuzz-python; FUZZ_ARGS adds libFuzzer flags (-jobs=N ...).
FUZZ_TIME ?= 60
FUZZ_CC ?= clang
FUZZ_ARGS ?=
FUZZ_FLAGS = -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all
fuzz: fuzz-nff fuzz-machine fuzz-python

fuzz-lib:
	@command -v $(FUZZ_CC) >/dev/null || { echo "make fuzz needs clang: apt-get install clang" >&2; exit 1; }
	$(MAKE) B=build/fuzz CC=$(FUZZ_CC) OPT="-O1 -g" WARN="-std=c99" \
	    EXTRA="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=all" build/fuzz/libmprt.a

# The NFF parser, grids, renders, intersection (tests/fuzz/fuzz_nff.c).
fuzz-nff: fuzz-lib
	$(FUZZ_CC) -O1 -g -std=c99 -ffp-contract=off -D_POSIX_C_SOURCE=200809L -Ic/include -Ic/src \
	    $(FUZZ_FLAGS) $(FUZZ_SRC) build/fuzz/libmprt.a -lm -lpthread -o build/fuzz/fuzz_nff
	@mkdir -p build/fuzz/corpus build/fuzz/found
	build/fuzz/fuzz_nff -dict=tests/fuzz/nff.dict -max_total_time=$(FUZZ_TIME) -timeout=10 -print_final_stats=1 \
	    -artifact_prefix=build/fuzz/found/ $(FUZZ_ARGS) build/fuzz/corpus tests/fuzz/corpus

# The compiled replay's load and run (tests/fuzz/fuzz_machine.c): configurations, and trace
# arrays made, damaged or given as raw bytes.
fuzz-machine: fuzz-lib
	$(FUZZ_CC) -O1 -g -std=c99 -D_POSIX_C_SOURCE=200809L -Ic/include -Ic/src \
	    $(FUZZ_FLAGS) tests/fuzz/fuzz_machine.c build/fuzz/libmprt.a -lm -lpthread -o build/fuzz/fuzz_machine
	@mkdir -p build/fuzz/corpus_machine build/fuzz/found_machine
	build/fuzz/fuzz_machine -max_total_time=$(FUZZ_TIME) -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
	    -artifact_prefix=build/fuzz/found_machine/ $(FUZZ_ARGS) build/fuzz/corpus_machine tests/fuzz/corpus_machine

# Atheris over the Python input surfaces (machine configurations, design spaces, sweep
# specs, trace files into stats --check and both engines: tests/fuzz/fuzz_inputs.py); its
# corpus replays in make test (tests/test_fuzz_inputs.py).  Atheris is installed into the
# venv here, not by make test.
fuzz-python: $(VENV)/.installed
	$(PY) -m pip install -q atheris
	@mkdir -p build/fuzz/corpus_inputs build/fuzz/found_inputs
	$(PY) tests/fuzz/fuzz_inputs.py -max_total_time=$(FUZZ_TIME) -rss_limit_mb=2048 -timeout=20 \
	    -print_final_stats=1 -artifact_prefix=build/fuzz/found_inputs/ $(FUZZ_ARGS) build/fuzz/corpus_inputs \
	    tests/fuzz/corpus_inputs

# The C tests under ThreadSanitizer (threaded renders, concurrent tile traces).
tsan:
	$(MAKE) B=build/tsan OPT="-O1 -g" EXTRA="-fsanitize=thread" EXTRA_LD="-fsanitize=thread" ctest

# The C tests with float geometry (MPRT_SINGLE).
single:
	$(MAKE) B=build/single EXTRA="-DMPRT_SINGLE" ctest

clean:
	rm -rf build
