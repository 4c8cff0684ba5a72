"""`wbpower segment` (see shared/spec/cli.md)."""
