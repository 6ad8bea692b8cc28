"""The protections every loopback HTTP server of loadpath applies (``serve`` and ``edit``).

One owner for: the address servers bind (127.0.0.1 only), the Host / Origin checks that stop other
machines' names (DNS rebinding) and other web pages from reaching a local server, and reading a
JSON body of bounded size.  Both servers raise :class:`RequestError` (HTTP status, code, one line)
and answer it as ``{"ok": false, "error": {"code", "message"}}``.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Mapping
from typing import Any, BinaryIO
from urllib.parse import urlsplit

from loadpath.plugin.service_job import RequestError

__all__ = ["HOST", "LOOPBACK", "RequestError", "check_host_origin", "read_json_body", "short"]

HOST = "127.0.0.1"
"""The only address loadpath's servers listen on."""

LOOPBACK = frozenset({"127.0.0.1", "localhost", "::1"})
"""Host names a request may be addressed to."""

_HOST_RE = re.compile(r"^(?:127\.0\.0\.1|localhost|\[::1\])(?::(?P<port>[0-9]{1,5}))?$", re.IGNORECASE)
"""A ``Host`` header spelled plainly: a loopback name and an optional port, nothing else (no
user-info part such as ``evil@localhost``)."""


def short(text: str) -> str:
    """``text`` cut to 60 characters for a one-line message."""
    return text if len(text) <= 60 else text[:57] + "..."


def check_host_origin(headers: Mapping[str, str], port: int | None = None) -> None:
    """Refuse a request addressed to another host name or sent by another web page.

    Parameters
    ----------
    headers : mapping
        The request's headers (``Host``, ``Origin``, ``Sec-Fetch-Site``).
    port : int, optional
        The server's own port: when given, a ``Host`` port must be it and an ``Origin`` must be
        this very server (a page it served itself), not some other loopback page.

    Raises
    ------
    RequestError
        403 ``forbidden``.
    """
    raw_host = headers.get("Host") or ""
    m = _HOST_RE.match(raw_host)
    if not m or (port is not None and m.group("port") is not None and int(m.group("port")) != port):
        raise RequestError(403, "forbidden", f"Host {short(raw_host)!r} is not this machine's loopback")
    origin = headers.get("Origin")
    if origin is not None:
        parts = urlsplit(origin)
        try:
            origin_port = parts.port
        except ValueError:
            origin_port = -1
        if parts.hostname not in LOOPBACK or (port is not None and origin_port != port):
            raise RequestError(403, "forbidden", f"requests from web pages ({short(origin)}) are not accepted")
    if port is not None and (headers.get("Sec-Fetch-Site") or "same-origin") not in ("same-origin", "none"):
        raise RequestError(
            403, "forbidden", f"requests from other sites ({headers.get('Sec-Fetch-Site')}) are not accepted"
        )


def read_json_body(
    headers: Mapping[str, str],
    rfile: BinaryIO,
    limit_mb: float,
    hint: str,
    read: Callable[[int], bytes] | None = None,
) -> Any:
    """Read and decode a JSON request body of at most ``limit_mb`` MB.

    Parameters
    ----------
    headers : mapping
        ``Content-Length`` must be given and ``Content-Type`` be ``application/json``.
    rfile : binary file
        The request stream.
    limit_mb : float
        Largest body, MB.
    hint : str
        How the user raises the limit (named in the 413 message).
    read : callable, optional
        ``read(n) -> bytes`` reading the body (the service's reads it within a deadline and raises
        :class:`TimeoutError`); default ``rfile.read``.

    Returns
    -------
    Any
        The decoded JSON.

    Raises
    ------
    RequestError
        411, 415, 413 or 400 (also for JSON nested too deeply to decode).
    """
    length = headers.get("Content-Length")
    if length is None or not length.strip().isdigit():
        raise RequestError(411, "length_required", "give the body's Content-Length")
    ctype = (headers.get("Content-Type") or "").split(";")[0].strip().lower()
    if ctype != "application/json":
        raise RequestError(
            415, "unsupported_media_type", "send the request as Content-Type: application/json"
        )
    n = int(length)
    if n > int(limit_mb * 1e6):
        raise RequestError(
            413,
            "too_large",
            f"the request has {n / 1e6:.1f} MB, more than the {limit_mb:g} MB allowed ({hint})",
        )
    body = (read or rfile.read)(n)
    try:
        return json.loads(body)
    except RecursionError:
        raise RequestError(400, "bad_request", "the body's JSON is nested too deeply") from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise RequestError(400, "bad_request", f"the body is not valid JSON ({short(str(exc))})") from None
