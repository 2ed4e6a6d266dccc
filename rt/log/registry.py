"""The signals the file format knows and their names at the file boundary.

``SIGNALS`` is the registry of every signal: the paper's symbol (``<point>`` stands for a point
name of plant.points, ``<screw>`` for a screw name of plant.screws, ``<j>`` for a contact pair
index 0, 1, ...), unit, owner (topic /owner),
the instant row k holds, its meaning and its ROS 2 field type. Inside the project (numpy
columns, the ``signals`` tuples, the kernels) a signal is named by its symbol; in a file (MCAP
fields, .rrd series, JSON keys of a log's layout) by its ROS 2 field name, one rule both ways:

    ros2_field(name)  = FIELD_EXCEPTIONS[name] if listed, else name.lower()
                        (F_N1 -> f_n1, V_cmd -> v_cmd, E_fric -> e_fric; W_exc -> work_exc because
                        w_exc is the displacement at the point exc, W_screw -> work_screw alike)
    signal_name(field, owner) = the registry's symbol whose ros2_field is ``field`` (patterns
                        filled in: w_tip -> w_tip, f_n_3 -> f_n_3), else ``field`` itself; only
                        needed for a file without the "signals" record (whose names are exact),
                        where a point name with capitals comes back lower-cased

The result must match ROS 2's field rule ``FIELD_RE`` (rosidl; Foxglove's parser and
``mcap_ros2`` enforce it) and must not be one of ``RESERVED`` (the fields every message carries
first); a signal that breaks either, or two signals of one layout with one field, are refused
with a ValueError (``field_names``). A new signal needs an entry here only if lower-casing
collides (then an exception) or if its value is an integer or a flag (then its type).
"""
from __future__ import annotations

import re
from typing import NamedTuple

FIELD_RE = re.compile(r"(?!.*__)(?!.*_\Z)[a-z][a-z0-9_]*\Z")
RESERVED = ("stamp", "tick")    # builtin_interfaces/Time stamp, int64 tick: first in every message
FIELD_EXCEPTIONS = {"W_exc": "work_exc", "W_screw": "work_screw"}   # lower-casing would collide


class Entry(NamedTuple):
    """One signal of the format."""
    name: str      # the paper's symbol (ros2_field gives the file's field); <point> = a plant point name, <j> = a contact pair index
    unit: str
    owner: str     # topic /owner
    at: str        # the instant (or interval) row k holds
    meaning: str
    type: str = "float64"   # its ROS 2 field type in the file (FIELD_TYPES)


SIGNALS = (
    Entry("F_exc", "N", "rt", "[t_k, t_k+1)", "excitation force at test.excitation_x_m, +z (up), held over the tick"),
    Entry("tick_ns", "ns", "rt", "tick k", "execution time of the loop's tick (simulation only)", "int64"),
    Entry("late_ns", "ns", "rt", "tick k", "lateness of the tick's start against its deadline (paced runs; 0 offline)", "int64"),
    Entry("fault_code", "-", "rt", "tick k", "supervisor: code of the first failing check of the tick, 0 none "
          "(docs/reliability.md)", "int32"),
    Entry("fault_latched", "-", "rt", "tick k", "supervisor: code of the latched fault, 0 while active", "int32"),
    Entry("passive", "-", "rt", "tick k", "supervisor: 1 while it commands passive F_min instead of the law's F_set", "bool"),
    Entry("a_tip_meas", "m/s^2", "sensors", "t_k", "accelerometer at test.sensor_positions_m.a_tip_meas (tip), "
          "after anti-alias filter, noise and ADC"),
    Entry("a_frf_meas", "m/s^2", "sensors", "t_k", "accelerometer at test.sensor_positions_m.a_frf_meas (FRF point), "
          "after anti-alias filter, noise and ADC"),
    Entry("v_tip_meas", "m/s", "sensors", "t_k", "tip velocity: the controller's leaky integral of a_tip_meas "
          "(corner sensors.velocity_corner_hz)"),
    Entry("F_strain", "N", "sensors", "t_k", "adaptive screw bolt force, strain gauge, after noise and ADC"),
    Entry("F_cell", "N", "sensors", "t_k", "adaptive screw bolt force, piezo force cell, after noise and ADC"),
    Entry("u_rel_hat", "m", "observer", "t_k", "estimated tangential relative displacement at the adaptive screw"),
    Entry("v_rel_hat", "m/s", "observer", "t_k", "estimated relative velocity at the adaptive screw"),
    Entry("innovation", "m/s", "observer", "t_k", "observer innovation (measured minus predicted tip velocity); "
          "0 with the oracle"),
    Entry("f_r_hat", "N", "observer", "t_k", "observer's friction force estimate; 0 with the oracle"),
    Entry("F_set", "N", "tracking", "t_k", "the control law's bolt force setpoint F*"),
    Entry("u0", "m", "tracking", "t_k+1", "RT1 amplitude of u_rel (hysteresis law; tracking.rt1)"),
    Entry("F_set_filtered", "N", "tracking", "t_k", "F* after the setpoint prefilter: the force tracking's setpoint"),
    Entry("V_cmd", "V", "tracking", "[t_k, t_k+1)", "voltage command to the DAC (amplifier input), held over the tick"),
    Entry("saturated", "-", "tracking", "t_k", "+1 command at V_max, -1 at V_min, 0 inside", "int8"),
    Entry("F_stack", "N", "actuator", "t_k+1", "the stack's force at zero separation of the beams (simulation only)"),
    Entry("V_dac", "V", "actuator", "[t_k, t_k+1)", "DAC output (16 bit, held)"),
    Entry("v_f", "V", "actuator", "t_k+1", "output of the 30 kHz analog low-pass"),
    Entry("V_a", "V", "actuator", "t_k+1", "piezo stack voltage (amplifier output)"),
    Entry("i", "A", "actuator", "last substep", "piezo stack current, C dV_a/dt, mean over the last actuator "
          "substep before t_k+1"),
    Entry("P", "W", "actuator", "last substep", "amplifier output power V_a i, mean over the last substep"),
    Entry("E", "J", "actuator", "t_k+1", "energy delivered by the amplifier since the start, integral of abs(V_a i) dt"),
    Entry("F_strain_a", "N", "actuator", "t_k+1", "strain gauge analog output (before noise and ADC)"),
    Entry("F_cell_a", "N", "actuator", "t_k+1", "force cell analog output (before noise and ADC)"),
    Entry("w_<point>", "m", "plant", "t_k+1", "transverse displacement w at the point"),
    Entry("v_<point>", "m/s", "plant", "t_k+1", "transverse velocity w' at the point"),
    Entry("a_<point>", "m/s^2", "plant", "t_k+1", "transverse acceleration w'' at the point"),
    Entry("u_rel", "m", "plant", "t_k+1", "tangential relative displacement at the adaptive screw"),
    Entry("v_rel", "m/s", "plant", "t_k+1", "tangential relative velocity at the adaptive screw"),
    Entry("g_n_<j>", "m", "plant", "t_k+1", "normal gap of contact pair j (j = 0 at interface.x_start_m)"),
    Entry("g_t_<j>", "m", "plant", "t_k+1", "tangential relative displacement of contact pair j"),
    Entry("f_n_<j>", "N", "plant", "t_k+1", "normal contact force of pair j"),
    Entry("f_t_<j>", "N", "plant", "t_k+1", "tangential (Jenkins) force of pair j"),
    Entry("E_fric", "J", "plant", "t_k+1", "energy dissipated by friction since the start"),
    Entry("E_damp", "J", "plant", "t_k+1", "energy dissipated by structural and interface damping"),
    Entry("W_exc", "J", "plant", "t_k+1", "work of the excitation force"),
    Entry("W_screw", "J", "plant", "t_k+1", "work of the adaptive screw force"),
    Entry("newton_iter", "-", "plant", "tick k", "contact Newton iterations of the tick (-1: a failed solve)", "int32"),
    Entry("substep_fallbacks", "-", "plant", "tick k", "substeps redone on finer substeps in the tick", "int32"),
    Entry("abar_<point>", "m/s^2", "plant", "[t_k, t_k+1]", "mean acceleration over the tick, what the "
          "accelerometers sample"),
    Entry("g_bolt_<screw>", "m", "plant", "t_k+1", "the beams' separation at the screw (> 0 opening)"),
    Entry("F_N1", "N", "plant", "t_k+1", "adaptive screw (bolt) force: F_stack (held) + k (g - g_ref) "
          "(true, simulation only)"),
    Entry("F_bolt_<screw>", "N", "plant", "t_k+1", "force of an ordinary bolt, F_N + k (g - g_ref)"),
    Entry("dF_N1", "N", "plant", "t_k+1", "the adaptive bolt's response to the separation, k (g - g_ref)"),
)


def _pattern(name: str) -> re.Pattern:
    rx = re.escape(name)
    for token, part in (("<point>", r"[A-Za-z0-9_]+"), ("<screw>", r"[A-Za-z0-9_]+"), ("<j>", r"[0-9]+")):
        rx = rx.replace(re.escape(token), part)
    return re.compile(rx + r"\Z")


_EXACT = {(e.owner, e.name): e for e in SIGNALS if "<" not in e.name}
_PATTERNS = [(e, _pattern(e.name)) for e in SIGNALS if "<" in e.name]


def entry_of(owner: str, name: str) -> Entry | None:
    """The registry entry of a signal: an exact name first (u_rel is not v_<point>), then a pattern."""
    e = _EXACT.get((owner, name))
    if e is not None:
        return e
    return next((e for e, rx in _PATTERNS if e.owner == owner and rx.match(name)), None)


def lower_rule(name: str) -> str:
    """FIELD_EXCEPTIONS[name] if listed, else name.lower() (placeholders kept: w_<point>)."""
    return FIELD_EXCEPTIONS.get(name, name.lower())


def ros2_field(name: str) -> str:
    """The ROS 2 field name of a signal (module docstring); ValueError if it is not a valid one."""
    field = lower_rule(name)
    if not FIELD_RE.match(field) or field in RESERVED:
        raise ValueError(f"signal {name!r} has no valid ROS 2 field name: {field!r} must match "
                         f"{FIELD_RE.pattern} and not be one of {list(RESERVED)}")
    return field


def field_names(signals) -> tuple[str, ...]:
    """The ROS 2 field of each (name, unit, owner) signal; ValueError if two share one."""
    out = tuple(ros2_field(n) for n, _, _ in signals)
    seen: dict[tuple[str, str], str] = {}
    for (name, _, owner), field in zip(signals, out):
        other = seen.setdefault((owner, field), name)
        if other != name:
            raise ValueError(f"signals {other!r} and {name!r} of /{owner} both map to the field {field!r}: "
                             "add one to rt.log.registry.FIELD_EXCEPTIONS")
    return out


def _field_pattern(entry: Entry) -> re.Pattern:
    """The fields of a pattern entry with its placeholder captured as "p": w_<point> -> w_(?P<p>...)."""
    head, _, rest = entry.name.partition("<")
    hole, _, tail = rest.partition(">")
    p = "[0-9]+" if hole == "j" else "[a-z0-9_]+"
    return re.compile(re.escape(head.lower()) + f"(?P<p>{p})" + re.escape(tail.lower()) + r"\Z")


_BY_FIELD = {(e.owner, ros2_field(e.name)): e.name for e in SIGNALS if "<" not in e.name}
_FIELD_PATTERNS = [(e, _field_pattern(e)) for e in SIGNALS if "<" in e.name]


def signal_name(field: str, owner: str) -> str:
    """The signal a ROS 2 field of /owner stands for (module docstring): the inverse of ros2_field."""
    name = _BY_FIELD.get((owner, field))
    if name is not None:
        return name
    for e, rx in _FIELD_PATTERNS:
        m = rx.match(field) if e.owner == owner else None
        if m:
            head, _, rest = e.name.partition("<")
            return head + m["p"] + rest.partition(">")[2]
    return field


def field_type(name: str, owner: str) -> str:
    """The ROS 2 type of a signal's field: the registry's, float64 for a signal it does not know."""
    e = entry_of(owner, name)
    return "float64" if e is None else e.type
