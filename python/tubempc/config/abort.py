"""The [abort] section: the certified safe abort (docs/model.md M52 "Safe abort", issue #43; tubempc.sim.abort,
cpp/include/tubempc/control/abort.hpp). The ``on_*`` fields are ``control::AbortSettings``'s, of the same names."""

from __future__ import annotations

from dataclasses import dataclass, field

from .fields import AT_LEAST_ONE, NONNEGATIVE, POSITIVE, boolean, integer, quantity


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
