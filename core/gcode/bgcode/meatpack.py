r"""MeatPack, as binary G-code uses it: 4-bit packing of G-code characters.

MeatPack is Scott Mudge's scheme (OctoPrint-MeatPack, BSD-3); binary G-code uses it with the
"no spaces" option always on. Facts (from the scheme's description and libbgcode's observable
behaviour, pinned by the interop tests):

- Packable characters and their 4-bit codes: ``0-9`` -> 0-9, ``.`` 10, ``E`` 11 (the space's code,
  reused because spaces are dropped), ``\\n`` 12, ``G`` 13, ``X`` 14; 15 means "a full byte follows".
- Two characters are packed per byte, the first in the low nibble. A byte whose low (high) nibble is
  15 is followed by the first (second) character in full; ``0xFF`` is followed by both.
- ``0xFF 0xFF c`` is a command: 251 enable packing, 250 disable, 247 no-spaces on, 246 off,
  249 reset (packing off). Each G-code block starts with 251, 247.
- Encoding is lossy by design. Per line: full-line comments are copied verbatim between
  disable/enable commands (encoding 2, "with comments") or dropped (encoding 1); empty lines and
  end-of-line comments are dropped; spaces and tabs are trimmed; a line with ``G<digit>`` loses all
  its spaces and gets ``x e g`` upper-cased (a ``*`` checksum is recomputed); an odd-length line is
  padded with a newline. The decoder collapses repeated newlines and puts a space back before each
  parameter letter (``XYZEFIJRSGPWHCA``) of lines that start with ``G``.

So ``unpack(pack(t))`` equals ``t`` only for text already in that normal form; PrusaSlicer's output
is, apart from its trailing comments, and ``unpack`` of a real file always is.

Both directions work on one G-code block (at most 64 KiB of text) with numpy over the bytes; the
Python loops run over lines (encoder) and over the few bytes that announce full characters (decoder).
"""

from __future__ import annotations

import re

import numpy as np
from loadpath.errors import GCodeParseError

__all__ = ["pack", "unpack", "normalize"]

_SIGNAL = b"\xff\xff"
_ENABLE, _DISABLE, _RESET, _NOSPACES_ON, _NOSPACES_OFF = 251, 250, 249, 247, 246
_NL = 10

# character -> 4-bit code (no-spaces mode), 15 = not packable
_CODE = np.full(256, 15, dtype=np.uint8)
for _i, _c in enumerate(b"0123456789.E\nGX"):
    _CODE[_c] = _i
# libbgcode's table also lists NUL as "packable" with code 15 (its sentinel); keep that quirk so
# our bytes match the reference's even for such (meaningless) input.
_PACKABLE = _CODE != 15
_PACKABLE[0] = True
# bytes that keep a G line off the bulk path (comment, checksum, lower case, tab, carriage return)
_NOT_PLAIN = np.zeros(256, dtype=bool)
_NOT_PLAIN[np.frombuffer(b";*xge\t\r", dtype=np.uint8)] = True
_COMMENT, _PLAIN, _OTHER = 0, 1, 2
_BULK_LINES = 12  # shorter runs of plain G lines are cheaper line by line than through numpy


def _decode_table(nospaces: bool) -> np.ndarray:
    table = np.zeros(16, dtype=np.uint8)
    table[:15] = np.frombuffer(b"0123456789." + (b"E" if nospaces else b" ") + b"\nGX", dtype=np.uint8)
    return table


_DECODE_BOTH = np.concatenate([_decode_table(False), _decode_table(True)])  # 16 codes each
_COMMAND = re.compile(rb"\xff\xff[\x00-\xff]")
_PARAM = np.zeros(256, dtype=bool)
_PARAM[np.frombuffer(b"XYZEFIJRSGPWHCA", dtype=np.uint8)] = True


def _command(code: int) -> bytes:
    return _SIGNAL + bytes((code,))


# ---------------------------------------------------------------------------------------- encode


def _normal_line(line: bytes) -> bytes | None:
    """One line (with its newline) as MeatPack sends it, or None when it is dropped."""
    if len(line) < 2 or line[0] in (10, 13):
        return None
    cut = line.find(b";")
    body = (line if cut < 0 else line[:cut]).strip(b" \t")
    if not body:
        return None
    g = body.find(b"G")
    if 0 <= g < len(body) - 1 and 48 <= body[g + 1] <= 57:
        body = body.replace(b" ", b"")
        if b"x" in body or b"g" in body or b"e" in body:
            body = body.replace(b"x", b"X").replace(b"g", b"G").replace(b"e", b"E")
        if b"*" in body:
            body = body.replace(b"*", b"")
            check = 0
            for byte in body:
                check ^= byte
            body += b"*" + str(check).encode()
        body += b"\n"
    if body[-1] != _NL:
        body += b"\n"
    if len(body) % 2:
        body += b"\n"  # the pair of the last character is a newline
    return body


def _pack_pairs(text: bytes) -> tuple[np.ndarray, np.ndarray]:
    """Pack an even-length text; also return each pair's packed size (1, 2 or 3 bytes)."""
    pairs = np.frombuffer(text, dtype=np.uint8).reshape(-1, 2)
    first, second = pairs[:, 0], pairs[:, 1]
    head = (_CODE[second] << 4) | _CODE[first]
    out = np.stack([head, first, second], axis=1)
    keep = np.stack([np.ones(len(pairs), bool), ~_PACKABLE[first], ~_PACKABLE[second]], axis=1)
    return out[keep], keep.sum(axis=1)


def _plain_g_lines(chunk: bytes) -> bytes:
    r"""Normalize a run of plain G lines at once.

    A plain line starts with ``G<digit>``, has none of ``; * x g e``, tab or CR, and ends in a
    newline. Each loses its spaces and gets a second newline (``G1X1\\n\\n``), and a third when that leaves
    it odd-length, exactly as :func:`_normal_line` does line by line.
    """
    s = np.frombuffer(chunk.replace(b" ", b""), dtype=np.uint8)
    nl = np.flatnonzero(s == _NL)
    length = nl - np.concatenate(([-1], nl[:-1]))  # with the newline
    count = np.ones(len(s), dtype=np.int64)
    count[nl] = np.where(length % 2, 2, 3)
    return np.repeat(s, count).tobytes()


def pack(text: bytes, keep_comments: bool = True) -> bytes:
    r"""Encode one G-code block's text.

    Parameters
    ----------
    text : bytes
        Lines separated by ``\\n``.
    keep_comments : bool
        True for encoding 2 (MeatPack keeping comment lines), False for encoding 1.

    Returns
    -------
    bytes
        The block payload, starting with the enable-packing and no-spaces commands.

    Notes
    -----
    Lines are classified with numpy (comment, plain ``G`` line, other); runs of plain ``G`` lines,
    most of a slicer's output, are normalized in bulk, the others line by line.
    """
    n = len(text)
    if n == 0:
        return _command(_ENABLE) + _command(_NOSPACES_ON) + (b"" if keep_comments else _command(_RESET))
    arr = np.frombuffer(text, dtype=np.uint8)
    ends = np.flatnonzero(arr == _NL) + 1
    if len(ends) == 0 or ends[-1] != n:
        ends = np.append(ends, n)
    starts = np.concatenate(([0], ends[:-1])).astype(np.int64)
    first = arr[starts]
    second = arr[np.minimum(starts + 1, n - 1)]
    bad = np.add.reduceat(_NOT_PLAIN[arr].astype(np.int64), starts) > 0
    kind = np.full(len(starts), _OTHER, dtype=np.int8)
    kind[(first == 71) & (second >= 48) & (second <= 57) & ~bad & (arr[ends - 1] == _NL)] = _PLAIN
    kind[first == 59] = _COMMENT
    # runs of lines of one kind
    cut = np.flatnonzero(np.diff(kind)) + 1
    run_first = np.concatenate(([0], cut)).tolist()
    run_last = np.concatenate((cut, [len(kind)])).tolist()
    starts_l, ends_l, kind_l = starts.tolist(), ends.tolist(), kind.tolist()

    # pieces: verbatim bytes (commands, comment lines) or an int m = "the next m bytes of packed text"
    pieces: list[bytes | int] = [_command(_ENABLE) + _command(_NOSPACES_ON)]
    packed: list[bytes] = []
    packing = True
    run = 0
    for i, j in zip(run_first, run_last, strict=True):
        k = kind_l[i]
        if k == _COMMENT:
            if keep_comments:
                if run:
                    pieces.append(run)
                    run = 0
                if packing:
                    pieces.append(_command(_DISABLE))
                    packing = False
                pieces.append(text[starts_l[i] : ends_l[j - 1]])
            continue
        if k == _PLAIN and j - i >= _BULK_LINES:
            bodies = [_plain_g_lines(text[starts_l[i] : ends_l[j - 1]])]
        else:
            bodies = [b for b in (_normal_line(text[starts_l[m] : ends_l[m]]) for m in range(i, j)) if b]
            if not bodies:
                continue
        if not packing:
            pieces.append(_command(_ENABLE))
            packing = True
        packed.extend(bodies)
        run += sum(len(b) for b in bodies)
    if run:
        pieces.append(run)
    if not keep_comments:
        pieces.append(_command(_RESET))
    if not packed:
        return b"".join(p for p in pieces if isinstance(p, bytes))
    # one vectorized packing for the whole block, cut where the runs end
    out, sizes = _pack_pairs(b"".join(packed))
    bounds = np.concatenate(([0], np.cumsum(sizes))).tolist()
    stream = out.tobytes()
    parts: list[bytes] = []
    pair = 0
    for piece in pieces:
        if isinstance(piece, int):
            stop = pair + piece // 2
            parts.append(stream[bounds[pair] : bounds[stop]])
            pair = stop
        else:
            parts.append(piece)
    return b"".join(parts)


def normalize(text: bytes, keep_comments: bool = True) -> bytes:
    """Return the text a MeatPack round trip gives: ``unpack(pack(text, keep_comments))``."""
    return unpack(pack(text, keep_comments))


# ---------------------------------------------------------------------------------------- decode


def unpack(data: bytes) -> bytes:
    """Decode one G-code block's MeatPack bytes into text.

    Vectorized over the block: the commands are located first (``0xFF 0xFF`` occurs nowhere else,
    full characters being text bytes), which fixes for every byte whether it is packed or verbatim;
    a short Python walk over the few bytes that announce full characters separates pair bytes from
    full characters; numpy then scatters the characters to their output positions.
    """
    n = len(data)
    if n == 0:
        return b""
    b = np.frombuffer(data, dtype=np.uint8)
    # --- commands, and the mode of every byte: segments alternate data, command, data, ...
    seg_len: list[int] = []
    seg_packed: list[bool] = []
    seg_nospace: list[bool] = []
    packing = nospaces = False
    prev = 0
    for m in _COMMAND.finditer(data):
        k = m.start()
        seg_len += [k - prev, 3]
        seg_packed += [packing, False]
        seg_nospace += [nospaces, False]
        code = data[k + 2]
        if code == _ENABLE:
            packing = True
        elif code in (_DISABLE, _RESET):
            packing = False
        elif code == _NOSPACES_ON:
            nospaces = True
        elif code == _NOSPACES_OFF:
            nospaces = False
        prev = k + 3
    seg_len.append(n - prev)
    seg_packed.append(packing)
    seg_nospace.append(nospaces)
    is_command = np.zeros(len(seg_len), dtype=bool)
    is_command[1::2] = True
    packed = np.repeat(np.array(seg_packed, dtype=bool), seg_len)
    nospace = np.repeat(np.array(seg_nospace, dtype=bool), seg_len)
    command = np.repeat(is_command, seg_len)
    # --- pair bytes versus full characters (a newline in the low half ends the pair)
    lo, hi = b & 15, b >> 4
    extra = ((lo == 15).astype(np.int64) + ((hi == 15) & (lo != 12))) * packed
    full = np.zeros(n, dtype=bool)
    cand = np.flatnonzero(extra)
    k = extra[cand]
    # A candidate is a pair byte unless an earlier pair byte's full characters cover it. Only
    # candidates within reach of the previous one can be covered ("clusters", rare: full characters
    # such as 'O', '_', '/' look like candidates); walk those in Python, take the rest as they are.
    near = cand[1:] - cand[:-1] <= k[:-1]
    head = np.ones(len(cand), dtype=bool)
    nxt = 0
    if near.any():
        involved = np.zeros(len(cand), dtype=bool)
        involved[1:] |= near
        involved[:-1] |= near
        for j in np.flatnonzero(involved).tolist():
            q = int(cand[j])
            if q < nxt:
                head[j] = False
            else:
                nxt = q + 1 + int(k[j])
    hq, hk = cand[head], k[head]
    full[np.minimum(hq + 1, n - 1)] = True
    full[np.minimum(hq + 2, n - 1)[hk == 2]] = True
    if len(hq):
        nxt = max(nxt, int(hq[-1] + 1 + hk[-1]))
    if nxt > n or (full & ~packed).any():
        raise GCodeParseError(
            "MeatPack data end inside a character pair; the file is damaged, export it again"
        )
    heads = packed & ~full
    verbatim = ~packed & ~command
    # --- scatter: a pair byte gives 1 or 2 characters, a verbatim byte 1
    count = heads.astype(np.int64) + (heads & (lo != 12)) + verbatim
    start = np.cumsum(count) - count
    out = np.zeros(int(count[-1] + start[-1]), dtype=np.uint8)
    out[start[verbatim]] = b[verbatim]
    h = np.flatnonzero(heads)
    hl, hh, hs = lo[h], hi[h], start[h]
    table = _DECODE_BOTH
    row = nospace[h].astype(np.int64) * 16  # second half of the table: no-spaces mode
    at1 = np.minimum(h + 1, n - 1)
    at2 = np.minimum(h + 1 + (hl == 15), n - 1)
    out[hs] = np.where(hl == 15, b[at1], table[row + hl])
    keep2 = hl != 12
    second = np.where(hh == 15, b[at2], table[row + hh])
    out[hs[keep2] + 1] = second[keep2]
    return _respace(out).tobytes()


def _respace(text: np.ndarray) -> np.ndarray:
    """Collapse repeated newlines; put spaces back before parameters on lines starting with G."""
    nl = text == _NL
    repeat = np.zeros(len(text), dtype=bool)
    repeat[1:] = nl[1:] & nl[:-1]
    text = text[~repeat]
    n = len(text)
    if n == 0:
        return text
    idx = np.arange(n)
    starts = np.zeros(n, dtype=bool)
    starts[0] = True
    starts[1:] = text[:-1] == _NL
    line_start = np.maximum.accumulate(np.where(starts, idx, 0))
    prev = np.concatenate(([_NL], text[:-1]))
    gap = (text[line_start] == ord("G")) & _PARAM[text] & ~starts & (prev != ord(" "))
    if not gap.any():
        return text
    return np.insert(text, np.flatnonzero(gap), ord(" "))
