#!/usr/bin/env bash
# The main job: install what is missing, build, and open the workbench on the
# bundled default organ. With no display, palpa says so, palpates the organ
# headless and writes a picture. Extra arguments go to the program.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
bash tools/build.sh
exec ./build/bin/palpa "$@"
