#!/usr/bin/env bash
# The main job: install what is missing, build, and palpate the bundled
# default organ. Extra arguments go to the program.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
bash tools/build.sh
exec ./build/bin/palpa-palpate "$@"
