"""`wbpower diagnose` (see shared/spec/cli.md)."""
