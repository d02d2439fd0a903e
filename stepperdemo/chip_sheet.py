"""What one chip has: its profile and, per room, the figures that room keeps for it.

A chip's figures are split by who uses them (:mod:`fas.arch` names the rooms): the
library's profile, the simulator's timing, QuickStep's and the user outputs'
figures, StepperDemo's build.  Each room looks its own table up by the profile;
:func:`chip_sheet` gathers them back into one :class:`ChipSheet`, the answer to
"what does this chip have".  It lives in the console because only here may all
rooms be seen at once (``fas`` imports neither ``fas.sim`` for its tables nor
``stepperdemo``).

    python -m stepperdemo.chip_sheet            # every profile: name and title
    python -m stepperdemo.chip_sheet esp32 ...  # each named chip's figures, by room
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import dataclass, fields

from fas.arch import PROFILES, Profile, get_profile
from fas.output_figures import NO_OUTPUTS, OutputFigures, output_figures
from fas.quickstep.figures import NO_QUICKSTEP, QuickStepFigures, quickstep_figures
from fas.sim.timing import SimTiming, sim_timing

from . import messages as msg
from .demo.build import DemoBuild, demo_build


@dataclass(frozen=True)
class ChipSheet:
    """Everything the project knows about one chip, room by room."""

    chip: Profile  # the library's figures (fas.arch)
    sim: SimTiming  # the simulated machine's timing (fas.sim.timing)
    quickstep: QuickStepFigures  # QuickStep's timers and costs (fas.quickstep.figures)
    outputs: OutputFigures  # the user outputs' pins and PWM timers (fas.output_figures)
    demo: DemoBuild  # StepperDemo's build (stepperdemo.demo.build)


# the rooms in the order of ChipSheet: its field and the module of its table
ROOMS: tuple[tuple[str, str], ...] = (
    ("chip", "fas.arch"),
    ("sim", "fas.sim.timing"),
    ("quickstep", "fas.quickstep.figures"),
    ("outputs", "fas.output_figures"),
    ("demo", "stepperdemo.demo.build"),
)
# what a room answers for a chip it has no entry for
_EMPTY: dict[str, object] = {"quickstep": NO_QUICKSTEP, "outputs": NO_OUTPUTS}


def chip_sheet(profile: Profile | str) -> ChipSheet:
    """The figures of every room for ``profile`` (a profile or its name)."""
    p = get_profile(profile)
    return ChipSheet(p, sim_timing(p), quickstep_figures(p), output_figures(p), demo_build(p))


def sheet_lines(sheet: ChipSheet) -> list[str]:
    """The sheet as text: a header, then each room's figures, one per line."""
    p = sheet.chip
    out = [msg.CHIP_SHEET_HEADER.format(name=p.name, title=p.title)]
    for room, module in ROOMS:
        figures = getattr(sheet, room)
        out.append(msg.CHIP_SHEET_ROOM.format(room=room, module=module))
        if figures is _EMPTY.get(room):
            out.append(msg.CHIP_SHEET_NONE.format(room=room))
            continue
        for f in fields(figures):
            out.append(msg.CHIP_SHEET_FIGURE.format(field=f.name,
                                                    value=getattr(figures, f.name)))
    return out


def main(argv: Sequence[str] | None = None) -> int:
    names = list(sys.argv[1:] if argv is None else argv)
    if not names:
        for p in PROFILES.values():
            print(msg.CHIP_SHEET_LIST.format(name=p.name, title=p.title))
        return 0
    try:
        sheets = [chip_sheet(name) for name in names]
    except ValueError as err:
        print(msg.CHIP_SHEET_ERROR.format(error=err), file=sys.stderr)
        return 2
    for i, sheet in enumerate(sheets):
        if i:
            print()
        print("\n".join(sheet_lines(sheet)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
