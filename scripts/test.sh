#!/usr/bin/env bash
# Sets up ./.venv if needed, then runs the whole test suite. Extra arguments go to pytest.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/setup.sh"
cd "$root"
# the linter first (pyproject.toml's [tool.ruff]: pyflakes, import order, bugbear): an unused import or a
# redefinition fails the run before the suite starts
"$root/.venv/bin/ruff" check --quiet . || { echo "test.sh: ruff found problems (fix them, or 'ruff check --fix .')" >&2; exit 1; }
set +e
"$root/.venv/bin/python" -m pytest "$@"
rc=$?
set -e
if [ "$rc" -eq 5 ]; then
    echo "test.sh: pytest collected no tests; treating as failure" >&2
    exit 1
fi
exit "$rc"
