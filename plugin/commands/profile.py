"""Flatten PrusaSlicer vendor presets into one .ini for slicing from the command line.

PrusaSlicer 2.5's command line cannot select a bundled vendor preset by name (and --load does not
follow the bundle's inherits chains), so a printer's real settings need flattening first:

    loadpath profile --printer "Original Prusa i3 MK3S & MK3S+" --print "0.20mm QUALITY @MK3" \\
        --filament "Prusament PLA" -o mk3s.ini
    prusa-slicer --export-gcode --load mk3s.ini --output part.gcode part.stl

--list KIND prints the presets of a kind (printer, print, filament) in the vendor's bundle.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = "flatten PrusaSlicer vendor presets into one .ini for prusa-slicer --load"

__all__ = ["HELP", "add_args", "run"]

MK3S = ("Original Prusa i3 MK3S & MK3S+", "0.20mm QUALITY @MK3", "Prusament PLA")


def add_args(parser: argparse.ArgumentParser) -> None:
    """The vendor bundle, the three presets (default the MK3S's), the output or --list."""
    parser.add_argument(
        "--vendor",
        default="PrusaResearch",
        help="bundle name in /usr/share/PrusaSlicer/profiles, or a path to a bundle .ini (default PrusaResearch)",
    )
    parser.add_argument("--printer", default=MK3S[0], help=f"printer preset (default {MK3S[0]!r})")
    parser.add_argument("--print", dest="print_", default=MK3S[1], help=f"print preset (default {MK3S[1]!r})")
    parser.add_argument("--filament", default=MK3S[2], help=f"filament preset (default {MK3S[2]!r})")
    parser.add_argument("-o", "--output", type=Path, default=None, metavar="OUT.ini", help="where to write")
    parser.add_argument(
        "--list", choices=("printer", "print", "filament"), default=None, help="list the presets of a kind"
    )


def run(args: argparse.Namespace) -> int:
    """Run the command (see the module docstring)."""
    from loadpath.errors import SettingsError
    from loadpath.plugin import profile

    if args.list:
        for name in profile.presets(profile.read_bundle(profile.bundle_path(args.vendor)), args.list):
            print(name)
        return 0
    if args.output is None:
        raise SettingsError("give -o OUT.ini (where to write the flattened presets), or --list KIND")
    keys = profile.flatten(args.vendor, args.printer, args.print_, args.filament)
    profile.write_ini(keys, args.output)
    print(
        f"loadpath: wrote {args.output} ({len(keys)} keys: {args.printer} / {args.print_} / {args.filament}); "
        f"slice with: prusa-slicer --export-gcode --load {args.output} --output part.gcode part.stl",
        file=sys.stderr,
    )
    return 0
