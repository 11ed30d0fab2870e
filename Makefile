# wrc — two commands on a fresh machine:
#   make run    the main job: the controller with a simulated board (wrc up)
#   make test   every test, lint and format check
# Toolchains present on the machine (cargo) are assumed; anything else is installed when
# missing (as root) or named with the command to install it.

SHELL := /bin/bash
CARGO ?= cargo
WRC := target/release/wrc
OUT ?= test-output

.PHONY: test-fuzz run test build check-toolchain lint test-rust bench bench-rt bench-controller demo clean

check-toolchain:
	@command -v $(CARGO) >/dev/null || { echo "wrc: cargo is missing; install Rust from https://rustup.rs"; exit 1; }

build: check-toolchain
	$(CARGO) build --release --bin wrc

# The main job: the controller (the paper's eight real-time tasks) with a simulated motion
# board on the embedded default configuration. Host protocol on tcp 127.0.0.1:7100 (try
# `target/release/wrc send HOME` in another terminal), simulator datagrams to udp
# 127.0.0.1:7200. Ctrl-C stops the robot and the controller.
run: build
	$(WRC) up

# The offline planning demo: the paper's Fig. 7 (PTP) and Fig. 8 (straight line) motions.
demo: build
	@mkdir -p $(OUT)
	$(WRC) plan ptp --from=-75,150,-75,0 --to=30,60,-90,100 --plot $(OUT)/ptp.svg > $(OUT)/ptp.csv
	$(WRC) plan line --from=300,-100,0,0 --to=300,150,0,0 --plot $(OUT)/line.svg > $(OUT)/line.csv
	@echo "wrc: PTP and straight-line plans written to $(OUT)/ptp.{csv,svg} and $(OUT)/line.{csv,svg}"

lint: check-toolchain
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings

test-rust: check-toolchain
	$(CARGO) test --workspace

test: lint test-rust test-fuzz

# Benchmarks (figures go into the README's performance section).
bench: check-toolchain
	$(CARGO) bench -p wrc-motion --bench velocity_generator
	$(CARGO) bench -p wrc-lang --bench compile

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

clean:
	$(CARGO) clean
	rm -rf $(OUT)

# Fuzz for a bounded time each: the DPRAM layout reader (wrc-board) and the robot-language
# compiler and VM (wrc-lang). cargo-fuzz builds with sanitizers, which need nightly features:
# the nightly toolchain when installed, otherwise the stable one with RUSTC_BOOTSTRAP=1 (stable
# ships the sanitizer runtimes on x86_64 Linux). cargo-fuzz is installed from crates.io when
# missing.
FUZZ_SECONDS ?= 20
FUZZ_TARGETS := crates/wrc-board/fuzz:layout_reader crates/wrc-lang/fuzz:compile
test-fuzz: check-toolchain
	@command -v cargo-fuzz >/dev/null || $(CARGO) install cargo-fuzz --locked
	@set -e; for t in $(FUZZ_TARGETS); do \
	  dir=$${t%%:*}; target=$${t##*:}; \
	  if rustup toolchain list 2>/dev/null | grep -q '^nightly'; then \
	    echo "wrc: fuzzing $$target with the nightly toolchain"; \
	    (cd $$dir && $(CARGO) +nightly fuzz run $$target -- -max_total_time=$(FUZZ_SECONDS) -max_len=8192); \
	  else \
	    echo "wrc: fuzzing $$target with stable and RUSTC_BOOTSTRAP=1 (no nightly toolchain)"; \
	    (cd $$dir && RUSTC_BOOTSTRAP=1 $(CARGO) fuzz run $$target -- -max_total_time=$(FUZZ_SECONDS) -max_len=8192); \
	  fi; \
	done
