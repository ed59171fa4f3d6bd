"""Every tool of training/ is a panolight command: listed by --help, run with its own command line."""
import pytest

from panolight_core.apps.cli import main
from training.commands import TOOLS


def test_panolight_help_lists_every_tool(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    for name in list(TOOLS) + ["train", "synth", "sheet", "render-mitsuba"]:
        assert f"    {name}" in out


@pytest.mark.parametrize("name", sorted(TOOLS))
def test_a_tool_shows_its_own_options(name, capsys):
    with pytest.raises(SystemExit) as exc:
        main([name, "--help"])
    assert exc.value.code == 0
    assert "usage:" in capsys.readouterr().out


def test_a_tool_gets_its_arguments_and_core_commands_still_refuse_unknown_ones(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["keylight-cv", "--evs", "zero"])  # the tool's own parser checks its options
    assert exc.value.code == 2 and "--evs" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["demo", "--no-such-option"])
    assert exc.value.code == 2 and "unrecognized arguments: --no-such-option" in capsys.readouterr().err


def test_a_tool_whose_extra_is_missing_says_which_package(monkeypatch, capsys):
    import importlib

    real = importlib.import_module

    def without_torch(name, *args):
        if name == "training.neural.cv":
            raise ModuleNotFoundError("No module named 'torch'", name="torch")
        return real(name, *args)

    monkeypatch.setattr(importlib, "import_module", without_torch)
    assert main(["neural-cv", "--help"]) == 1
    err = capsys.readouterr().err
    assert "neural-cv needs the package 'torch'" in err and "setup.sh" in err
