"""The ``panolight`` command's entry point: Ctrl-C or SIGTERM while the command is still importing (about 0.2 s)
ends it with its one line and status (130, 143), not a traceback or a silent kill: nothing has started yet, so
there is nothing to clean. From ``cli.main`` on, the command's own handling takes over."""
from __future__ import annotations

import os
import signal
import sys


def _before_main(signum, frame):
    sys.stderr.write("panolight: terminated (SIGTERM)\n" if signum == signal.SIGTERM else "panolight: interrupted\n")
    sys.stderr.flush()
    os._exit(128 + signum)


def main() -> int:
    signal.signal(signal.SIGINT, _before_main)
    signal.signal(signal.SIGTERM, _before_main)
    from . import cli

    signal.signal(signal.SIGTERM, cli.terminate)  # what cli.main installs too: no moment without a handler
    signal.signal(signal.SIGINT, signal.default_int_handler)
    return cli.main()


if __name__ == "__main__":
    sys.exit(main())
