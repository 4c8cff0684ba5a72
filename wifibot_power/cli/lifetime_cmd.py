"""`wbpower lifetime` (see shared/spec/cli.md)."""
