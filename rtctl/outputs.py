"""Output files named on the command line, checked before any work: a path that cannot be
written (a directory, a path under a file, a read-only or pseudo file system such as /sys, a
name whose format the writer cannot tell) is an exit 2 naming the option — not a traceback
after the work is done, and not a run that ends without its summary."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

from rtctl.errors import ConfigError


def output_path(path, option: str, *, suffixes: tuple[str, ...] = (), default_suffix: str | None = None) -> Path:
    """``path`` made ready to be written — its folder created, a probe file written and
    removed there — or :class:`ConfigError` naming ``option``. ``suffixes``: the formats the
    writer knows (a name without one gets ``default_suffix``, and the caller reports the path
    returned)."""
    p = Path(path)

    def bad(why: str) -> ConfigError:
        return ConfigError("<command line>", option, f"a file that can be written; {why}")

    if p.is_dir():
        raise bad(f"{p} is a directory")
    if suffixes and not p.suffix and default_suffix:
        p = p.with_name(p.name + default_suffix)
    if suffixes and p.suffix.lower() not in suffixes:
        raise bad(f"{p.name} does not end in {' or '.join(suffixes)}")
    existing = next(a for a in (p.parent, *p.parent.parents) if a.exists())
    if not existing.is_dir():
        raise bad(f"{existing} is a file, not a folder")
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=p.parent, prefix=".rtctl-probe-"):
            pass
    except OSError as e:
        raise bad(f"{p.parent}: {e.strerror or e}") from None
    if p.exists() and not os.access(p, os.W_OK):
        raise bad(f"{p} is not writable")
    return p
