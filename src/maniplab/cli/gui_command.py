"""``maniplab gui``: the design environment in the browser."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def add(sub: argparse._SubParsersAction) -> None:
    """Register the gui sub-command."""
    gui = sub.add_parser(
        "gui", help="configure, simulate, compare and watch an arm in the browser",
        description="Start a local web server with the design environment's page (Configure, "
                    "Simulate, Runs, Watch) and open it. The page reads and writes only the "
                    "workspace folder. Stop with Ctrl-C: the runs already stored stay.",
        epilog="The server listens on 127.0.0.1 only unless --host says otherwise. The page opens "
               "only at the address printed, which carries a secret token: whoever has that "
               "address and can reach the server can run simulations and write into the "
               "workspace.")
    gui.add_argument("spec", nargs="?", default="erector", metavar="SPEC",
                     help="spec file or built-in name shown first (default: erector)")
    gui.add_argument("--port", type=int, default=8080, metavar="N",
                     help="TCP port (default 8080; the next free one when taken)")
    gui.add_argument("--host", default="127.0.0.1",
                     help="interface to listen on (default 127.0.0.1: this machine only)")
    gui.add_argument("--no-browser", action="store_true", help="do not open a browser")
    gui.add_argument("--workspace", type=Path, default=Path("maniplab-workspace"), metavar="DIR",
                     help="folder of the runs, specs and exports (default: maniplab-workspace)")
    gui.add_argument("--controller", action="append", default=[], metavar="MODULE:NAME",
                     help="offer your own controller in the closed-loop moves (a factory "
                          "NAME(spec, move) in MODULE or FILE.py, as 'maniplab control "
                          "--controller' takes it; repeatable)")
    gui.set_defaults(func=_cmd_gui)


def _cmd_gui(args: argparse.Namespace) -> int:
    import maniplab as ml
    from maniplab.control.loading import load_factory
    from maniplab.gui.app import exposed, serve

    spec = ml.resolve_spec(args.spec)
    controllers = {text.rpartition(":")[2]: load_factory(text) for text in args.controller}
    began = time.perf_counter()
    app = serve(spec, args.workspace, host=args.host, port=args.port, controllers=controllers)
    print(f"maniplab gui: {app.url} (workspace {app.workspace.root}; "
          f"ready in {time.perf_counter() - began:.1f} s; Ctrl-C stops)", flush=True)
    if exposed(args.host):
        print(f"maniplab gui: WARNING: listening on {args.host}, not only on this machine: anyone "
              "who reaches this address and has its token can run simulations and write into "
              "the workspace (the traffic is not encrypted)",
              file=sys.stderr, flush=True)
    if not args.no_browser:
        import webbrowser

        webbrowser.open(app.url)
    try:
        while True:
            time.sleep(1.0)
    finally:
        app.close()
