"""`wbpower fit` (see shared/spec/cli.md)."""
