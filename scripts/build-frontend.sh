#!/usr/bin/env bash
# Build the operator UI (frontend/) into the brain's static directory. Skips when nothing the
# build depends on changed since the last build (a stamp holds the hash of its inputs).
# Needs Node >= 20 + npm; without them the brain still runs and `/` says how to build the UI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../frontend"

static=../packages/robot_voice_chat/src/robot_voice_chat/static
stamp="$static/.build-stamp"
if ! command -v npm >/dev/null 2>&1; then
  echo "setup: npm not found — skipping the UI build (install Node 20+ and re-run make setup)"
  exit 0
fi
inputs=$(find package.json package-lock.json index.html vite.config.ts tsconfig.json src scripts \
  -type f -print0 | sort -z | xargs -0 sha256sum | sha256sum | cut -d' ' -f1)
lock=$(sha256sum package-lock.json | cut -d' ' -f1)
if [[ ! -d node_modules || ! -f node_modules/.lock-hash || $(cat node_modules/.lock-hash) != "$lock" ]]; then
  echo "setup: npm ci (frontend)"
  npm ci --no-audit --no-fund --loglevel=error
  echo "$lock" > node_modules/.lock-hash
fi
if [[ -f "$stamp" && $(cat "$stamp") == "$inputs" && -f "$static/index.html" ]]; then
  exit 0
fi
echo "setup: building the UI into $static"
npm run --silent build >/dev/null
echo "$inputs" > "$stamp"
