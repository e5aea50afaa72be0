"""The [abort] section: the certified safe abort (docs/model.md M52 "Safe abort", issue #43; tubempc.design.abort,
cpp/include/tubempc/control/abort.hpp). The ``on_*`` fields are ``control::AbortSettings``'s, of the same names."""

from __future__ import annotations

from dataclasses import dataclass, field

from .. import _core
from .fields import AT_LEAST_ONE, NONNEGATIVE, POSITIVE, boolean, integer, number, quantity

_WINDOW = (
    lambda v: 1 <= v <= _core.control.MAX_INPUT_NIS_WINDOW,
    f"in [1, {_core.control.MAX_INPUT_NIS_WINDOW}] (control::kMaxInputNisWindow)",
)


@dataclass(frozen=True, eq=False)
class AbortSection:
    """A back-away to a hover above the landing site along its local normal, planned and certified at set-up from
    entries spread over the descent (every ``entry_period`` steps); the last certified entry is the commit step,
    past which the descent lands whatever is detected. Entered by the step on an enabled detection (``on_*``) or
    on command at ``command_time``."""

    enabled: bool = field(metadata=boolean("plan the abort library at set-up and fly the abort on a detection"))
    hover_altitude: float = field(
        metadata=quantity("length", "the abort's hover above the site's surface along its normal", check=POSITIVE)
    )
    safe_altitude: float = field(
        metadata=quantity(
            "length", "an abort ends safe above this altitude (below hover_altitude), in the cone", check=POSITIVE
        )
    )
    entry_period: int = field(metadata=integer("steps between two entries of the abort library", AT_LEAST_ONE))
    command_time: float = field(metadata=quantity("time", "an abort commanded at this time (0: none)", check=NONNEGATIVE))
    on_navigation_fault: bool = field(metadata=boolean("a fault the navigation step detects enters the abort"))
    on_tube_uncertified: bool = field(metadata=boolean("a descent tube that cannot be certified enters the abort"))
    on_allocation_infeasible: bool = field(
        metadata=boolean("an allocation that cannot deliver the command's direction enters the abort")
    )
    on_estimate_outside_tube: bool = field(
        metadata=boolean("the state handed to the descent (the estimate) outside its last tube enters the abort")
    )
    on_disturbance_beyond_limit: bool = field(
        metadata=boolean("an identified disturbance set beyond disturbance_limit x the prior's enters the abort")
    )
    on_input_nis: bool = field(
        metadata=boolean("the measured inputs' innovation over a window beyond input_nis_limit enters the abort")
    )
    input_nis_window: int = field(metadata=integer("steps of the input innovation's window", _WINDOW))
    input_nis_limit: float = field(
        metadata=number(
            "the window's mean normalised innovation of the measured inputs beyond which they are not drawn from the "
            "identified distribution (about 1 when they are)",
            check=POSITIVE,
        )
    )
    disturbance_limit: float = field(
        metadata=number(
            "the identified disturbance set the descent lands under, as a ratio to the prior's (largest generalised "
            "eigenvalue); within the abort's certified envelope",
            check=POSITIVE,
        )
    )
