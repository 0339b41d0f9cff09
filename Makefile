# penumbra — the two commands are `make run` and `make test`.
SHELL := /bin/bash
CARGO ?= cargo
BIN := target/release/penumbra
# Debian packages the build and the tests need (fonts-dejavu-core: the
# font of `penumbra bench --plot`; the build itself does not need it).
APT_PACKAGES := libembree-dev libclang-dev xvfb xauth fonts-dejavu-core

.PHONY: run test deps build lint bench bench-quick fit-ltc clean

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

test: deps
	$(CARGO) test --release

lint: deps
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --release --all-targets -- -D warnings

# Criterion micro-benchmarks, then speed against error on the shipped scenes
# (references are cached under target/penumbra-cache; the first run renders them).
bench: build
	$(CARGO) bench
	$(BIN) bench --json target/bench.json --plot docs/speed-vs-error.png

# The smoke run: seconds, small frames, a cheap reference.
bench-quick: build
	$(BIN) bench --quick --json target/bench-quick.json

fit-ltc: build
	$(BIN) fit-ltc --size 64 --out data/ltc_64.bin --heatmap docs/ltc-fit-error.png

clean:
	$(CARGO) clean
