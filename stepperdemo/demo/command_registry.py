"""Every command StepperDemo knows, registered explicitly and in this order: the
firmware's own, then QuickStep's config commands (issue 14).

A new module of commands declares a :class:`~.command_table.CommandSet` and is added
to :data:`COMMANDS` here; nothing registers itself by being imported.
"""

from __future__ import annotations

from . import commands, quickstep
from .command_table import CommandTable

COMMANDS = CommandTable(commands.FIRMWARE, quickstep.COMMANDS)
