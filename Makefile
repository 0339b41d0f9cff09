# penumbra — the two commands are `make run` and `make test`.
SHELL := /bin/bash
CARGO ?= cargo
BIN := target/release/penumbra
# Debian packages the build and the tests need (fonts-dejavu-core: the font of
# `penumbra bench --plot`; the build does not need it).
APT_PACKAGES := libembree-dev libclang-dev xvfb xauth fonts-dejavu-core

.PHONY: run test test-embree4 deps build lint bench bench-quick profile profile-wall fit-ltc clean fuzz memcheck longrun golden-bless peer-denoise

# No target CPU is forced: one build runs on any x86-64 CPU, and its hot
# loops pick AVX-512, AVX2 or baseline at run time (crates/isa/src/lib.rs;
# PENUMBRA_ISA=baseline|avx2|avx512 caps the level).

# Installs missing Debian packages when root or sudo is available.
deps:
	@missing=""; for p in $(APT_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then SUDO=""; elif command -v sudo >/dev/null; then SUDO="sudo"; \
	  else echo "missing packages:$$missing (install them with apt-get as root)"; exit 1; fi; \
	  echo "installing:$$missing"; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing >/dev/null; \
	fi

build: deps
	$(CARGO) build --release

# Opens the viewer on the built-in scene; without a display, renders it to a PNG.
run: build
	@if [ -n "$$DISPLAY$$WAYLAND_DISPLAY" ]; then $(BIN) view; \
	else mkdir -p out && $(BIN) render --frames 16 --out out/default.png && echo "no display: rendered the built-in scene to out/default.png"; fi

# Every crate's tests: unit tests, each crate's tests/ (the renderer's in
# tests/integration/, the binding's in crates/embree/tests/) and doc tests.
test: deps
	$(CARGO) test --release --workspace

# The Embree 4 leg (docs/embree.md): fetches Embree 4 into target/embree4,
# builds against it in the same target dir (only the crates above the
# binding are built again), runs the binding's tests against it and checks
# every shipped scene's frames against the Embree 3 build's.
test-embree4: deps
	scripts/embree4-test.sh

lint: deps
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --release --workspace --all-targets -- -D warnings

# Criterion micro-benchmarks (numbers only: the benches turn criterion's HTML
# plots off, which panicked for want of a font), then speed against error on the shipped scenes,
# and the many-light hall against its first two lights
# (references are cached under target/penumbra-cache; the first run renders them).
bench: build
	$(CARGO) bench
	$(BIN) bench --json target/bench.json --plot docs/speed-vs-error.png
	$(BIN) bench scenes/hall.toml --light-subset 0,1 --only "ratio+dn,ratio+dn 1/4,unshadowed" \
	  --spp 1 --width 640 --height 360 --json target/bench-hall.json

# The smoke run: seconds, small frames, a cheap reference.
bench-quick: build
	$(BIN) bench --quick --json target/bench-quick.json

# Instructions per pixel per frame, stage by stage: callgrind on a fixed
# small render (valgrind runs the AVX2 level; scripts/valgrind.sh fetches a
# valgrind that decodes it), counted inside Frame::render
# only, turned into a table by scripts/profile.py (docs/performance.md,
# "Instruction profile"). The same binary gives the same counts on any load.
PROFILE_WIDTH := 320
PROFILE_HEIGHT := 180
PROFILE_FRAMES := 4
PROFILE_SCENE ?= scenes/room.toml
profile: build
	mkdir -p target/profile
	scripts/valgrind.sh --tool=callgrind --callgrind-out-file=target/profile/callgrind.out \
	  --toggle-collect='*Frame*::render' \
	  $(BIN) render $(PROFILE_SCENE) --width $(PROFILE_WIDTH) --height $(PROFILE_HEIGHT) \
	  --threads 1 --frames $(PROFILE_FRAMES) --orbit 1 --out target/profile/frame.exr
	scripts/profile.py target/profile/callgrind.out $$(($(PROFILE_WIDTH) * $(PROFILE_HEIGHT))) \
	  $(PROFILE_FRAMES) --json target/profile/profile.json

# Where the time goes, kernel by kernel: perf samples of a full-size render
# at this CPU's own level, each attributed to the line that opened its
# kernel by scripts/wall_profile.py (docs/performance.md, "The wall clock,
# kernel by kernel"). What `profile` cannot see: time spent waiting.
WALL_FRAMES := 12
profile-wall: build
	@command -v perf >/dev/null || { echo "profile-wall needs perf: apt-get install linux-perf"; exit 1; }
	mkdir -p target/profile
	perf record -F 2000 -o target/profile/perf.data $(BIN) render $(PROFILE_SCENE) \
	  --frames $(WALL_FRAMES) --out target/profile/wall.exr
	scripts/wall_profile.py target/profile/perf.data $(BIN)

# The denoiser beside Open Image Denoise on penumbra's own raw 1-spp frames
# (albedo and normal AOVs as its guides): relMSE, speckles and ms on room,
# shadow-plane and the built-in scene, first frame, after a camera cut and
# after 16 frames (docs/first-frame.md). OIDN comes from PyPI (pyoidn) into a
# virtual environment under target/, a development tool only.
PEER_VENV := target/peer-venv
PEER_ARGS ?=
peer-denoise: build
	@test -x $(PEER_VENV)/bin/python || python3 -m venv $(PEER_VENV)
	@$(PEER_VENV)/bin/python -c "import pyoidn, numpy, OpenEXR" 2>/dev/null || \
	  $(PEER_VENV)/bin/pip install -q pyoidn==2.5.1.0 numpy OpenEXR
	$(PEER_VENV)/bin/python scripts/peer_denoise.py --bin $(BIN) $(PEER_ARGS)

fit-ltc: build
	$(BIN) fit-ltc --size 64 --out data/ltc_64.bin --heatmap docs/ltc-fit-error.png

clean:
	$(CARGO) clean

# Fuzzes the scene loader (TOML + OBJ + image map, see fuzz/fuzz_targets/) for
# FUZZ_SECONDS. cargo-fuzz passes nightly-only flags (-Zsanitizer, -Cpasses=
# sancov-module); RUSTC_BOOTSTRAP=1 lets this machine's stable toolchain accept
# them. FUZZ_SANITIZER=none by default: the loader has no unsafe code, so
# AddressSanitizer adds cost and no findings (`make fuzz FUZZ_SANITIZER=address`
# works too). Debug assertions stay on, so integer overflow is a finding.
# New inputs go to fuzz/corpus/ (ignored); seeds live in fuzz/seeds/.
FUZZ_SECONDS ?= 120
FUZZ_SANITIZER ?= none
FUZZ_FLAGS ?= -max_len=16384 -timeout=30 -rss_limit_mb=4096
fuzz: deps
	@command -v cargo-fuzz >/dev/null || $(CARGO) install cargo-fuzz --locked
	mkdir -p fuzz/corpus/scene_loader
	RUSTC_BOOTSTRAP=1 nice -n 19 $(CARGO) fuzz run --sanitizer $(FUZZ_SANITIZER) scene_loader \
	  fuzz/corpus/scene_loader fuzz/seeds/scene_loader -- -max_total_time=$(FUZZ_SECONDS) $(FUZZ_FLAGS)

# Small renders under valgrind memcheck: any invalid read or write, or leak
# definitely lost, in any code fails the run (--error-exitcode). No
# suppressions are needed with Debian's Embree 3.13 / TBB (see docs/robustness.md).
VALGRIND := scripts/valgrind.sh --tool=memcheck --error-exitcode=99 --errors-for-leak-kinds=definite --leak-check=full --track-origins=yes --num-callers=30
# valgrind runs no AVX-512 and reports none to the program, whose hot loops
# then run their AVX2 (or baseline) code: the same build serves.
memcheck: build
	mkdir -p out
	nice -n 19 $(VALGRIND) $(BIN) render --width 24 --height 16 --frames 2 --threads 2 --spp 2 --out out/memcheck.png
	nice -n 19 $(VALGRIND) $(BIN) render scenes/room.toml --mode reference --width 16 --height 12 --frames 2 --spp 2 --threads 2 --aov albedo,normal,depth,u,un,sn,ratio --out out/memcheck-room.exr

# Long runs with flat memory (not in `make test`): 5000 frames of `render` and
# of the scripted viewer under Xvfb, at a small size; scripts/longrun.sh samples
# VmRSS/VmHWM from /proc and fails if resident memory grows by more than
# LONGRUN_BOUND_KIB between the first frames and the last.
LONGRUN_FRAMES ?= 5000
LONGRUN_BOUND_KIB ?= 8192
longrun: build
	mkdir -p out
	scripts/longrun.sh "render --frames $(LONGRUN_FRAMES)" $(LONGRUN_BOUND_KIB) \
	  $(BIN) render --frames $(LONGRUN_FRAMES) --width 64 --height 36 --out out/longrun.png
	scripts/longrun.sh "view --frames $(LONGRUN_FRAMES) (Xvfb)" $(LONGRUN_BOUND_KIB) \
	  xvfb-run -a $(BIN) view --frames $(LONGRUN_FRAMES) --width 64 --height 36 --screenshot out/longrun-view.png

# Re-renders every golden frame of tests/integration/golden.rs into tests/golden/ (after a
# change to the frames that is meant); `make test` compares against them.
golden-bless: deps
	PENUMBRA_GOLDEN_BLESS=1 $(CARGO) test --release --test integration -- golden::every_mode_on_every_shipped_scene
