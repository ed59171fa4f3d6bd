"""Every command in the README and the user guides runs as written on a fresh clone (after the set-up), at tiny
sizes: the demo, estimate, batch, the Blender headless lines and render-mitsuba. The commands run in order (the
README, then each guide of PAGES) in one shell, in a scratch folder that holds the checkout's set-up (so nothing
tracked is written), with only render sizes and sample counts turned down. Every line of a quoted ```text block is
what the commands print now. The README is a landing page of at most 200 lines."""
import os
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

TINY = [  # (pattern, replacement): the same commands at test sizes
    (r"--spp \d+", "--spp 1"),
    (r"--samples \d+", "--samples 1"),
    (r"--resolution 480x270", "--resolution 48x27"),
]
# `blender -b FILE --python SCRIPT -- ARGS` in a Blender installation, run with the bpy module: FILE opened, then
# SCRIPT with ARGS, as Blender does; the extension's batch.py is the checkout's blender_addon/batch.py
BLENDER = ("import runpy, sys, bpy; bpy.ops.wm.open_mainfile(filepath=sys.argv[1]); "
           "sys.argv = sys.argv[2:]; runpy.run_path(sys.argv[0], run_name='__main__')")


PAGES = ("README.md", "docs/captures.md", "docs/pipeline.md")  # the pages whose commands run, in this order


def readme_commands() -> list[str]:
    """The bash lines of PAGES, continuations joined and comments dropped (the test command itself left out)."""
    text = "\n".join((ROOT / page).read_text(encoding="utf-8") for page in PAGES)
    lines = []
    for block in re.findall(r"```bash\n(.*?)```", text, re.S):
        for line in block.replace("\\\n", " ").splitlines():
            line = re.sub(r"\s+#\s.*$", "", line).strip()
            if line and not line.startswith("#") and line != "bash scripts/test.sh":
                lines.append(line)
    return lines


def tiny(line: str) -> str:
    for pattern, repl in TINY:
        line = re.sub(pattern, repl, line)
    if "render-mitsuba" in line:
        line += " --resolution 32x24 --no-panorama-view" + ("" if "--spp" in line else " --spp 1")
    m = re.match(r"blender -b (\S+) --python (\S+) -- (.*)$", line)
    if m:
        line = (f".venv/bin/python -c \"{BLENDER}\" {m.group(1)} blender_addon/batch.py -- {m.group(3)} "
                f"--resolution 48x27")
    return line


def test_the_readme_is_a_landing_page():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 200
    heads = [line for line in text.splitlines() if line.startswith("## ")]
    assert heads[:3] == ["## Set up", "## Examples", "## Guides"]
    for page in re.findall(r"\]\((docs/[^)#]+)", text):
        assert (ROOT / page).exists(), page


def test_the_readme_commands_are_the_ones_this_test_runs():
    lines = readme_commands()
    assert lines[0] == "bash scripts/demo.sh"
    assert any(line.startswith("blender -b ") for line in lines)
    for kind in ("estimate", "batch", "render-mitsuba", "blender_addon/batch.py"):
        assert any(kind in line for line in lines), kind


def _setup_is_current() -> bool:
    """Whether scripts/setup.sh's stamp in .venv matches pyproject.toml, setup.sh and constraints.txt: else the
    README's setup line would reinstall the real .venv, linked here, from this test's temporary folder."""
    import hashlib

    want = hashlib.sha256(b"".join((ROOT / p).read_bytes() for p in ("pyproject.toml", "scripts/setup.sh",
                                                                       "scripts/constraints.txt"))).hexdigest()[:16]
    stamp = ROOT / ".venv" / ".panolight-setup-stamp"
    return stamp.is_file() and stamp.read_text().strip() == want


def test_every_readme_command_runs_as_written(tmp_path):
    assert _setup_is_current(), "the .venv is older than pyproject.toml or scripts/: run 'bash scripts/setup.sh' first"
    for name in (".venv", "blender_addon", "scripts", "pyproject.toml"):
        (tmp_path / name).symlink_to(ROOT / name)
    script = "set -euo pipefail\n" + "".join(f"echo '+ {i}' >&2\n{tiny(line)}\n"
                                            for i, line in enumerate(readme_commands()))
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST")}
    r = subprocess.run(["bash", "-c", script], cwd=tmp_path, capture_output=True, text=True, timeout=1500, env=env)
    assert r.returncode == 0, f"the README command after the last '+ N' failed:\n{r.stderr[-4000:]}"
    printed = r.stdout + r.stderr
    quoted = [line for page in PAGES for block in re.findall(r"```text\n(.*?)```", (ROOT / page).read_text(), re.S)
              for line in block.splitlines() if line.strip()]
    assert quoted, "the README quotes what its demo prints"
    for line in quoted:
        assert line in printed, f"quoted, but not what the commands print now: {line}"
    for made in ("courtyard/input.jpg", "city/input.jpg", "photo/lighting.json", "sh8/lighting.json",
                 "batch/batch_report.json", "farm/batch_report-2-of-4.json", "blender_render.png",
                 "shot_lit.blend", "cg_layer.exr", "figure/figure.png", "from-jpeg/figure.png"):
        assert (tmp_path / "out" / made).is_file(), made
    assert not (tmp_path / "docs").exists()  # nothing written into the checkout's tracked folders
