"""Notes under a table (reasons a line each: the drive model's terms not determined) wrap at
the terminal's width, not at the table's (docs/cli-output.md)."""

from __future__ import annotations

import io

from rich.console import Console

from wifibot_power.cli.tables import Col, print_table


def test_notes_wrap_at_the_console_width_not_the_tables():
    out = io.StringIO()
    console = Console(file=out, width=80, force_terminal=False, color_system=None)
    reason = "- braking_mass_kg: " + "leaves more power open than the power varies " * 4
    print_table(
        console, "Terms", [Col("term", key=True), Col("W")], [["idle_W", "12"]], notes=reason
    )
    lines = out.getvalue().splitlines()
    table_width = max(len(line) for line in lines[:6])
    note_lines = lines[lines.index(next(ln for ln in lines if ln.startswith("- braking"))) :]
    assert table_width < 40
    assert max(len(line.rstrip()) for line in note_lines) > table_width + 20
    assert all(len(line) <= 80 for line in lines)
    assert " ".join(line.strip() for line in note_lines).split() == reason.split()
