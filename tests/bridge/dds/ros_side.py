"""Run under a ROS 2 Python (never kartci's): what the installed ROS 2 makes of kartci's messages.

stdin: {"<pkg>/msg/<T>": "<CDR hex>", ...}; stdout: for each type installed here, its RIHS01
hash from `share/<pkg>/msg/<T>.json` and `serialize_message(deserialize_message(bytes))` in hex
(rclpy's own bytes for the message kartci sent; an error text where rclpy cannot read it).
Types not installed here are left out. Imports no kartci code.
"""

from __future__ import annotations

import importlib
import json
import os
import sys
from pathlib import Path

from rclpy.serialization import deserialize_message, serialize_message


def description(typename: str) -> Path | None:
    """`share/<pkg>/msg/<T>.json` in $AMENT_PREFIX_PATH or this Python's prefix."""
    package, kind, name = typename.split("/")
    prefixes = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    for prefix in [*prefixes, sys.prefix]:
        path = Path(prefix) / "share" / package / kind / f"{name}.json"
        if path.exists():
            return path
    return None


def main() -> int:
    """One answer per installed type."""
    out: dict[str, dict[str, str]] = {}
    for typename, data in json.load(sys.stdin).items():
        path = description(typename)
        if path is None:
            continue
        package, kind, name = typename.split("/")
        cls = getattr(importlib.import_module(f"{package}.{kind}"), name)
        try:
            again = serialize_message(deserialize_message(bytes.fromhex(data), cls)).hex()
        except Exception as err:  # rclpy cannot read kartci's bytes: say so, per type
            again = f"error: {type(err).__name__}: {err}"
        out[typename] = {"hash": json.loads(path.read_text())["type_hashes"][0]["hash_string"],
                         "cdr": again}
    json.dump(out, sys.stdout)
    return 0


if __name__ == "__main__":
    sys.exit(main())
