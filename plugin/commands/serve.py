"""Serve loadpath to slicer plugins over HTTP on 127.0.0.1 (JSON in and out; schema in the README).

POST /v1/run takes the G-code text and the load case's TOML text (plus settings) and answers the
processed G-code and the report's metrics; FEA results are cached in the cache folder, so
re-slicing the same part under the same load case with other print settings does not solve again.
Requests are bounded in size, in number (--workers running, --queue waiting) and in time
(--timeout); the service only reads and writes files inside its cache folder.  Stop it with Ctrl-C.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = "local HTTP service for slicer plugins (127.0.0.1 only)"

__all__ = ["HELP", "add_args", "run"]


def add_args(parser: argparse.ArgumentParser) -> None:
    """Add the port, the cache folder and the limits."""
    from loadpath.plugin.service import ServiceConfig, default_cache_dir

    d = ServiceConfig()
    parser.add_argument(
        "--port", type=int, default=d.port, help=f"TCP port on 127.0.0.1 (default {d.port}; 0: any)"
    )
    parser.add_argument(
        "--cache",
        type=Path,
        default=None,
        metavar="DIR",
        help=f"cache folder (default {default_cache_dir()})",
    )
    parser.add_argument("--workers", type=int, default=d.workers, metavar="N", help="jobs running at once")
    parser.add_argument(
        "--queue", type=int, default=d.queue, metavar="N", help="requests waiting beyond those"
    )
    parser.add_argument("--timeout", type=float, default=d.timeout, metavar="S", help="per request, seconds")
    parser.add_argument(
        "--max-mb", type=float, default=d.max_request_mb, metavar="MB", help="largest request body"
    )
    parser.add_argument(
        "--fea-cache-entries",
        type=int,
        default=d.fea_cache_entries,
        metavar="N",
        help="FEA results kept (least recently used dropped)",
    )


def run(args: argparse.Namespace) -> int:
    """Serve until interrupted; prints the address on stdout first."""
    from loadpath.errors import SettingsError
    from loadpath.plugin.service import Service, ServiceConfig, confine, default_cache_dir

    for name in ("workers", "timeout", "max_mb", "fea_cache_entries"):
        if getattr(args, name) <= 0:
            raise SettingsError(f"--{name.replace('_', '-')} {getattr(args, name)}: give a positive number")
    if args.queue < 0 or not 0 <= args.port <= 65535:
        raise SettingsError("--queue must be >= 0 and --port within 0..65535")
    config = ServiceConfig(
        port=args.port,
        cache_dir=args.cache or default_cache_dir(),
        max_request_mb=args.max_mb,
        workers=args.workers,
        queue=args.queue,
        timeout=args.timeout,
        fea_cache_entries=args.fea_cache_entries,
    )
    confine(config.cache_dir)  # temporary files and libraries' settings files stay in the cache folder
    try:
        service = Service(config)
    except OSError as exc:
        raise SettingsError(
            f"cannot listen on 127.0.0.1:{args.port} ({exc.strerror or exc}); choose another --port"
        ) from None
    print(f"loadpath serve: listening on {service.url} (cache {config.cache_dir})", flush=True)
    try:
        service.serve_forever()
    except KeyboardInterrupt as exc:
        ended = service.close_jobs()
        how = getattr(exc, "signame", "interrupted")
        print(f"loadpath serve: {how}: stopped; " + (
            f"{ended} running job(s) ended, their G-code not returned and their folders removed"
            if ended else "no job was running"), file=sys.stderr, flush=True)
        status = getattr(exc, "status", 130)
    else:
        status = 0
    finally:
        service.httpd.server_close()
        service.close_jobs()
    return status
