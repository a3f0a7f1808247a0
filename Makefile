# Robot stack — one entry point for people and CI. Every target sets itself up first.
SHELL := /bin/bash
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export PATH := $(HOME)/.local/bin:$(PATH)

.PHONY: setup demo demo-mission test lint format typecheck audit bench clean help

help:  ## list the targets
	@grep -E '^[a-z-]+:.*##' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  %-10s %s\n", $$1, $$2}'

setup:  ## install uv, sync the locked workspace, build the ROS 2 interfaces, make sample frames
	@bash scripts/setup.sh

demo: setup  ## the whole stack with the operator UI on http://127.0.0.1:8000 (Ctrl+C stops it)
	@ROS_DOMAIN_ID=$${ROS_DOMAIN_ID:-$$((RANDOM % 90 + 10))} uv run --frozen python scripts/ui_demo.py

demo-mission: setup  ## one mailroom mission on the embedded defaults, narrated in the terminal
	@ROS_DOMAIN_ID=$${ROS_DOMAIN_ID:-$$((RANDOM % 90 + 10))} uv run --frozen python scripts/demo.py

test: setup lint  ## lint + type-check + every test suite with per-package coverage gates
	@bash scripts/run-tests.sh

lint: setup  ## ruff check, ruff format --check, mypy --strict, import contracts
	uv run --frozen ruff check .
	uv run --frozen ruff format --check .
	uv run --frozen mypy packages/*/src
	@if [[ -f .importlinter ]]; then uv run --frozen lint-imports; fi

format: setup  ## apply ruff fixes and formatting
	uv run --frozen ruff check --fix .
	uv run --frozen ruff format .

NPM_PROJECTS := frontend tools/mcp-inspector

audit: setup  ## pip-audit + npm audit of the locked dependencies (needs the registries); fails if either could not look
	uv export --frozen --all-packages --no-emit-workspace --no-hashes -o build/requirements-audit.txt
	rm -f build/pip-audit.json build/npm-audit-*.json
	-uv run --frozen pip-audit -r build/requirements-audit.txt --progress-spinner off --format json -o build/pip-audit.json
	-for p in $(NPM_PROJECTS); do n=$${p//\//-}; \
	  (cd $$p && npm audit --package-lock-only --json >$(CURDIR)/build/npm-audit-$$n.json; \
	   npm audit --package-lock-only --omit=dev --json >$(CURDIR)/build/npm-audit-$$n-runtime.json); done
	pip=0; uv run --frozen python scripts/audit_gate.py build/pip-audit.json || pip=$$?; \
	uv run --frozen python scripts/npm_audit_gate.py $(foreach p,$(NPM_PROJECTS),$(p)=build/npm-audit-$(subst /,-,$(p)).json:build/npm-audit-$(subst /,-,$(p))-runtime.json) \
	  && exit $$pip

bench: setup  ## run every benchmark; JSON results in benchmarks/results/
	@ROS_DOMAIN_ID=$${ROS_DOMAIN_ID:-$$((RANDOM % 90 + 10))} bash scripts/run-benchmarks.sh

clean:  ## remove build output (keeps .venv)
	rm -rf build benchmarks/results .pytest_cache .mypy_cache .ruff_cache
