"""Walking a DataFlash log's messages as pymavlink's DFReader indexes them, to find where it would go wrong.

DFReader (pymavlink DFReader.py, init_arrays, and its compiled twin dfindexer) steps from message to
message by the length each type's FMT declares. Past a bad header (not 0xA3 0x95) it moves on a byte at a
time until the next one, but at a good header of a type no FMT declares it stops indexing: nothing after
it is read, and no error is raised. One damaged type byte a quarter into a real ArduCopter log left 4.5 s
of its 113 s. Such a header is what a damaged byte or a resynchronisation inside a message body looks
like, so it is skipped as a bad header is: ``readable`` blanks its first byte, which DFReader then passes
over, in a copy of the log.
"""
from __future__ import annotations

from dataclasses import dataclass

from dobwind.core.errors import InputError

DATAFLASH_MAGIC = b"\xa3\x95"  # every DataFlash message starts so (ArduPilot's LogStructure.h)
FMT_TYPE = 128                 # the FMT message's type; its body starts with the type it defines and its length
FMT_LENGTH = 89


@dataclass(frozen=True)
class Undeclared:
    """Good headers of types no FMT declared before them: (byte offset, type) of each; and whether the file
    ends inside a message that follows only well-formed ones (the cut end of a crash log or a short copy:
    a file with a bad byte before its end is damaged there, not cut)."""
    headers: tuple[tuple[int, int], ...]
    ends_inside: bool = False

    def note(self, size: int) -> str | None:
        if not self.headers:
            return None
        at, kind = self.headers[0]
        return (f"damaged: {len(self.headers)} message header(s) of a type no FMT declares (the first: type "
                f"{kind} at byte {at:,} of {size:,}), skipped as bad bytes; the messages after them are read")


def undeclared_headers(path: str, blob: bytes) -> Undeclared:
    """Walk ``blob`` as DFReader does, but past an undeclared type as past a bad header. A type declared
    shorter than its own 3-byte header would stall DFReader for ever (a corrupt FMT): refused here. The
    same walk says whether the file ends inside a message (``ends_inside``): as long as every message so far
    was well formed (``clean``), it is the walk a reader stepping by the declared lengths makes."""
    lengths, pos, size, found, clean = {FMT_TYPE: FMT_LENGTH}, 0, len(blob), [], True
    while pos + 3 <= size:
        if blob[pos:pos + 2] != DATAFLASH_MAGIC:
            clean = False
            pos = blob.find(DATAFLASH_MAGIC, pos + 1)
            if pos < 0:
                break
            continue
        kind = blob[pos + 2]
        if kind not in lengths:
            clean = False
            found.append((pos, kind))
            pos += 1
            continue
        if lengths[kind] < 3:
            raise InputError(path, None, f"not a readable DataFlash log: message type {kind} at byte {pos} is "
                             f"declared {lengths[kind]} bytes long by its FMT, shorter than its own 3-byte header "
                             "(a corrupt FMT)")
        if kind == FMT_TYPE and pos + 5 <= size:
            lengths[blob[pos + 3]] = blob[pos + 4]
        pos += lengths[kind]
    return Undeclared(tuple(found), clean and pos != size)  # past the end, or 1-2 bytes of a header left


def readable(blob: bytes, undeclared: Undeclared) -> bytes:
    """``blob`` with the first byte of each undeclared header zeroed: a bad header to DFReader, which it
    skips byte by byte to the next message, as the walk above does."""
    if not undeclared.headers:
        return blob
    out = bytearray(blob)
    for pos, _ in undeclared.headers:
        out[pos] = 0
    return bytes(out)
