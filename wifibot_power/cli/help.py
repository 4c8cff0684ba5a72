"""What `wbpower --help` and each `wbpower COMMAND --help` say beyond the options: a short
line per command for the command list (never cut mid-phrase), and an Examples block (as
httpie and ruff have). `tests/test_cli_help.py` checks every command has both and that every
example parses."""

from __future__ import annotations

#: command -> its line in `wbpower --help` (whole; click only wraps it)
SHORT_HELP = {
    "inspect": "What is in each log: samples, period, power, energy, problems.",
    "segment": "Split one log into phases (idle, accel, cruise, decel).",
    "fit": "Fit the paper's power models to logs, with 95% intervals.",
    "energy": "Energy of a trip in N stop-and-go steps (paper Eq. 5/6).",
    "lifetime": "Relay network lifetime (paper Eq. 7-11, Figure 7).",
    "diagnose": "What the paper's model gets wrong, why, and the gain.",
    "simulate": "Write synthetic logs of a simulated robot, with truth.",
    # for branch `report` (its command registers with **command_help("report"))
    "report": "Figures and one report.html: traces, fits, diagnosis.",
    "export": "The drive model as Open-RMF or Gazebo power parameters.",
    "docs": "Read the documentation pages: causes, log formats, outputs.",
}

#: command -> (example arguments after `wbpower COMMAND`, what it does)
EXAMPLES: dict[str, list[tuple[str, str]]] = {
    "inspect": [
        ("sample_logs/", "every log in a folder"),
        ("log.csv --supply-voltage 12.6", "a log of current only, at 12.6 V"),
        ("sample_logs/ --json", "one JSON document, for scripts"),
        ("sample_logs/ -o out/", "also out/logs.parquet, a row per log"),
    ],
    "segment": [
        ("sample_logs/v0.50_d10_s10_r1.csv.gz", "the phases of one run"),
        ("run.csv --json", "the same as JSON, with the doubts"),
        ("run.csv -o out/", "also out/phases.parquet (with run_id, doubts)"),
    ],
    "fit": [
        ("sample_logs/", "the paper's table from a folder of logs"),
        ("logs/ -o results/", "also runs.parquet, phases.parquet, model.json"),
        ("logs/ --cache .wbcache -j 4", "a second run skips parsing; 4 workers"),
        ("logs/ --json", "for CI (model_complete: false if a slope is not fitted)"),
    ],
    "energy": [
        ("--speed 0.8 --dist 10 --steps 10", "10 m in 10 steps at 0.8 m/s"),
        ("--speed 0.5 --dist 2 --model results/model.json", "with a fitted model"),
        ("--sweep speed", "the paper's Figure 5 as a table"),
    ],
    "lifetime": [
        ("--rate 100", "the relay scenario at 100 Mbit/s"),
        ("--rate 54 --sweep e0b", "the paper's Figure 7 (b): against B's energy"),
        ("--rate 10 --embedded-scale 0.5 --wide", "a half-power robot, one wide table"),
    ],
    "diagnose": [
        ("sample_logs/", "what the paper's model misses on these logs"),
        ("logs/ -o out/ --fail-on-discrepancy", "for CI: exit 1 on any finding"),
        ("logs/ --model results/model.json", "against a stored model"),
    ],
    "simulate": [
        ("-o logs/", "the paper's grid (about 1 GB of CSV)"),
        ("-o logs/ --effect decel_phase=0.3 --seed 1", "a robot that needs 0.3 s to stop"),
        ("-o small/ --sample-period 0.001024 --compress zst", "smaller, zstd-compressed"),
        ("-o free/ --drive free --realism field", "free driving: turns, stops, two surfaces"),
    ],
    "report": [
        ("sample_logs/ -o out/report", "out/report/report.html, opens offline"),
        ("logs/ -o out/ --jobs 2", "figures drawn by 2 workers"),
    ],
    "export": [
        ("--model out/model.json --to rmf --turn-rate 0.6", "the fleet config's YAML"),
        ("--model m.json --to gazebo --voltage 24 --capacity 20", "the battery <plugin>"),
        ("--model m.json --to rmf --moment-of-inertia 9 --json", "JSON, for CI"),
    ],
    "docs": [
        ("", "the pages, each with its title"),
        ("causes", "the causes diagnose names, and how a cause earns its name"),
        ("log-format", "the log formats wbpower reads, and their columns"),
    ],
}


def epilog(command: str) -> str:
    """The Examples block of `command`'s help (`\\b`: click keeps its lines as written)."""
    lines = []
    for args, what in EXAMPLES[command]:
        lines += [f"  # {what}", f"  wbpower {command} {args}".rstrip()]
    return "\b\nExamples:\n" + "\n".join(lines)


def command_help(command: str) -> dict[str, str]:
    """Keyword arguments of `app.command(command, ...)`: its short help and Examples."""
    return {"short_help": SHORT_HELP[command], "epilog": epilog(command)}
