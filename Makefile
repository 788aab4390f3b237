# nanopush: `make demo` runs the main job on the simulated rig, `make test` runs every check.
# Both install missing system packages first (scripts/install-deps.sh).
SHELL := /bin/bash
CARGO ?= cargo
DEMO_OUT ?= out/demo

.PHONY: deps demo test build bench lint fmt peers

deps:
	@bash scripts/install-deps.sh

build: deps
	$(CARGO) build --release

demo: deps
	$(CARGO) run --release --quiet -- demo --out $(DEMO_OUT)

lint: deps
	$(CARGO) fmt --check
	$(CARGO) clippy --all-targets -- -D warnings

test: lint
	$(CARGO) test --all-targets
	$(CARGO) test --doc

bench: deps
	$(CARGO) bench

fmt:
	$(CARGO) fmt
