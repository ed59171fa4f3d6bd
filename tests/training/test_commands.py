"""Every tool of training/ is a panolight command: the users' ones at the top of --help, the developers'
under ``panolight dev``, each run with its own command line."""
import pytest

from panolight_core.apps.cli import main
from training.commands import TOOLS


def _listed(out: str) -> list[str]:
    """The command names an argparse help lists (indented 4, after 'positional arguments')."""
    import re

    return re.findall(r"^    (\S+)", out.split("positional arguments:")[1].split("options:")[0], re.M)


def test_panolight_help_lists_the_users_commands_and_dev_the_tools(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    top = _listed(capsys.readouterr().out)
    assert len(top) <= 12 and not set(TOOLS) & set(top), top
    assert {"estimate", "batch", "eval", "demo", "project", "render-mitsuba", "train", "dev"} <= set(top)
    with pytest.raises(SystemExit):
        main(["dev", "--help"])
    assert _listed(capsys.readouterr().out) == list(TOOLS)


@pytest.mark.parametrize("name", sorted(TOOLS))
def test_a_tool_shows_its_own_options(name, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["dev", name, "--help"])
    assert exc.value.code == 0
    assert "usage:" in capsys.readouterr().out


def test_a_tool_gets_its_arguments_and_core_commands_still_refuse_unknown_ones(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["dev", "keylight-cv", "--evs", "zero"])  # the tool's own parser checks its options
    assert exc.value.code == 2 and "--evs" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["demo", "--no-such-option"])
    assert exc.value.code == 2 and "unrecognized arguments: --no-such-option" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:  # the command's usage, and the option meant
        main(["estimate", "x.jpg", "--exposre", "2"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and err.startswith("usage: panolight estimate") and "did you mean --exposure?" in err


def test_a_tool_whose_extra_is_missing_says_which_package(monkeypatch, capsys):
    import importlib

    real = importlib.import_module

    def without_torch(name, *args):
        if name == "training.neural.cv":
            raise ModuleNotFoundError("No module named 'torch'", name="torch")
        return real(name, *args)

    monkeypatch.setattr(importlib, "import_module", without_torch)
    assert main(["dev", "neural-cv", "--help"]) == 1
    err = capsys.readouterr().err
    assert "neural-cv needs the package 'torch'" in err and "setup.sh" in err
