# wrc — two commands on a fresh machine:
#   make run    the main job: the controller with a simulated board and the web GUI (wrc up)
#   make test   every test (Rust, fuzz, web unit tests, the browser end-to-end test), lint and
#               format check
# Also: make faults   the fault-injection campaign (wrc bench faults: kill -9 of the board, the
#               controller and the GUI, E-stop, vacuum loss, following error, serial garbage
#               and unplugging, a client dropping mid-command, a full or read-only state
#               directory, corrupt state files), FAULT_ROUNDS injections of each kind at
#               seeded random moments, on loopback and temporary directories only, at most
#               FAULT_MINUTES (default 5 rounds, 10 minutes); its table is in the README
#       make soak     10 minutes (SOAK_SECONDS) of random valid and invalid requests from 4
#               clients while the robot moves at the 10 ms servo period, then 60 s
#               (SOAK_1KHZ_SECONDS) at 1 ms idle and 60 s at 1 ms under stress-ng (wrc bench
#               soak: underruns, watchdog and following-error trips, lost pulses, the Pulse
#               Generator beside cyclictest); make fuzz: every fuzz target for FUZZ_SECONDS (300)
# Toolchains present on the machine (cargo) are assumed; anything else is installed when
# missing (as root) or named with the command to install it.

SHELL := /bin/bash
CARGO ?= cargo
WRC := target/release/wrc
OUT ?= test-output

.PHONY: test-fuzz fuzz run test build check-toolchain check-node lint test-rust test-web test-e2e web bench bench-rt bench-controller bench-ui bench-gui bench-motion bench-stop soak faults demo clean

check-toolchain:
	@command -v $(CARGO) >/dev/null || { echo "wrc: cargo is missing; install Rust from https://rustup.rs"; exit 1; }

# The web app (web/, TypeScript + Vite): npm packages pinned by web/package-lock.json,
# installed when the lock file is newer than the install; built when a source is newer than
# the build. The wrc binary embeds web/dist when it exists at compile time.
check-node:
	@scripts/need.sh node nodejs
	@scripts/need.sh npm npm
	@node -e 'const [a,b]=process.versions.node.split(".").map(Number); process.exit(a>20||(a==20&&b>=19)?0:1)' || { echo "wrc: the web app (Vite 8) needs Node.js 20.19 or later; this is $$(node --version). Install a newer Node.js (https://nodejs.org) and retry"; exit 1; }

web/node_modules/.package-lock.json: web/package-lock.json web/package.json | check-node
	cd web && npm ci --no-audit --no-fund
	@touch $@

WEB_SOURCES := $(shell find web/src web/index.html web/vite.config.ts web/tsconfig.json -type f 2>/dev/null)
web/dist/index.html: web/node_modules/.package-lock.json $(WEB_SOURCES)
	cd web && npm run build
	@touch $@

web: web/dist/index.html

build: check-toolchain web
	$(CARGO) build --release --bin wrc

# The main job: the controller (the paper's eight real-time tasks) with a simulated motion
# board on the embedded default configuration, and the web GUI on http://127.0.0.1:8080.
# Host protocol on tcp 127.0.0.1:7100 (try `target/release/wrc send HOME` in another
# terminal), simulator datagrams to udp 127.0.0.1:7200. Ctrl-C stops the robot and the
# controller. `make run CONFIG=config/dual-blade.toml`: the same with the dual-blade robot,
# its state (wafer map, simulated cell) in /tmp/wrc-dual-blade, apart from the default's.
run: build
	$(WRC) up $(if $(CONFIG),--config $(CONFIG) --state-dir /tmp/wrc-$(basename $(notdir $(CONFIG))))

# The offline planning demo: the paper's Fig. 7 (PTP) and Fig. 8 (straight line) motions.
demo: build
	@mkdir -p $(OUT)
	$(WRC) plan ptp --from=-75,150,-75,0 --to=30,60,-90,100 --plot $(OUT)/ptp.svg > $(OUT)/ptp.csv
	$(WRC) plan line --from=300,-100,0,0 --to=300,150,0,0 --plot $(OUT)/line.svg > $(OUT)/line.csv
	@echo "wrc: PTP and straight-line plans written to $(OUT)/ptp.{csv,svg} and $(OUT)/line.{csv,svg}"

lint: check-toolchain
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings
	# The real-time controller without the simulator (wrc-controller's `sim` feature off).
	$(CARGO) clippy -p wrc-controller --no-default-features -- -D warnings

test-rust: check-toolchain
	$(CARGO) test --workspace

test: lint test-rust test-web test-fuzz

# The browser application: Vitest unit tests, a type-checked build, then the end-to-end test
# in a real headless Chromium (Debian's package, driven by @playwright/test; no browser
# download) against `wrc up` on free ports. Screenshots, the HTML report and, on failure, the
# trace, screenshot and controller output go to $(OUT)/gui/.
test-web: web
	cd web && npm test
	$(MAKE) test-e2e

test-e2e: web check-toolchain
	@scripts/need.sh chromium chromium fonts-dejavu-core
	$(CARGO) build --bin wrc
	@mkdir -p $(OUT)/gui
	cd web && WRC_BIN=$(CURDIR)/target/debug/wrc WRC_TEST_OUTPUT=$(CURDIR)/$(OUT)/gui npm run e2e

# Benchmarks (figures go into the README's performance section).
bench: check-toolchain
	$(CARGO) bench -p wrc-motion --bench velocity_generator
	$(CARGO) bench -p wrc-lang --bench compile
	$(CARGO) bench -p wrc-trace --bench trace
	$(CARGO) bench -p wrc-controller --bench cell_check

# Real-time runtime benchmark (docs/realtime.md): the paper's Tables 3-5 with cyclictest in
# the same run, idle and under load. Installs cyclictest (rt-tests) and stress-ng when root.
RT_SECONDS ?= 25
bench-rt: build
	@scripts/need.sh cyclictest rt-tests
	@scripts/need.sh stress-ng stress-ng
	@mkdir -p $(OUT)
	$(WRC) bench rt --seconds $(RT_SECONDS) --json $(OUT)/bench-rt.json
	$(WRC) bench rt --seconds $(RT_SECONDS) --load --json $(OUT)/bench-rt-load.json

# Controller benchmark: command-to-first-pulse and ESTOP-to-deceleration latencies, and the
# Pulse Generator's jitter idle and while 200 TCP clients poll STATUS.
bench-controller: build
	@mkdir -p $(OUT)
	$(WRC) bench controller --json $(OUT)/bench-controller.json

# The web GUI's cost on a PC without a graphics card (docs/gui.md, "What the GUI costs"): in
# Chromium's software renderer with the Simulator tab open on the demo cell, LP1 full, the
# page's CPU at rest and E-STOP press → ESTOP on the page's socket during GET/PUT transfers
# (median, p99, samples); BENCH_ESTOPS clicks (40), BENCH_REST_S seconds at rest (20), the
# controller at real-time priority (BENCH_RT=0: --no-rt). Figures printed and written to
# $(OUT)/gui/bench-gui.json.
bench-gui: build
	@scripts/need.sh chromium chromium fonts-dejavu-core
	@mkdir -p $(OUT)/gui
	cd web && WRC_BIN=$(CURDIR)/$(WRC) WRC_TEST_OUTPUT=$(CURDIR)/$(OUT)/gui npm run bench

# Straight lines against the time-optimal lower bound: 200 random reachable lines and 20 long
# ones (fixed seed), planned and run as the controller does; durations over the bound, limits
# used from the output pulses, accuracy, and what planning costs the Velocity Generator.
bench-motion: build
	@mkdir -p $(OUT)
	$(WRC) bench motion --json $(OUT)/bench-motion.json

# Stopping times and distances (ISO 10218-1 Annex B form): every axis and a straight line at
# 33, 66 and 100 % speed, stopped at peak acceleration and in cruise, ESTOP (full limits) and
# STOP (the move's limits), from the output pulses, against the 1-D time-optimal brake.
bench-stop: build
	@mkdir -p $(OUT)
	$(WRC) bench stop --json $(OUT)/bench-stop.json

# A sustained run: 10 minutes (SOAK_SECONDS) of random valid and invalid requests from 4
# clients while the robot moves at the default 10 ms servo period, then 60 s
# (SOAK_1KHZ_SECONDS) at 1 ms (1 kHz) idle and 60 s at 1 ms under `stress-ng --cpu 2 --vm 1
# --vm-bytes 256M`. Each run: no crash, every request answered, no descriptor or memory left
# behind, the Pulse Generator's latency at the end as at the start, and the servo goal: no
# underrun, no watchdog or following-error trip, no lost pulse (the board's count equals the
# controller's on every axis at rest); cyclictest runs beside the Pulse Generator at its
# priority and interval. Installs cyclictest (rt-tests) and stress-ng when root. Every run is
# made even when one before it failed; make soak fails if any did. make test runs 8 s and 6 s.
SOAK_SECONDS ?= 600
SOAK_1KHZ_SECONDS ?= 60
soak: build
	@scripts/need.sh cyclictest rt-tests
	@scripts/need.sh stress-ng stress-ng
	@mkdir -p $(OUT)
	status=0; \
	$(WRC) bench soak --seconds $(SOAK_SECONDS) --json $(OUT)/bench-soak.json || status=1; \
	$(WRC) bench soak --period-ms 1 --seconds $(SOAK_1KHZ_SECONDS) --json $(OUT)/bench-soak-1ms.json || status=1; \
	$(WRC) bench soak --period-ms 1 --seconds $(SOAK_1KHZ_SECONDS) --load --json $(OUT)/bench-soak-1ms-load.json || status=1; \
	exit $$status

# The GUI must not disturb control: the Pulse Generator's wake-up latency with no GUI, with
# wrc ui and browsers-worth of WebSocket clients attached, and after kill -9 of wrc ui.
bench-ui: build
	@mkdir -p $(OUT)
	$(WRC) bench ui --json $(OUT)/bench-ui.json

# Fault-injection campaign (README, "Faults"): every fault kind injected FAULT_ROUNDS times at
# random moments of a transfer or a move (seed FAULT_SEED), each round judged: detected (and
# how fast), stopped safely, wafer map consistent with the simulated cell, recovered. Free
# loopback ports and temporary directories only (never /tmp/wrc, 7100, 7200 or 8080); the
# full and read-only state directory run in a user and mount namespace of their own
# (util-linux's unshare and nsenter). Bounded by FAULT_MINUTES; exit 1 if any round failed.
FAULT_ROUNDS ?= 5
FAULT_SEED ?= 2026
FAULT_MINUTES ?= 10
faults: build
	@scripts/need.sh unshare util-linux
	@scripts/need.sh nsenter util-linux
	@mkdir -p $(OUT)
	$(WRC) bench faults --seed $(FAULT_SEED) --rounds $(FAULT_ROUNDS) --max-minutes $(FAULT_MINUTES) --json $(OUT)/faults.json

clean:
	$(CARGO) clean
	rm -rf $(OUT) web/dist

# Fuzzing (cargo-fuzz, libFuzzer): every reader of outside input, one fuzz crate per library
# crate (crates/<crate>/fuzz, outside the workspace, its own Cargo.lock). `make test-fuzz`, part
# of `make test`, runs each target for FUZZ_SECONDS (default 10); `make fuzz` runs each for
# FUZZ_SECONDS=300 (`make fuzz FUZZ_SECONDS=3600` for longer). A target starts from its
# committed seeds (fuzz/seeds/<target>/, from the docs' examples) and the inputs it kept
# before (fuzz/corpus/<target>/, not committed); a crash stops the run and leaves the input in
# fuzz/artifacts/<target>/ (libFuzzer's progress lines are left out of the output; its final
# statistics are kept). cargo-fuzz builds with sanitizers, which need nightly features:
# the nightly toolchain when installed, otherwise the stable one with RUSTC_BOOTSTRAP=1 (stable
# ships the sanitizer runtimes on x86_64 Linux). The fuzz crates share one build directory,
# target/fuzz. cargo-fuzz is installed from crates.io when missing.
FUZZ_SECONDS ?= 10
fuzz: FUZZ_SECONDS = 300
# <crate>:<target>[:<longest input in bytes, default 8192>]
FUZZ_TARGETS := \
  wrc-board:layout_reader \
  wrc-lang:compile \
  wrc-protocol:request \
  wrc-protocol:sim_stream \
  wrc-config:config \
  wrc-cell:stations \
  wrc-cell:wafer_map \
  wrc-cell:world \
  wrc-trace:trace_file:65536 \
  wrc-controller:upload
FUZZ_CARGO = $(if $(shell rustup toolchain list 2>/dev/null | grep '^nightly'),$(CARGO) +nightly,RUSTC_BOOTSTRAP=1 $(CARGO))
test-fuzz fuzz: check-toolchain
	@command -v cargo-fuzz >/dev/null || $(CARGO) install cargo-fuzz --locked
	@echo "wrc: fuzzing each target for $(FUZZ_SECONDS) s with $(FUZZ_CARGO)"
	@set -eo pipefail; for t in $(FUZZ_TARGETS); do \
	  IFS=: read -r crate target max_len <<< "$$t"; \
	  dir=crates/$$crate/fuzz; \
	  mkdir -p $$dir/corpus/$$target; \
	  echo "wrc: fuzzing $$crate $$target"; \
	  (cd $$dir && $(FUZZ_CARGO) fuzz run --target-dir $(CURDIR)/target/fuzz $$target \
	    corpus/$$target $$(test -d seeds/$$target && echo seeds/$$target) \
	    -- -max_total_time=$(FUZZ_SECONDS) -max_len=$${max_len:-8192} -print_final_stats=1 2>&1 \
	    | { grep -v -e '^#' -e '^INFO:' -e 'NEW_FUNC' -e ' # Uses: ' || true; }); \
	done
