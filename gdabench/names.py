"""File names made from labels (designer, environment), which users type and may make arbitrarily long."""

from __future__ import annotations

import hashlib
import re

#: longest name made from a label: file systems allow 255 bytes, and prefixes and suffixes are added to it
MAX_NAME = 100


def file_name(text: str, allowed: str = "A-Za-z0-9_.=-") -> str:
    """``text`` made safe as (part of) a file name: other characters become ``_``; a long one is cut
    and ends with a hash of the whole, so two long labels that differ only at the end stay apart."""
    safe = re.sub(f"[^{allowed}]+", "_", text)
    if len(safe) <= MAX_NAME:
        return safe
    return f"{safe[:MAX_NAME - 13]}-{hashlib.sha256(text.encode()).hexdigest()[:12]}"
