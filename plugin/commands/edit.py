"""Edit a load case in the browser: click the part's holes and edges, see the stress, save the TOML.

PART is G-code (the layer outlines ``inspect`` finds) or an STL (its cross-sections, for a case
made before slicing; the saved case then uses frame = "part", so it fits any placement on the bed).
The editor is a local web page served on 127.0.0.1 only (the protections of ``loadpath serve``);
Save writes the case to CASE.toml (--loadcase; opened first when it exists) or, without it, to
PART's name with .toml beside PART.  Stop it with Ctrl-C.
"""

from __future__ import annotations

import argparse
import sys
import webbrowser
from pathlib import Path

HELP = "edit a load case in the browser on the part (G-code or STL) and save the TOML"

__all__ = ["HELP", "add_args", "run", "default_save_path"]


def add_args(parser: argparse.ArgumentParser) -> None:
    """Register the command's arguments."""
    parser.add_argument("part", metavar="PART", help="G-code (.gcode, .bgcode) or STL of the part")
    parser.add_argument(
        "--loadcase",
        metavar="CASE.toml",
        type=Path,
        help="the case to open (when it exists) and to save; default PART's name with .toml",
    )
    parser.add_argument("--port", type=int, default=0, help="TCP port on 127.0.0.1 (default: any free port)")
    parser.add_argument("--no-browser", action="store_true", help="print the address, do not open a browser")


def default_save_path(part: Path) -> Path:
    """``bracket.gcode`` -> ``bracket.toml`` beside it."""
    return part.with_suffix(".toml")


def run(args: argparse.Namespace) -> int:
    """Serve the editor until interrupted."""
    from loadpath import loadcase
    from loadpath.errors import SettingsError
    from loadpath.plugin.editor.part import load_part
    from loadpath.plugin.editor.server import EditorServer
    from loadpath.plugin.editor.session import EditorSession

    if not 0 <= args.port <= 65535:
        raise SettingsError(f"--port {args.port} must lie within 0..65535")
    part = load_part(args.part)
    save = Path(args.loadcase) if args.loadcase else default_save_path(part.path)
    initial = loadcase.read(save) if save.is_file() else None
    session = EditorSession(part, save, initial)
    try:
        server = EditorServer(session, args.port)
    except OSError as exc:
        session.close()
        raise SettingsError(
            f"cannot listen on 127.0.0.1:{args.port} ({exc.strerror or exc}); choose another --port"
        ) from None
    opened = "opened " + str(save) if initial is not None else "new case, saved to " + str(save)
    print(
        f"loadpath edit: {part.path.name} ({part.kind}, {len(session.view['layers'])} distinct region(s)); "
        f"{opened}; editor at {server.url}",
        flush=True,
    )
    if not args.no_browser:
        webbrowser.open(server.url)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        print("loadpath edit: stopped", file=sys.stderr)
    finally:
        server.shutdown()
    return 0
