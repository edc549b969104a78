"""Say in words what is wrong with a log, from whatever a reader library raised.

The readers (rosbags, mcap, zstd, lz4, bz2, sqlite3, the CDR decoders) raise their own and
Python's built-in exceptions on damaged input, some with empty messages (a failed `assert`) or
with messages that only make sense next to a traceback (`OverflowError: Python int too large to
convert to C ssize_t`). Users see one line, so each is turned into a phrase about the file.
"""

from __future__ import annotations

import re
import sqlite3
import struct
import traceback
from collections.abc import Callable

from rosbags.highlevel import AnyReaderError
from rosbags.rosbag1 import ReaderError as Ros1ReaderError
from rosbags.rosbag2 import ReaderError as Ros2ReaderError
from rosbags.serde import SerdeError
from rosbags.typesys import TypesysError

_MAX_DETAIL = 200

# (module path part, function) where rosbags asserts on what it reads -> what that means
_ASSERTS = {
    ("rosbag1", "read_index_data"): "its chunk index records are laid out in a way the reader "
                                    "does not know (an old or unusual rosbag writer, or damage)",
    ("rosbag1", "messages"): "a message record does not match the bag's index (damaged)",
    ("rosbag2", "_open"): "its MCAP summary is inconsistent (damaged)",
    ("rosbag2", "messages"): "a chunk's records do not match its summary (damaged)",
}

# exception class name -> phrase, for libraries whose error classes are not imported here
_BY_NAME = {
    "ZstdError": "a zstd-compressed chunk does not decompress (damaged)",
    "CRCValidationError": "a chunk fails its CRC check (damaged)",
    "EndOfFile": "the file ends in the middle of a record (truncated)",
    "InvalidMagic": "the file does not start or end with the MCAP magic bytes",
    "RecordLengthLimitExceeded": "a record claims a length beyond the end of the file (damaged)",
}


# rosbags' words for a few common cases -> what they mean for the user
_REWORDED = {
    "File end magic is invalid.": "it does not end with the MCAP magic bytes (truncated, or "
                                  "still being written)",
    "File magic is invalid.": "it starts with neither the ROS 1 bag nor the MCAP magic bytes "
                              "(not a log, or damaged)",
    "Bag is not indexed, reindex before reading.": "the bag has no index (the recording did "
                                                   "not finish)",
    "Invalid data stream": "a bz2-compressed chunk does not decompress (damaged)",
}


def detail(text: str) -> str:
    """One line of at most _MAX_DETAIL characters, first letter lower case unless an acronym."""
    text = _REWORDED.get(text, text)
    text = re.sub(r"\('(.*?)',\)", r"\1", text)  # rosbags formats some errors' args tuples
    line = " ".join(text.split()).rstrip(".")
    if len(line) > _MAX_DETAIL:
        line = line[: _MAX_DETAIL - 3] + "..."
    if len(line) > 1 and line[0].isupper() and not line[1].isupper():
        line = line[0].lower() + line[1:]
    return line


def count_of(n: int, noun: str) -> str:
    """`1 topic`, `3 topics`: notes are read by people."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def _failed_assert(err: AssertionError) -> str:
    frames = traceback.extract_tb(err.__traceback__)
    if not frames:
        return "a consistency check of the reader failed (damaged or an unsupported variant)"
    last = frames[-1]
    for (module, func), words in _ASSERTS.items():
        if module in last.filename and func == last.name:
            return words
    return (f"a consistency check of the reader failed in {last.name}() "
            "(damaged or an unsupported variant)")


# Reader failures by type, first match wins: each a phrase for "<path>: <phrase>".
_BY_TYPE: tuple[tuple[tuple[type[BaseException], ...], Callable[[BaseException], str]], ...] = (
    ((AnyReaderError, Ros1ReaderError, Ros2ReaderError),
     lambda e: detail(str(e)) or f"the reader rejected it ({type(e).__name__})"),
    ((AssertionError,), lambda e: _failed_assert(e)),  # type: ignore[arg-type]
    ((OverflowError, MemoryError),
     lambda e: "a record claims an impossible length or offset (damaged)"),
    ((struct.error, EOFError), lambda e: "a record ends before its fields do (truncated or "
                                         "damaged)"),
    ((UnicodeDecodeError,), lambda e: "a name or text field is not valid UTF-8 (damaged)"),
    ((sqlite3.DatabaseError,),
     lambda e: f"the sqlite3 database cannot be read ({detail(str(e))})"),
    ((TypesysError,), lambda e: f"a message definition cannot be used ({detail(str(e))})"),
    ((SerdeError,), lambda e: f"a message does not decode ({detail(str(e))})"),
    ((KeyError,),
     lambda e: f"a field it needs is missing or unreadable ({detail(str(e))}; damaged)"),
    ((OSError,), lambda e: detail(getattr(e, "strerror", None) or str(e))),
)


def describe(err: BaseException) -> str:
    """What is wrong, as a phrase to put after `<path>: `; never empty, never two lines."""
    name = type(err).__name__
    if name in _BY_NAME:
        return _BY_NAME[name]
    if isinstance(err, RuntimeError) and str(err).startswith("LZ4"):
        return "an lz4-compressed chunk does not decompress (damaged)"
    for types, phrase in _BY_TYPE:
        if isinstance(err, types):
            return phrase(err)
    text = detail(str(err))
    return f"unreadable ({name}: {text})" if text else f"unreadable ({name})"
