#!/usr/bin/env bash
# Idempotent setup: creates ./.venv (Python >= 3.11) and installs PanoLight with every extra.
# Re-running is cheap: it only reinstalls when pyproject.toml, this script or scripts/constraints.txt changed.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
venv="$root/.venv"
stamp="$venv/.panolight-setup-stamp"
want="$(cat pyproject.toml scripts/setup.sh scripts/constraints.txt | sha256sum | cut -c1-16)"
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ] && [ -x "$venv/bin/panolight" ]; then
    exit 0
fi
py="${PYTHON:-}"
if [ -z "$py" ]; then
    for cand in python3.11 python3 python; do
        if command -v "$cand" >/dev/null 2>&1 && "$cand" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
            py="$cand"; break
        fi
    done
fi
[ -n "$py" ] || { echo "setup: Python 3.11 is required (bpy 5.0.1 and the local torch wheel are built for it)" >&2; exit 1; }
echo "setup: creating/updating $venv with $("$py" --version)" >&2
[ -x "$venv/bin/python" ] || "$py" -m venv "$venv"
pip_install() {
    # pip warns once per package about index folders this machine does not have; keep real errors only.
    "$venv/bin/python" -m pip --disable-pip-version-check -q install "$@" 2> >(grep -v "is ignored: it is neither" >&2)
}
# torch first, pinned to the local CPU wheel: any other spec would pull several GB of CUDA packages.
pip_install "torch==2.13.0"
# every other package at the versions in scripts/constraints.txt: the shipped models are reproducible with them
pip_install -c scripts/constraints.txt -e ".[train,mitsuba,blender,usd,bench,dev,plot]"
# The checkout's own folders (training/, blender_addon/) are not installed as packages; this venv finds
# them on its path instead, so `panolight train` and `python -m training...` work from any folder.
site="$("$venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
echo "$root" > "$site/panolight-checkout.pth"
echo "$want" > "$stamp"
echo "setup: done" >&2
