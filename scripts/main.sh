#!/usr/bin/env bash
# The main job: set up and build, start geld on its embedded SQLite default (a data directory),
# submit the default `quick` compression with gelctl, watch it, print the resulting curve.
set -euo pipefail
cd "$(dirname "$0")/.."
GEL_BUILD_DIR=build scripts/setup.sh
exec server/demo.sh
