"""The kernels' version: a number raised by every change that moves the bits a run computes.

Every log records ``KERNEL_VERSION`` (metadata "kernel_version"); a replay of a log recorded with
another version reports the changes in between (``changes_since``), so a replay that is no longer
bit-exact says why. The source hash (``jit_cache.source_hash``) changes with every edit of a
kernel file; this number changes only when the numbers change, and says how.

To change the bits: raise ``KERNEL_VERSION`` by one and add a line to ``CHANGES`` that names the
kernel and what now differs; regenerate the determinism fixture (tests/fixtures/make_fixtures.py).
"""
from __future__ import annotations

KERNEL_VERSION = 5

# version -> what changed the bits from the version before it. Version 1 is the first recorded;
# a log without a record (version 0) was computed by version 1's kernels or older ones, and its
# "kernels" source hash tells which.
CHANGES: dict[int, str] = {
    2: "observer Newton (observer/step.py _implicit_v, the C export's implicit_v) stops on convergence before "
       "the bracket test and on an exact zero of the residual; the observer's next state differs in the last "
       "bits where the old iteration bisected past its converged root",
    3: "amplitude-following observer (observer/amplitude_step.py _amplitude_step, the C export's amplitude_step): "
       "a participation per mode and grid amplitude (the blocks' seventh column) scales the mode's rows of C_u, C_v "
       "and its friction input, mode 5's from the plant's U_rel / V_tip growth with the amplitude; the outputs are "
       "summed per mode after the interpolation; the paper's observer and the oracle unchanged",
    4: "superelement contact Newton (plant/se_plant.py _se_substep): after a rejected full step the line search "
       "first tries the step to the first stick/slip/open branch change of the end-point law (_first_kink); an "
       "imported structure's runs differ from the first tick whose full step is rejected; the built-in 2-D "
       "plant's kernel (plant.newmark) is unchanged",
    5: "superelement contact Newton (plant/se_plant.py _se_substep): each substep's Newton starts from the previous "
       "substep's gaps (was: the fixed-point guess g_pred + W Lambda(g0, g0)), a kink step that reduced |r| by "
       "less than 1 % is not followed by another (KINK_PROGRESS), and the Jacobian J = I - W D is built block by "
       "block with unsigned indices; an imported structure's runs differ in the bits below the "
       "Newton tolerance (and in the iteration counts) from the first tick; the built-in 2-D plant's kernel "
       "(plant.newmark) is unchanged",
}


def logged_version(meta: dict[str, str]) -> int:
    """The kernel version a log's metadata records; 0 for a log that records none."""
    try:
        return int(meta.get("kernel_version", "0"))
    except ValueError:
        return 0


def changes_since(version: int) -> list[str]:
    """What changed the kernels' bits after ``version``: ["v2: ...", ...]; empty when the bits
    are those of this version (versions 0 and 1 compute the same)."""
    if version > KERNEL_VERSION:
        return [f"the log is from a newer frictionrt (kernel version {version} > {KERNEL_VERSION})"]
    return [f"v{v}: {CHANGES[v]}" for v in range(max(version, 1) + 1, KERNEL_VERSION + 1)]
