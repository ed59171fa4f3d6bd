#!/usr/bin/env bash
# Sets up ./.venv if needed, then runs the main job on a bundled default:
# SH lighting of Blender's "courtyard" studio HDRI, written to out/courtyard/.
# Extra arguments go to `panolight demo` (try --help, --scene sunset, --lmax 8 --window auto).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/setup.sh"
cd "$root"
exec "$root/.venv/bin/panolight" demo "$@"
