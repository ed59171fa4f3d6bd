"""Command-line helpers shared by the core's commands and the commands plugins add (training/commands.py)."""
from __future__ import annotations

import argparse
import logging
import sys
from contextlib import contextmanager

from ..errors import printable

MAX_MAP_HEIGHT = 2048  # radiance.exr / irradiance.exr: at most 4096 x 2048
HelpFormatter = argparse.RawDescriptionHelpFormatter  # epilogs keep their examples' line breaks


def stderr_log(quiet: bool):
    """A progress printer for the training tools' ``log=`` callbacks: one line on stderr per message, or
    nothing when quiet (the core reports through ``logging``: ``progress_to_stderr``)."""
    return (lambda msg: None) if quiet else (lambda msg: print(printable(msg), file=sys.stderr, flush=True))


class _Printable(logging.Formatter):
    def format(self, record):
        return printable(record.getMessage())


@contextmanager
def progress_to_stderr(quiet: bool):
    """While a command runs: the INFO messages of the core's loggers (``panolight_core.*``), one line each
    on stderr, or none when quiet (warnings still show). A library user configures ``logging`` instead:
    the core only ever logs, never prints its progress."""
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_Printable())
    core = logging.getLogger("panolight_core")
    saved = core.level, core.propagate
    core.setLevel(logging.WARNING if quiet else logging.INFO)
    core.propagate = False
    core.addHandler(handler)
    try:
        yield
    finally:
        core.removeHandler(handler)
        core.setLevel(saved[0])
        core.propagate = saved[1]


def resolution(text: str) -> tuple[int, int]:
    """An argparse type: '512x256' -> (512, 256), 2:1 with height 1..MAX_MAP_HEIGHT (the SH maps are smooth:
    4096 x 2048 resolves every order PanoLight fits many times over; larger maps only cost memory)."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"resolution must look like 512x256, got {text!r}") from None
    if w != 2 * h or h < 1 or h > MAX_MAP_HEIGHT:
        raise argparse.ArgumentTypeError(f"resolution must be 2:1 with height 1..{MAX_MAP_HEIGHT} (the SH maps are "
                                         f"smooth; hdr.exr keeps the input's full resolution), got {text!r}")
    return w, h

