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
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --no-deps --quiet

# Benches are compiled by clippy --all-targets; they are run by `make bench`, not here.
test: lint
	$(CARGO) test --lib --bins --tests
	$(CARGO) test --doc

bench: deps
	$(CARGO) bench

fmt:
	$(CARGO) fmt

# Peer tools outside the product (Python venvs): trackpy, scipy, PIPython.
peers:
	bash scripts/peers/setup-venv.sh
	bash scripts/peers/setup-venv-scipy.sh
	bash scripts/peers/setup-venv-pipython.sh
