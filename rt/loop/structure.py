"""An imported structure (a superelement file, plant.superelement) as the loop's plant: which
file, its SHA-256 and the interface's coarsening (``Structure``), the plant built from it for the
loop, and the record a log keeps of it (its "structure" metadata), from which a replay rebuilds it.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Structure:
    """The imported structure of a loop: the superelement file (absolute path), the SHA-256 of its
    bytes, the number of contact points its interface is coarsened to (0: as read) and how the
    points are grouped (plant.superelement.CLUSTERINGS)."""
    path: str
    sha256: str
    clusters: int = 0
    clustering: str = "footprint"

    def record(self) -> str:
        """The log's "structure" metadata (JSON: file, sha256, clusters, clustering)."""
        return json.dumps({"file": self.path, "sha256": self.sha256, "clusters": self.clusters,
                           "clustering": self.clustering})


def file_sha256(path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def structure_of(path, clusters: int = 0, clustering: str = "footprint") -> Structure:
    """The ``Structure`` of the superelement file at path; ValueError naming the file if it is
    missing, for clusters < 0 or an unknown clustering."""
    from frictionrt.plant.superelement import CLUSTERINGS
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"--structure {path}: {'not a file' if p.exists() else 'no such file'}")
    if clusters < 0:
        raise ValueError(f"--clusters {clusters}: must be >= 0 (0: the interface as read)")
    if clustering not in CLUSTERINGS:
        raise ValueError(f"--clustering {clustering}: must be one of {', '.join(CLUSTERINGS)}")
    return Structure(str(p.resolve()), file_sha256(p), int(clusters), clustering)


def logged_structure(meta: dict[str, str], override=None, log_path="") -> Structure | None:
    """The ``Structure`` a log's metadata records (None: the built-in beams), its file found at the
    recorded path or at ``override`` (a moved file); ValueError naming the log if the file is
    missing or its SHA-256 differs from the recorded one (another structure)."""
    if "structure" not in meta:
        if override is not None:
            raise ValueError(f"{log_path}: --structure {override}: the log is a run of the built-in beams")
        return None
    rec = json.loads(meta["structure"])
    path = Path(override if override is not None else rec["file"])
    if not path.is_file():
        raise ValueError(f"{log_path}: the run's structure {path} is not found; give its file with --structure FILE")
    got = file_sha256(path)
    if got != rec["sha256"]:
        raise ValueError(f"{log_path}: {path} is not the run's structure (SHA-256 {got[:12]}..., the log records "
                         f"{rec['sha256'][:12]}...)")
    # a log without "clustering" was written when k-means on the coordinates was the only grouping
    return Structure(str(path.resolve()), got, int(rec.get("clusters", 0)), rec.get("clustering", "coordinates"))


def build_structure_plant(cfg, structure: Structure):
    """The plant of ``structure`` with cfg's interface, step and damping (plant.se_plant.build_se_plant),
    the adaptive bolt's reference separation at the loop's rest force F_N1 = actuator.F0_N (0 V).
    ValueError (one line) for a bad file (plant.superelement.SuperelementError) or a static
    equilibrium that fails."""
    from frictionrt.plant.se_plant import build_se_plant
    from frictionrt.plant.se_coarsen import coarsen_structure
    from frictionrt.plant.superelement import SuperelementError, load
    try:
        se = coarsen_structure(load(structure.path), structure.clusters, cfg, structure.clustering)
        return build_se_plant(se, cfg, F_N1=cfg.actuator.F0_N)
    except (SuperelementError, RuntimeError) as exc:
        raise ValueError(f"--structure {structure.path}: {exc}") from None
