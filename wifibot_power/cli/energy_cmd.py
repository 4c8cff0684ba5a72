"""`wbpower energy` (see shared/spec/cli.md)."""
