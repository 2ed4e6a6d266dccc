"""Writing outputs so that nothing is lost: a folder replaced as a whole, never half-written."""
from __future__ import annotations

from pathlib import Path


def write_folder(out, force: bool, write):
    """Run ``write()``, which creates the folder ``out``, and return its result. With ``force`` an
    existing ``out`` is moved aside first (a hidden sibling), removed once ``write`` returned and put
    back if it raised: --force replaces a folder as a whole and never loses the old one to a failed run."""
    import os
    import shutil
    out = Path(out)
    aside = None
    if force and out.exists():
        aside = out.with_name(f".{out.name}.replaced-{os.getpid()}")
        os.replace(out, aside)
    try:
        result = write()
    except BaseException:
        if aside is not None and not out.exists():
            os.replace(aside, out)
        raise
    if aside is not None:
        shutil.rmtree(aside) if aside.is_dir() else aside.unlink()
    return result
