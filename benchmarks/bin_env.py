"""The environment for running the package's binaries from a --bin-dir (run_mrclam,
run_experiments).

Binaries copied out of a build tree keep their RPATH to it, so after a rebuild they would load
the rebuilt libraries, with another ABI or another behaviour, and a study run from a fixed copy
would break or change half way. The libraries beside the binaries (bins itself, or its parent as
in devel/lib/rbpf_slam) therefore come first on LD_LIBRARY_PATH.
"""

import os
from pathlib import Path


def prefer_libraries_beside(bins):
    """Puts the directories of bins (a Path) that hold lib*.so first on this process's
    LD_LIBRARY_PATH, which its subprocesses inherit. Returns the directories added."""
    bins = Path(bins)
    dirs = [str(d) for d in (bins, bins.parent) if d.is_dir() and any(d.glob("lib*.so"))]
    if dirs:
        rest = [p for p in os.environ.get("LD_LIBRARY_PATH", "").split(os.pathsep) if p]
        os.environ["LD_LIBRARY_PATH"] = os.pathsep.join(dirs + rest)
    return dirs
